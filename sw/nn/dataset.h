#pragma once
/// Image datasets: CIFAR-10 binary records and MNIST idx (gzip), and where to find them.
#include <cstdint>
#include <string>
#include <vector>

#include "sw/common/config.h"
#include "sw/nn/model.h"

namespace xbarsim {

struct Dataset {
  std::string name;
  Shape shape;                  ///< C x H x W of one image
  std::vector<uint8_t> pixels;  ///< count x (C*H*W), C planes row-major
  std::vector<float> values;    ///< float images (a .npz of float32): used instead of pixels
  std::vector<int> labels;
  int first = 0;  ///< the index of image 0 in its file (a range's offset)
  bool from_calib_array = false;  ///< a .npz's calib_images (else its images)
  int count() const { return static_cast<int>(labels.size()); }
  /// x = (pixel * scale - mean[c]) / std[c] into `out` (C*H*W floats).
  void preprocess(int index, const Preprocessing& p, float* out) const;
};

/// `count` images of shape `s` with pixels uniform in 0..255 from `seed` (labels 0), for runs
/// and tests without data.
Dataset random_dataset(const Shape& s, int count, uint64_t seed);

/// CIFAR-10 binary file (1 label byte + 3072 bytes per record): records [offset, offset+count).
/// count < 0 = to the end. Throws InputError with the path on a missing/short file.
Dataset load_cifar10(const std::string& file, int offset = 0, int count = -1);

/// MNIST idx3 images + idx1 labels, gzip-compressed or plain.
Dataset load_mnist(const std::string& images, const std::string& labels, int offset = 0, int count = -1);

/// A dataset a user writes from NumPy (numpy.savez or savez_compressed): `images`, N x C x H x
/// W (or N x H x W: one channel) of uint8 pixels or float32/float64 values, and `labels`, N
/// integers; the calibration split is `calib_images` (labels optional) when the file has it,
/// else the test images themselves (`note` says so). Images [offset, offset + count).
Dataset load_npz_dataset(const std::string& path, const std::string& split, int offset, int count, std::string* note);
/// Whether a --dataset value names such a file (it ends in .npz).
bool is_npz_dataset(const std::string& name);

/// The data directory: config `data.dir`, else $XBARSIM_DATA_DIR, else the first existing of
/// ./../shared/data, ../shared/data beside the source tree. Throws InputError listing every
/// place it looked when none exists.
std::string resolve_data_dir(const ConfigTree& cfg);

/// Applies the `preprocessing.` overrides (scale, mean, std; "" = keep the model's metadata)
/// and checks that mean/std have 1 or `channels` entries and std > 0.
void apply_preprocessing_overrides(const ConfigTree& cfg, Preprocessing& pre, int channels);

/// A warning when the images are preprocessed with defaults nobody chose: the model has no
/// preprocessing metadata and the configuration sets none of preprocessing.* ("" otherwise).
std::string preprocessing_warning(const Model& m, const ConfigTree& cfg);
/// A warning when float images (a .npz of float32/float64 values) contradict the preprocessing,
/// which multiplies every value by `scale` as it would a 0..255 pixel ("" otherwise): values all
/// within [-1, 1] with a scale below 1/16 (the default 1/255: the images are already scaled, and
/// would reach the network 255 times too small), or values above 255 with a scale below 1 (more
/// than a pixel holds). `what` names the images in the sentence.
std::string dataset_range_warning(const Dataset& d, const Preprocessing& p, const std::string& what);
/// The preprocessing as the JSON reports record it.
std::string preprocessing_text(const Preprocessing& p);

/// The models directory: `data.models_dir`, else <data dir>/../models.
std::string resolve_models_dir(const ConfigTree& cfg);

/// Path of a model given as a path, or as a name in the models directory (with or without
/// .onnx), normalised ("data/../models/m.onnx" is "models/m.onnx"); throws InputError listing
/// every place it looked.
std::string find_model_file(const std::string& given, const ConfigTree& cfg);

/// Images of a named dataset ("cifar10" or "mnist") in `data_dir`; `split` is "test" or
/// "calib". CIFAR-10 calibration images are calib_batch.bin (training images). MNIST ships
/// no training images here, so its calibration split is test images 9000-9999, which
/// callers must then exclude from evaluation (see kMnistCalibrationStart).
constexpr int kMnistCalibrationStart = 9000;

/// The files of `split` of the named dataset in `data_dir` (InputError for an unknown name).
std::vector<std::string> dataset_files(const std::string& name, const std::string& data_dir, const std::string& split);

Dataset load_dataset(const std::string& name, const std::string& data_dir, const std::string& split, int offset,
                     int count);

}  // namespace xbarsim
