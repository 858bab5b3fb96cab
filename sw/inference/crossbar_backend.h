#pragma once
/// Runs every linear layer (Conv/Gemm) of a model on crossbars through AnalogLayer
/// (dense mapping: the im2col rows are the crossbar input vectors, one per iteration).
#include <functional>
#include <memory>
#include <vector>

#include "sw/analog/analog_layer.h"
#include "sw/nn/dataset.h"
#include "sw/nn/network.h"

namespace xbarsim {

/// Per-layer input ranges and calibration vectors gathered from software activations.
struct LayerStatistics {
  double x_max = 0;      ///< the inputs' full scale (ranging.inputs; the DAC clips above it)
  double input_max = 0;  ///< largest |input| over the calibration images
  double input_clipped = 0;  ///< fraction of the sampled inputs' values above x_max
  bool signed_inputs = false;
  Eigen::MatrixXd samples;         ///< up to `max_samples` im2col rows (real inputs)
  Eigen::VectorXd out_lo, out_hi;  ///< per output channel: range of the software outputs
  /// Per output channel: the software outputs' mean (bias included) over the first
  /// CrossbarBackend::kBiasImagesMax calibration images, what the bias correction aims at.
  Eigen::VectorXd bias_mean;
};

class CrossbarBackend : public LinearBackend {
 public:
  CrossbarBackend(const Model& m, const AnalogConfig& cfg);

  /// Runs the software model on the calibration images, then maps, converts and
  /// calibrates every layer. `progress(done, total)` is called per programmed layer.
  void program(const Dataset& calib, int max_samples = 2048, const std::function<void(int, int)>& progress = nullptr);

  /// Gives the programmed layers the readout of `cfg` (AnalogLayer::set_readout: its ADCs and
  /// whether it calibrates; programs_alike) without programming them again: the backend then
  /// equals one constructed with `cfg` and programmed on the same images, bit for bit.
  /// `progress(done, total)` per layer. std::invalid_argument when `cfg` does not program alike
  /// or nothing is programmed; on an error every layer keeps its readout.
  void set_readout(const AnalogConfig& cfg, const std::function<void(int, int)>& progress = nullptr);
  /// The configuration the layers are programmed and read out with.
  const AnalogConfig& config() const { return cfg_; }

  /// The layers' crossbars, mapping and input slicing without programming them (timing-only
  /// simulation: timing and action counts do not depend on the conductances); inputs are
  /// signed where the network can make them negative. multiply() must not be called.
  void structure_only();

  /// The dataset index of the image the calling thread runs next (run_image on this backend):
  /// it keys the read noise of every read, so each image draws the same on any thread count.
  static void set_image(uint64_t image);

  void multiply(int layer, const RowMatrixXf& cols, Eigen::MatrixXf& out) const override;
  /// Quantizes the activation once (DAC codes; zero padding stays zero), then im2col.
  void multiply_activation(int layer, const LinearLayer& L, const float* chw, RowMatrixXf& scratch,
                           Eigen::MatrixXf& out) const override;

  /// The bias correction's calibration images (the first of the set): L passes, each ending at
  /// its layer, over this many images.
  static constexpr int kBiasImagesMax = 64;
  /// The image ids the bias passes read with (read noise): calibration image k is kBiasImages + k.
  static constexpr uint64_t kBiasImages = 1ull << 63;

  /// The configuration of layer l: `c` with the converters of a layer that reads the image or
  /// not (ConvertersSpec::for_layer, converters.image_bits).
  AnalogConfig layer_config(const AnalogConfig& c, int l) const;

  const AnalogLayer& layer(int l) const { return layers_.at(l); }
  const LayerStatistics& statistics(int l) const { return stats_.at(l); }
  int layers() const { return static_cast<int>(layers_.size()); }

 private:
  /// Software pass over `calib`: input ranges, output ranges, sampled im2col rows.
  void gather_statistics(const Dataset& calib, int max_samples);
  /// One unprogrammed AnalogLayer per linear layer, from stats_ (its input range and signedness).
  void make_layers();
  /// Builds and programs one AnalogLayer per linear layer (in parallel, deterministic).
  void program_layers(const std::function<void(int, int)>& progress);
  /// Gives the programmed layers the readout of `target` (AnalogLayer::set_readout); with
  /// ranging.bias_correction the output offsets are measured first, at t = 0 (or at
  /// device.time_s when the compensation recalibrates there).
  void read_out_layers(const AnalogConfig& target, const std::function<void(int, int)>& progress);
  /// Bias correction (ranging.bias_correction): layer by layer in network order, a pass of the
  /// crossbars over the first kBiasImagesMax calibration images up to the layer moves its output
  /// offsets by the software's mean output per channel minus the crossbars' (so a layer's
  /// correction includes what the corrected layers before it shift: the empirical bias
  /// correction of Nagel et al., ICCV 2019).
  void correct_biases();
  const Dataset* calib_ = nullptr;  ///< the calibration images of the last program() (not owned)
  /// Runs f(l) for every layer on all threads, largest first, each serially; the first failure
  /// in network order is rethrown with the layer's name.
  void for_layers(const std::function<void(int)>& f, const std::function<void(int, int)>& progress) const;

  const Model& model_;
  AnalogConfig cfg_;
  std::vector<AnalogLayer> layers_;
  std::vector<LayerStatistics> stats_;
  std::vector<bool> reads_image_;  ///< per linear layer: linear_reads_image
};

}  // namespace xbarsim
