#include "sw/nn/dataset.h"

#include <zlib.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <map>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <random>
#include <stdexcept>
#include <filesystem>
#include <fstream>
#include <sys/stat.h>

#include "sw/common/errors.h"
#include "sw/common/input_file.h"
#include "sw/nn/npy.h"

namespace xbarsim {

namespace {

bool exists(const std::string& p) {
  struct stat st;
  return stat(p.c_str(), &st) == 0;
}

std::vector<uint8_t> read_gz_or_plain(const std::string& path) {
  open_as_input(path, "the dataset file");
  gzFile f = gzopen(path.c_str(), "rb");
  if (!f) throw InputError("cannot open '" + path + "'");
  std::vector<uint8_t> out;
  uint8_t buf[1 << 16];
  int n;
  constexpr size_t kMaxBytes = size_t{1} << 30;  // far above MNIST (47 MB); refuses decompression bombs
  while ((n = gzread(f, buf, sizeof buf)) > 0) {
    out.insert(out.end(), buf, buf + n);
    if (out.size() > kMaxBytes) {
      gzclose(f);
      throw InputError("'" + path + "' holds more than 1 GiB of data; not an MNIST file");
    }
  }
  const bool bad = n < 0;
  gzclose(f);
  if (bad) throw InputError("'" + path + "' is not a readable gzip/idx file");
  return out;
}

uint32_t be32(const std::vector<uint8_t>& b, size_t at) {
  return (uint32_t(b[at]) << 24) | (uint32_t(b[at + 1]) << 16) | (uint32_t(b[at + 2]) << 8) | uint32_t(b[at + 3]);
}

void clamp_range(int total, int& offset, int& count, const std::string& what) {
  if (offset < 0 || offset >= total)
    throw InputError(what + ": offset " + std::to_string(offset) + " is outside the " + std::to_string(total) +
                     " images");
  if (count < 0 || count > total - offset) count = total - offset;
}

}  // namespace

void Dataset::preprocess(int index, const Preprocessing& p, float* out) const {
  if (index < 0 || index >= count())
    throw std::out_of_range("image " + std::to_string(index) + " of a dataset of " + std::to_string(count()));
  const int hw = shape.h * shape.w, n = shape.size();
  const uint8_t* px = pixels.data() + static_cast<size_t>(index) * n;
  const float* fx = values.empty() ? nullptr : values.data() + static_cast<size_t>(index) * n;
  for (int c = 0; c < shape.c; ++c) {
    const double mean = p.mean.size() == 1 ? p.mean[0] : p.mean.at(c);
    const double sd = p.std.size() == 1 ? p.std[0] : p.std.at(c);
    for (int k = 0; k < hw; ++k)
      out[c * hw + k] = static_cast<float>(((fx ? fx[c * hw + k] : px[c * hw + k]) * p.scale - mean) / sd);
  }
}

Dataset random_dataset(const Shape& s, int count, uint64_t seed) {
  Dataset d;
  d.name = "random";
  d.shape = s;
  d.pixels.resize(static_cast<size_t>(count) * s.size());
  d.labels.assign(count, 0);
  std::mt19937_64 rng(seed);
  for (auto& p : d.pixels) p = static_cast<uint8_t>(rng() & 0xff);
  return d;
}

Dataset load_cifar10(const std::string& file, int offset, int count) {
  open_as_input(file, "the dataset file");
  std::ifstream in(file, std::ios::binary | std::ios::ate);
  if (!in) throw InputError("cannot open CIFAR-10 file '" + file + "': " + std::strerror(errno));
  const long long size = in.tellg();
  constexpr int kRecord = 1 + 3072;
  if (size <= 0 || size % kRecord)
    throw InputError("'" + file + "' is not in the CIFAR-10 binary record format (" + std::to_string(size) +
                     " bytes is not a whole number of " + std::to_string(kRecord) + "-byte records)");
  const int total = static_cast<int>(size / kRecord);
  clamp_range(total, offset, count, file);
  Dataset d;
  d.name = "cifar10";
  d.first = offset;
  d.shape = {3, 32, 32};
  d.pixels.resize(static_cast<size_t>(count) * 3072);
  d.labels.resize(count);
  in.seekg(static_cast<long long>(offset) * kRecord);
  std::vector<uint8_t> rec(kRecord);
  for (int k = 0; k < count; ++k) {
    in.read(reinterpret_cast<char*>(rec.data()), kRecord);
    if (!in) throw InputError("'" + file + "' ended early");
    if (rec[0] > 9) throw InputError("'" + file + "': record " + std::to_string(offset + k) + " has label > 9");
    d.labels[k] = rec[0];
    std::copy(rec.begin() + 1, rec.end(), d.pixels.begin() + static_cast<size_t>(k) * 3072);
  }
  return d;
}

Dataset load_mnist(const std::string& images, const std::string& labels, int offset, int count) {
  const auto im = read_gz_or_plain(images);
  const auto lb = read_gz_or_plain(labels);
  if (im.size() < 16 || be32(im, 0) != 2051) throw InputError("'" + images + "' is not an idx3 image file");
  if (lb.size() < 8 || be32(lb, 0) != 2049) throw InputError("'" + labels + "' is not an idx1 label file");
  const uint32_t total32 = be32(im, 4), rows32 = be32(im, 8), cols32 = be32(im, 12);
  if (total32 < 1 || total32 > 10000000 || rows32 < 1 || rows32 > 4096 || cols32 < 1 || cols32 > 4096)
    throw InputError("'" + images + "' has an implausible header (" + std::to_string(total32) + " images of " +
                     std::to_string(rows32) + "x" + std::to_string(cols32) + ")");
  const int total = static_cast<int>(total32), rows = static_cast<int>(rows32), cols = static_cast<int>(cols32);
  if (be32(lb, 4) != total32) throw InputError("MNIST image and label counts differ");
  if (im.size() < 16 + static_cast<size_t>(total) * rows * cols || lb.size() < 8 + static_cast<size_t>(total))
    throw InputError("MNIST files '" + images + "' / '" + labels + "' are truncated");
  clamp_range(total, offset, count, images);
  Dataset d;
  d.name = "mnist";
  d.first = offset;
  d.shape = {1, rows, cols};
  const size_t n = static_cast<size_t>(rows) * cols;
  d.pixels.assign(im.begin() + 16 + offset * n, im.begin() + 16 + (offset + count) * n);
  d.labels.assign(lb.begin() + 8 + offset, lb.begin() + 8 + offset + count);
  for (int k = 0; k < count; ++k)
    if (d.labels[k] > 9) throw InputError("'" + labels + "': label " + std::to_string(offset + k) + " is > 9");
  return d;
}

std::string resolve_data_dir(const ConfigTree& cfg) {
  std::vector<std::string> tried;
  const std::string configured = cfg.get_string("data.dir");
  if (!configured.empty()) {
    if (exists(configured)) return configured;
    throw InputError("data directory '" + configured + "' (data.dir) does not exist");
  }
  if (const char* env = std::getenv("XBARSIM_DATA_DIR")) {
    if (exists(env)) return env;
    throw InputError(std::string("data directory '") + env + "' (XBARSIM_DATA_DIR) does not exist");
  }
  std::vector<std::string> candidates = {"../shared/data"};
#ifdef XBARSIM_SOURCE_DIR
  candidates.push_back(std::string(XBARSIM_SOURCE_DIR) + "/../shared/data");
#endif
  for (const auto& c : candidates) {
    if (exists(c)) return c;
    tried.push_back(c);
  }
  std::string list;
  for (const auto& t : tried) list += " " + t;
  throw InputError("no data directory found: set data.dir or XBARSIM_DATA_DIR (looked in:" + list + ")");
}

std::string preprocessing_text(const Preprocessing& p) {
  auto list = [](const std::vector<double>& v) {
    std::string s;
    for (double x : v) s += (s.empty() ? "" : ",") + std::to_string(x);
    return s;
  };
  return "scale " + std::to_string(p.scale) + ", mean " + list(p.mean) + ", std " + list(p.std);
}

std::string preprocessing_warning(const Model& m, const ConfigTree& cfg) {
  if (m.preprocessing_in_metadata) return "";
  for (const char* k : {"preprocessing.scale", "preprocessing.mean", "preprocessing.std"})
    if (!cfg.get_string(k).empty()) return "";
  return "the model has no preprocessing metadata (input_scale, input_mean, input_std): using the defaults " +
         preprocessing_text(m.pre) + ", x = (pixel * scale - mean) / std (set preprocessing.* to change them)";
}

std::string dataset_range_warning(const Dataset& d, const Preprocessing& p, const std::string& what) {
  if (d.values.empty()) return "";
  const auto [lo, hi] = std::minmax_element(d.values.begin(), d.values.end());
  const double largest = std::max(std::fabs(*lo), std::fabs(*hi));
  char text[512];
  if (largest <= 1.0 && p.scale < 1.0 / 16) {
    std::snprintf(text, sizeof text,
                  "%s are float values within [%.3g, %.3g] but preprocessing.scale is %.6g, which expects 0..255 "
                  "pixels: images already in [0, 1] reach the network 255 times too small (set "
                  "preprocessing.scale=1)",
                  what.c_str(), static_cast<double>(*lo), static_cast<double>(*hi), p.scale);
    return text;
  }
  if (largest > 255.0 && p.scale < 1.0) {
    std::snprintf(text, sizeof text,
                  "%s hold float values up to %.6g, beyond the 0..255 pixels preprocessing.scale %.6g expects: check "
                  "the images and preprocessing.scale",
                  what.c_str(), largest, p.scale);
    return text;
  }
  return "";
}

void apply_preprocessing_overrides(const ConfigTree& cfg, Preprocessing& pre, int channels) {
  const std::string origin = "configuration";
  const std::string scale = cfg.get_string("preprocessing.scale"), mean = cfg.get_string("preprocessing.mean"),
                    sd = cfg.get_string("preprocessing.std");
  if (!scale.empty()) pre.scale = parse_number_list(scale, "preprocessing.scale", origin).at(0);
  if (!mean.empty()) pre.mean = parse_number_list(mean, "preprocessing.mean", origin);
  if (!sd.empty()) pre.std = parse_number_list(sd, "preprocessing.std", origin);
  auto check = [&](const std::vector<double>& v, const char* key) {
    if (v.size() != 1 && static_cast<int>(v.size()) != channels)
      throw InputError(std::string("'") + key + "' needs 1 or " + std::to_string(channels) + " values, got " +
                       std::to_string(v.size()));
  };
  check(pre.mean, "preprocessing.mean");
  check(pre.std, "preprocessing.std");
  for (double v : pre.std)
    if (!(v > 0)) throw InputError("'preprocessing.std' values must be > 0");
  if (!(pre.scale > 0)) throw InputError("'preprocessing.scale' must be > 0");
  // The network computes in float: every preprocessed pixel (0..255) must be a finite float,
  // and not every one zero.
  bool any_nonzero = false;
  for (int c = 0; c < channels; ++c) {
    const double mean_c = pre.mean.size() == 1 ? pre.mean[0] : pre.mean[c];
    const double std_c = pre.std.size() == 1 ? pre.std[0] : pre.std[c];
    for (double pixel : {0.0, 255.0}) {
      const double x = (pixel * pre.scale - mean_c) / std_c;
      if (!(std::fabs(x) <= std::numeric_limits<float>::max())) {
        char msg[512];
        std::snprintf(msg, sizeof msg,
                      "preprocessing turns pixel %d of channel %d into (%d x %.6g - %.6g) / %.6g = %.6g, which a float "
                      "cannot hold: check 'preprocessing.scale', 'preprocessing.mean' and 'preprocessing.std' (or the "
                      "model's metadata they override)",
                      static_cast<int>(pixel), c, static_cast<int>(pixel), pre.scale, mean_c, std_c, x);
        throw InputError(msg);
      }
      any_nonzero = any_nonzero || static_cast<float>(x) != 0.0f;
    }
  }
  if (!any_nonzero)
    throw InputError(
        "preprocessing ('preprocessing.scale', 'preprocessing.mean', 'preprocessing.std' or the "
        "model's metadata) turns every pixel into 0");
}

std::string resolve_models_dir(const ConfigTree& cfg) {
  const std::string configured = cfg.get_string("data.models_dir");
  if (!configured.empty()) {
    if (!exists(configured)) throw InputError("models directory '" + configured + "' (data.models_dir) does not exist");
    return configured;
  }
  return resolve_data_dir(cfg) + "/../models";
}

namespace {
/// `p` without "." and "dir/.." steps ("data/../models/m.onnx" -> "models/m.onnx") where that
/// names the same file; through a symbolic link it may not ("link/.." is where the link points,
/// not its folder): then the absolute path with every link resolved.
std::string normal_path(const std::string& p) {
  namespace fs = std::filesystem;
  std::error_code ec;
  const fs::path lexical = fs::path(p).lexically_normal();
  if (fs::equivalent(lexical, p, ec) && !ec) return lexical.string();
  const fs::path canonical = fs::weakly_canonical(p, ec);
  return ec ? p : canonical.string();
}
}  // namespace

std::string find_model_file(const std::string& given, const ConfigTree& cfg) {
  if (exists(given)) return normal_path(given);
  std::vector<std::string> tried{given};
  // A list (sweep) in these keys is an error of its own, not a model that was not found.
  for (const char* key : {"data.dir", "data.models_dir"}) cfg.get_string(key);
  try {
    const std::string dir = resolve_models_dir(cfg);
    for (const std::string& c : {dir + "/" + given, dir + "/" + given + ".onnx"}) {
      if (exists(c)) return normal_path(c);
      tried.push_back(c);
    }
  } catch (const InputError&) {
  }
  std::string list;
  for (const auto& t : tried) list += " " + t;
  throw InputError("model '" + given + "' not found (looked at:" + list + ")");
}

bool is_npz_dataset(const std::string& name) {
  return name.size() > 4 && name.compare(name.size() - 4, 4, ".npz") == 0;
}

Dataset load_npz_dataset(const std::string& path, const std::string& split, int offset, int count, std::string* note) {
  // Only the arrays this split uses are read: the calibration split's own, else the test set.
  std::map<std::string, NpyArray> arrays;
  if (split == "calib") arrays = read_npz(path, {"calib_images", "calib_labels"});
  const bool own_calib = split == "calib" && arrays.count("calib_images");
  if (!own_calib) arrays = read_npz(path, {"images", "labels"});
  const std::string images_key = own_calib ? "calib_images" : "images", labels_key = own_calib ? "calib_labels" : "labels";
  if (split == "calib" && !own_calib && note)
    *note = "'" + path + "' has no calib_images: calibrating on its test images";
  auto it = arrays.find(images_key);
  if (it == arrays.end()) throw InputError("'" + path + "' has no array '" + images_key + "' (N x C x H x W images)");
  const NpyArray& im = it->second;
  const std::string what = "'" + path + "', array '" + images_key + "'";
  if (im.shape.size() != 3 && im.shape.size() != 4)
    throw InputError(what + " has " + std::to_string(im.shape.size()) + " dimensions: give N x C x H x W (or N x H x W)");
  for (int64_t d : im.shape)
    if (d < 1 || d > (1 << 20)) throw InputError(what + " has an empty or too large dimension");
  Dataset d;
  d.name = path;
  d.from_calib_array = own_calib;
  const bool chw = im.shape.size() == 4;
  d.shape = {chw ? static_cast<int>(im.shape[1]) : 1, static_cast<int>(im.shape[chw ? 2 : 1]),
             static_cast<int>(im.shape[chw ? 3 : 2])};
  const int64_t n = im.shape[0];
  std::vector<int> labels(static_cast<size_t>(n), 0);
  const auto lt = arrays.find(labels_key);
  if (lt != arrays.end()) {
    const NpyArray& lb = lt->second;
    if (!lb.is_integer() || lb.elements() != n)
      throw InputError("'" + path + "', array '" + labels_key + "' must hold " + std::to_string(n) +
                       " integer labels (one per image)");
    for (int64_t k = 0; k < n; ++k) {
      const double v = lb.at(k);
      if (v < 0 || v > 1e9) {
        char label[32];
        std::snprintf(label, sizeof label, "%.0f", v);  // an integer dtype: -1, not -1.000000
        throw InputError("'" + path + "', array '" + labels_key + "': label " + label + " of image " +
                         std::to_string(k) + " is negative or too large");
      }
      labels[static_cast<size_t>(k)] = static_cast<int>(v);
    }
  } else if (!own_calib) {
    throw InputError("'" + path + "' has no array '" + labels_key + "' (N integer labels)");
  }
  if (offset < 0 || offset > n) throw InputError("offset " + std::to_string(offset) + " is past the " +
                                                 std::to_string(n) + " images of '" + path + "'");
  const int64_t take = count < 0 ? n - offset : std::min<int64_t>(count, n - offset);
  const size_t per = static_cast<size_t>(d.shape.size());
  d.first = offset;
  d.labels.assign(labels.begin() + offset, labels.begin() + offset + take);
  if (im.dtype == "u1") {
    d.pixels.assign(im.data.begin() + static_cast<std::ptrdiff_t>(offset * per),
                    im.data.begin() + static_cast<std::ptrdiff_t>((offset + take) * per));
  } else if (im.dtype == "f4" || im.dtype == "f8") {
    d.values.resize(static_cast<size_t>(take) * per);
    for (size_t k = 0; k < d.values.size(); ++k) {
      const double v = im.at(static_cast<int64_t>(offset * per + k));
      if (!(std::fabs(v) <= std::numeric_limits<float>::max()))  // (NaN too) the network computes in float
      {
        char value[64];
        std::snprintf(value, sizeof value, "%g", v);
        throw InputError(what + " holds " +
                         (std::isfinite(v) ? "a value a float cannot hold (" + std::string(value) + ")"
                                           : std::string("a non-finite value")) +
                         " at element " + std::to_string(offset * per + k));
      }
      d.values[k] = static_cast<float>(v);
    }
    d.pixels.assign(d.values.size(), 0);  // (the uint8 view is unused for float images)
  } else {
    throw InputError(what + " has dtype " + im.dtype + ": give uint8 pixels or float32 values");
  }
  return d;
}

std::vector<std::string> dataset_files(const std::string& name, const std::string& dir, const std::string& split) {
  if (is_npz_dataset(name)) return {name};
  if (name == "cifar10") return {dir + "/cifar10/" + (split == "calib" ? "calib_batch.bin" : "test_batch.bin")};
  if (name == "mnist") return {dir + "/mnist/t10k-images-idx3-ubyte.gz", dir + "/mnist/t10k-labels-idx1-ubyte.gz"};
  throw InputError("unknown dataset '" + name + "' (cifar10, mnist or a .npz file)");
}

Dataset load_dataset(const std::string& name, const std::string& dir, const std::string& split, int offset, int count) {
  if (is_npz_dataset(name)) return load_npz_dataset(name, split, offset, count, nullptr);
  const std::vector<std::string> files = dataset_files(name, dir, split);
  for (const auto& f : files)
    if (!exists(f))
      throw InputError((name == "mnist" ? "MNIST" : "CIFAR-10") + std::string(" file not found: looked for '") + f +
                       "'");
  if (name == "cifar10") return load_cifar10(files[0], offset, count);
  // MNIST ships no training images here: its calibration split is test images 9000-9999.
  return load_mnist(files[0], files[1], split == "calib" ? kMnistCalibrationStart + offset : offset, count);
}

}  // namespace xbarsim
