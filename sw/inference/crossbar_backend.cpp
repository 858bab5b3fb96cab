#include "sw/inference/crossbar_backend.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <exception>
#include <mutex>
#include <stdexcept>
#include <thread>

#include "sw/analog/calibration.h"
#include "sw/common/cancel.h"

namespace xbarsim {

namespace {
thread_local uint64_t t_image = 0;
}  // namespace

void CrossbarBackend::set_image(uint64_t image) { t_image = image; }

CrossbarBackend::CrossbarBackend(const Model& m, const AnalogConfig& cfg)
    : model_(m), cfg_(cfg), reads_image_(linear_reads_image(m)) {}

AnalogConfig CrossbarBackend::layer_config(const AnalogConfig& c, int l) const {
  AnalogConfig per = c;
  per.converters = c.converters.for_layer(reads_image_.at(l));
  return per;
}

void CrossbarBackend::program(const Dataset& calib, int max_samples, const std::function<void(int, int)>& progress) {
  gather_statistics(calib, max_samples);
  calib_ = &calib;
  if (!cfg_.ranging.bias_correction) {
    program_layers(progress);
    return;
  }
  // Programmed and read out at t = 0, where the offsets are measured; then moved to the time.
  const AnalogConfig target = cfg_;
  cfg_.device.time_s = 0;
  try {
    program_layers(progress);
    read_out_layers(target, nullptr);
  } catch (...) {
    cfg_ = target;
    throw;
  }
}

void CrossbarBackend::correct_biases() {
  const Dataset& calib = *calib_;
  const int L = static_cast<int>(model_.linear.size());
  const int images = std::min(calib.count(), kBiasImagesMax);
  const int threads = std::max(1, std::min(resolve_threads(cfg_.solver.threads), images));
  // Layer by layer in network order, each pass ending at its layer: layer l's offsets are
  // measured on the inputs the corrected layers before it give it.
  std::vector<Eigen::VectorXd> sums(static_cast<size_t>(images));
  std::vector<Eigen::Index> rows(static_cast<size_t>(images));
  for (int l = 0; l < L; ++l) {
    check_cancel();
    parallel_for(threads, threads, [&](int t) {
      LayerTrace trace;
      trace.record_inputs = false;
      trace.stop_after_linear = l;
      std::vector<float> x(model_.input.size());
      for (int k = t; k < images; k += threads) {
        calib.preprocess(k, model_.pre, x.data());
        set_image(kBiasImages + static_cast<uint64_t>(k));
        run_image(model_, x.data(), *this, &trace);
        sums[static_cast<size_t>(k)] = trace.outputs[l].colwise().sum().transpose().cast<double>();
        rows[static_cast<size_t>(k)] = trace.outputs[l].rows();
      }
    });
    Eigen::VectorXd mean = Eigen::VectorXd::Zero(model_.linear[l].c_out);
    double n = 0;
    for (int k = 0; k < images; ++k) {  // in image order: the same sums on any thread count
      mean += sums[static_cast<size_t>(k)];
      n += static_cast<double>(rows[static_cast<size_t>(k)]);
    }
    mean /= std::max(n, 1.0);
    const Eigen::VectorXd& before = layers_[l].output_offsets();
    layers_[l].set_output_offsets((before.size() ? before : Eigen::VectorXd::Zero(mean.size())) +
                                  stats_[l].bias_mean - mean);
  }
}

void CrossbarBackend::read_out_layers(const AnalogConfig& target, const std::function<void(int, int)>& progress) {
  const auto set_all = [&](const AnalogConfig& c, const std::function<void(int, int)>& p) {
    for_layers([&](int l) { layers_[l].set_readout(layer_config(c, l), stats_[l].samples); }, p);
    cfg_ = c;
  };
  for (AnalogLayer& layer : layers_) layer.set_output_offsets(Eigen::VectorXd::Zero(layer.outputs()));
  if (!target.ranging.bias_correction || !calib_) {
    set_all(target, progress);
    return;
  }
  AnalogConfig at0 = target;
  at0.device.time_s = 0;
  set_all(at0, progress);
  correct_biases();
  set_all(target, nullptr);
  // A compensation that recalibrates at the time reads there anyway: the offsets too.
  if (target.device.compensation == Compensation::Recalibrate && target.device.time_s != 0) correct_biases();
}

void CrossbarBackend::structure_only() {
  const int L = static_cast<int>(model_.linear.size());
  const std::vector<bool> may_be_negative = linear_inputs_signed(model_);
  stats_.assign(L, LayerStatistics{});
  for (int l = 0; l < L; ++l) {
    stats_[l].x_max = 1.0;
    stats_[l].signed_inputs = may_be_negative[l];
  }
  make_layers();
}

void CrossbarBackend::make_layers() {
  const int L = static_cast<int>(model_.linear.size());
  layers_.clear();
  layers_.reserve(L);
  for (int l = 0; l < L; ++l) {
    try {
      const LinearLayer& L = model_.linear[l];
      layers_.emplace_back(layer_config(cfg_, l), L.weight.cast<double>(), stats_[l].x_max, stats_[l].signed_inputs,
                           static_cast<uint64_t>(l + 1), RowGroups{L.group, L.c_in});
    } catch (const std::exception&) {
      rethrow_with_context("layer " + model_.linear[l].name);
    }
  }
}

void CrossbarBackend::gather_statistics(const Dataset& calib, int max_samples) {
  const int L = static_cast<int>(model_.linear.size());
  const int images = calib.count();
  if (images < 1) throw InputError("crossbar programming needs at least one calibration image");
  // Software pass over the calibration images on all threads. Everything an image
  // contributes (its sampled rows, drawn from a stream seeded by the image index) is kept
  // per image and combined in image order, so the result does not depend on the threads.
  struct ImageTally {
    std::vector<double> x_max;
    std::vector<char> sign;
    std::vector<char> bad_out;  // per layer: its software output held inf or NaN
    std::vector<Eigen::MatrixXd> rows;  // per layer: the sampled im2col rows
    std::vector<Eigen::VectorXd> lo, hi, sum;
    std::vector<Eigen::Index> out_rows;
  };
  std::vector<ImageTally> tally(images);
  const int per_image = calibration_rows_per_image(max_samples, images);
  const int threads = std::max(1, std::min(resolve_threads(cfg_.solver.threads), images));
  parallel_for(threads, threads, [&](int t) {
    SoftwareBackend sw(model_);
    LayerTrace trace;
    std::vector<float> x(model_.input.size());
    for (int k = t; k < images; k += threads) {
      ImageTally& ty = tally[k];
      calib.preprocess(k, model_.pre, x.data());
      run_image(model_, x.data(), sw, &trace);
      ty.x_max.resize(L);
      ty.sign.resize(L);
      ty.bad_out.assign(L, 0);
      ty.rows.resize(L);
      ty.lo.resize(L);
      ty.hi.resize(L);
      ty.sum.resize(L);
      ty.out_rows.resize(L);
      for (int l = 0; l < L; ++l) {
        const RowMatrixXf& in = trace.inputs[l];
        // A value a float cannot hold (an unbounded Clip, a huge LeakyRelu slope, pixels of
        // 1e300) has no crossbar full scale: recorded as NaN, reported below with the layer.
        ty.x_max[l] = in.allFinite() ? static_cast<double>(in.cwiseAbs().maxCoeff())
                                     : std::numeric_limits<double>::quiet_NaN();
        ty.sign[l] = in.minCoeff() < 0;
        ty.rows[l].resize(per_image, in.cols());
        const std::vector<Eigen::Index> picks = calibration_row_picks(cfg_.calibration.seed, k, l, in.rows(), per_image);
        for (int s = 0; s < per_image; ++s) ty.rows[l].row(s) = in.row(picks[s]).cast<double>();
        const Eigen::MatrixXf& out = trace.outputs[l];
        // Finite inputs whose products overflow (a LeakyRelu slope of 3e38 gives inputs of
        // 1e38): the software reference itself is then inf/NaN, also reported below.
        ty.bad_out[l] = !out.allFinite();
        ty.lo[l] = out.colwise().minCoeff().transpose().cast<double>();
        ty.hi[l] = out.colwise().maxCoeff().transpose().cast<double>();
        ty.sum[l] = out.colwise().sum().transpose().cast<double>();
        ty.out_rows[l] = out.rows();
      }
    }
  });
  stats_.assign(L, LayerStatistics{});
  const std::vector<bool> may_be_negative = linear_inputs_signed(model_);
  for (int l = 0; l < L; ++l) {
    LayerStatistics& st = stats_[l];
    st.out_lo = tally[0].lo[l];
    st.out_hi = tally[0].hi[l];
    st.bias_mean = Eigen::VectorXd::Zero(st.out_lo.size());
    double out_rows = 0;
    const int n = std::min(per_image * images, max_samples);
    st.samples.resize(n, model_.linear[l].rows());
    for (int k = 0; k < images; ++k) {
      const ImageTally& ty = tally[k];
      if (std::isnan(ty.x_max[l]))
        throw InputError("layer " + model_.linear[l].name + ": its input on calibration image " +
                         std::to_string(calib.first + k) +
                         " holds a value that is not a finite float (inf or NaN), so the crossbar has no input full "
                         "scale: check the operators before it (a Clip without finite bounds, an activation's "
                         "parameter such as LeakyRelu's alpha) and the images and preprocessing");
      if (ty.bad_out[l]) {
        char full[32];
        std::snprintf(full, sizeof full, "%.3g", ty.x_max[l]);
        throw InputError("layer " + model_.linear[l].name + ": its output on calibration image " +
                         std::to_string(calib.first + k) +
                         " is not a finite float (inf or NaN) although its input is (up to " + full +
                         "): inputs that large overflow the layer's sums; check the operators before it (an "
                         "activation's parameter such as LeakyRelu's alpha) and the images and preprocessing");
      }
      st.x_max = std::max(st.x_max, ty.x_max[l]);
      st.signed_inputs = st.signed_inputs || ty.sign[l];
      st.out_lo = st.out_lo.cwiseMin(ty.lo[l]);
      st.out_hi = st.out_hi.cwiseMax(ty.hi[l]);
      if (k < kBiasImagesMax) {  // the images the bias correction runs
        st.bias_mean += ty.sum[l];
        out_rows += static_cast<double>(ty.out_rows[l]);
      }
      for (int s = 0; s < per_image && k * per_image + s < n; ++s)
        st.samples.row(k * per_image + s) = ty.rows[l].row(s);
    }
    // Signedness is the network's (the same reads in every command); the data can only add it.
    st.signed_inputs = st.signed_inputs || may_be_negative[l];
    if (!(st.x_max > 0)) st.x_max = 1.0;  // a layer that only ever sees zeros
    st.bias_mean /= std::max(out_rows, 1.0);
    st.input_max = st.x_max;
    // The DAC's full scale by ranging.inputs, from the sampled inputs' magnitudes (never above
    // the largest input): the DAC quantizes them to its levels (a sign and bits - 1 magnitude
    // bits for signed inputs) and clips above.
    st.x_max = input_full_scale(st.samples, st.x_max, st.signed_inputs, cfg_.ranging,
                                cfg_.converters.for_layer(reads_image_[l]).activation_bits());
    if (st.x_max < st.input_max && st.samples.size() > 0)
      st.input_clipped = static_cast<double>((st.samples.array().abs() > st.x_max).count()) / st.samples.size();
  }
}

void CrossbarBackend::program_layers(const std::function<void(int, int)>& progress) {
  make_layers();
  // Layers are independent: each is programmed serially, on all threads together.
  SolverOptions serial = cfg_.solver;
  serial.threads = 1;
  for_layers([&](int l) { layers_[l].program(stats_[l].samples, serial); }, progress);
}

void CrossbarBackend::set_readout(const AnalogConfig& cfg, const std::function<void(int, int)>& progress) {
  if (layers_.empty() && !model_.linear.empty())
    throw std::invalid_argument("crossbar backend: set_readout before program()");
  if (!programs_alike(cfg_, cfg))
    throw std::invalid_argument("crossbar backend: set_readout with a configuration that programs other conductances");
  // All or nothing: on an error the layers read out already go back to the readout they had.
  std::vector<std::shared_ptr<const AnalogLayer::SavedReadout>> before;
  for (const AnalogLayer& layer : layers_) before.push_back(layer.save_readout());
  const AnalogConfig cfg_before = cfg_;
  try {
    read_out_layers(cfg, progress);
  } catch (...) {
    for (size_t l = 0; l < layers_.size(); ++l) layers_[l].restore_readout(*before[l]);
    cfg_ = cfg_before;
    throw;
  }
}

void CrossbarBackend::for_layers(const std::function<void(int)>& f,
                                 const std::function<void(int, int)>& progress) const {
  const int L = static_cast<int>(model_.linear.size());
  // Largest first, so that the last layers to finish are short.
  std::vector<int> order(L);
  for (int l = 0; l < L; ++l) order[l] = l;
  std::sort(order.begin(), order.end(), [&](int a, int b) {
    return model_.linear[a].rows() * model_.linear[a].c_out > model_.linear[b].rows() * model_.linear[b].c_out;
  });
  std::mutex mu;
  int done = 0;
  const int workers = resolve_threads(cfg_.solver.threads);
  // A layer that fails is reported by its place in the network, not by which thread was first:
  // the same message on any thread count.
  std::vector<std::exception_ptr> failed(L);
  parallel_for(L, workers, [&](int k) {
    const int l = order[k];
    try {
      f(l);
    } catch (...) {
      failed[l] = current_exception_with_context("layer " + model_.linear[l].name);
      return;
    }
    std::lock_guard<std::mutex> lock(mu);
    if (progress) progress(++done, L);
  });
  for (const std::exception_ptr& e : failed)
    if (e) std::rethrow_exception(e);
}

void CrossbarBackend::multiply_activation(int layer, const LinearLayer& L, const float* chw, RowMatrixXf& scratch,
                                          Eigen::MatrixXf& out) const try {
  const AnalogLayer& a = layers_.at(layer);
  if (!a.quantizes_inputs()) {
    im2col(L, chw, scratch);
    a.forward<float>(scratch, out, /*quantized=*/false, t_image);
    return;
  }
  thread_local std::vector<float> q;
  q.assign(chw, chw + L.in.size());
  a.dac_values<float>(q.data(), static_cast<Eigen::Index>(q.size()));
  im2col(L, q.data(), scratch);
  a.forward<float>(scratch, out, /*quantized=*/true, t_image);
} catch (const std::exception&) {
  rethrow_with_context("layer " + L.name);
}

void CrossbarBackend::multiply(int layer, const RowMatrixXf& cols, Eigen::MatrixXf& out) const try {
  layers_.at(layer).forward<float>(cols, out, /*quantized=*/false, t_image);
} catch (const std::exception&) {
  rethrow_with_context("layer " + model_.linear.at(layer).name);
}

}  // namespace xbarsim
