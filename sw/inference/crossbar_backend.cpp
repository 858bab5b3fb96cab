#include "sw/inference/crossbar_backend.h"

#include <limits>
#include <algorithm>
#include <mutex>
#include <random>
#include <thread>

namespace xbarsim {

CrossbarBackend::CrossbarBackend(const Model& m, const AnalogConfig& cfg) : model_(m), cfg_(cfg) {}

void CrossbarBackend::program(const Dataset& calib, int max_samples,
                              const std::function<void(int, int)>& progress) {
  const int L = static_cast<int>(model_.linear.size());
  stats_.assign(L, LayerStatistics{});
  if (calib.count() < 1) throw InputError("crossbar programming needs at least one calibration image");
  // Software pass over the calibration images, both cores; each thread keeps its own tallies.
  const int threads = std::max(1, std::min(resolve_threads(cfg_.solver.threads), calib.count()));
  struct Tally {
    std::vector<double> x_max;
    std::vector<char> sign;
    std::vector<std::vector<Eigen::RowVectorXd>> rows;
    std::vector<Eigen::VectorXd> lo, hi;
  };
  std::vector<Tally> tally(threads);
  const int per_image = std::max(1, max_samples / calib.count() + 1);
  parallel_for(threads, threads, [&](int t) {
    Tally& ty = tally[t];
    ty.x_max.assign(L, 0.0);
    ty.sign.assign(L, 0);
    ty.rows.assign(L, {});
    ty.lo.resize(L);
    ty.hi.resize(L);
    for (int l = 0; l < L; ++l) {
      ty.lo[l] = Eigen::VectorXd::Constant(model_.linear[l].c_out, std::numeric_limits<double>::infinity());
      ty.hi[l] = -ty.lo[l];
    }
    SoftwareBackend sw(model_);
    LayerTrace trace;
    std::vector<float> x(model_.input.size());
    std::mt19937_64 rng(1234 + t);
    for (int k = t; k < calib.count(); k += threads) {
      calib.preprocess(k, model_.pre, x.data());
      run_image(model_, x.data(), sw, &trace);
      for (int l = 0; l < L; ++l) {
        const RowMatrixXf& in = trace.inputs[l];
        ty.x_max[l] = std::max(ty.x_max[l], static_cast<double>(in.cwiseAbs().maxCoeff()));
        ty.sign[l] |= in.minCoeff() < 0;
        for (int s = 0; s < per_image; ++s)
          ty.rows[l].push_back(in.row(static_cast<Eigen::Index>(rng() % in.rows())).cast<double>());
        const Eigen::MatrixXf& out = trace.outputs[l];
        ty.lo[l] = ty.lo[l].cwiseMin(out.colwise().minCoeff().transpose().cast<double>());
        ty.hi[l] = ty.hi[l].cwiseMax(out.colwise().maxCoeff().transpose().cast<double>());
      }
    }
  });
  for (int l = 0; l < L; ++l) {
    LayerStatistics& st = stats_[l];
    std::vector<Eigen::RowVectorXd> rows;
    st.out_lo = tally[0].lo[l];
    st.out_hi = tally[0].hi[l];
    for (const Tally& ty : tally) {
      st.x_max = std::max(st.x_max, ty.x_max[l]);
      st.signed_inputs = st.signed_inputs || ty.sign[l];
      rows.insert(rows.end(), ty.rows[l].begin(), ty.rows[l].end());
      st.out_lo = st.out_lo.cwiseMin(ty.lo[l]);
      st.out_hi = st.out_hi.cwiseMax(ty.hi[l]);
    }
    if (!(st.x_max > 0)) st.x_max = 1.0;  // a layer that only ever sees zeros
    const int n = std::min<int>(static_cast<int>(rows.size()), max_samples);
    st.samples.resize(n, model_.linear[l].rows());
    for (int r = 0; r < n; ++r) st.samples.row(r) = rows[r];
  }
  layers_.clear();
  layers_.reserve(L);
  for (int l = 0; l < L; ++l)
    layers_.emplace_back(cfg_, model_.linear[l].weight.cast<double>(), stats_[l].x_max, stats_[l].signed_inputs,
                         static_cast<uint64_t>(l + 1));
  // Layers are independent: program them on all threads (largest first), each serially.
  AnalogConfig serial = cfg_;
  serial.solver.threads = 1;
  std::vector<int> order(L);
  for (int l = 0; l < L; ++l) order[l] = l;
  std::sort(order.begin(), order.end(), [&](int a, int b) {
    return model_.linear[a].rows() * model_.linear[a].c_out > model_.linear[b].rows() * model_.linear[b].c_out;
  });
  std::mutex mu;
  int done = 0;
  const int workers = resolve_threads(cfg_.solver.threads);
  parallel_for(L, workers, [&](int k) {
    const int l = order[k];
    layers_[l].program(stats_[l].samples, serial.solver);
    std::lock_guard<std::mutex> lock(mu);
    if (progress) progress(++done, L);
  });
}

void CrossbarBackend::multiply_activation(int layer, const LinearLayer& L, const float* chw, RowMatrixXf& scratch,
                                          Eigen::MatrixXf& out) const {
  const AnalogLayer& a = layers_.at(layer);
  if (a.config().dac_bits <= 0) {
    im2col(L, chw, scratch);
    a.forward<float>(scratch, out);
    return;
  }
  thread_local std::vector<float> q;
  q.assign(chw, chw + L.in.size());
  a.dac_values<float>(q.data(), static_cast<Eigen::Index>(q.size()));
  im2col(L, q.data(), scratch);
  a.forward<float>(scratch, out, /*quantized=*/true);
}

void CrossbarBackend::multiply(int layer, const RowMatrixXf& cols, Eigen::MatrixXf& out) const {
  layers_.at(layer).forward<float>(cols, out);
}

}  // namespace xbarsim
