#include "sw/analog/calibration.h"

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "sw/common/errors.h"
#include "sw/common/seed.h"

namespace xbarsim {

Eigen::MatrixXd ColumnFit::apply(const Eigen::MatrixXd& actual) const {
  return ((actual.array().rowwise() * gain.transpose().array()).rowwise() + offset.transpose().array()).matrix();
}

namespace {
/// Outputs closer than this fraction of the column's largest |output| are equal (rounding of
/// the recovery), when no ADC step says what is resolved.
constexpr double kRoundingTolerance = 1e-9;

/// How many distinct values x takes, counting values more than `tol` apart as distinct.
int distinct_values(const Eigen::VectorXd& x, double tol) {
  std::vector<double> v(x.data(), x.data() + x.size());
  std::sort(v.begin(), v.end());
  int n = v.empty() ? 0 : 1;
  for (size_t r = 1; r < v.size(); ++r) n += v[r] - v[r - 1] > tol ? 1 : 0;
  return n;
}
}  // namespace

ColumnFit fit_columns(const Eigen::MatrixXd& actual, const Eigen::MatrixXd& ideal, const Eigen::VectorXd& step) {
  if (actual.rows() != ideal.rows() || actual.cols() != ideal.cols() || (step.size() && step.size() != actual.cols()))
    throw InputError("calibration fit: actual outputs, ideal outputs and ADC steps disagree in size");
  const Eigen::Index n = actual.cols();
  const double rows = static_cast<double>(actual.rows());
  ColumnFit f;
  f.gain.resize(n);
  f.offset.resize(n);
  f.gain_fitted.resize(n);
  for (Eigen::Index j = 0; j < n; ++j) {
    const double mx = actual.col(j).mean(), my = ideal.col(j).mean();
    // Offset only (gain 1) unless the data determine a gain.
    f.gain(j) = 1.0;
    f.offset(j) = my - mx;
    f.gain_fitted(j) = false;
    const double delta = step.size() ? step(j) : 0.0;
    const double tol = std::max(0.5 * delta, kRoundingTolerance * actual.col(j).cwiseAbs().maxCoeff());
    const int distinct = distinct_values(actual.col(j), tol);
    // The errors are in the crossbar's outputs (ADC rounding, device and read noise), not in the
    // ideal ones: fit actual ~ a ideal + b (the ideal outputs as the regressor, exact) and invert
    // it, corrected = (actual - b) / a. Regressing ideal on the noisy actual outputs instead
    // attenuates the gain by var(signal) / (var(signal) + var(noise)) (regression dilution): a
    // 4-bit ADC's rounding shrank every calibrated output.
    const Eigen::ArrayXd di = ideal.col(j).array() - my;
    const double sii = di.square().sum();
    if (distinct < kMinDistinctOutputs || !(sii > 0)) continue;
    const double a = (di * (actual.col(j).array() - mx)).sum() / sii;
    if (!(std::abs(a) > 0)) continue;
    const double gain = 1.0 / a;
    const double offset = my - gain * mx;
    // The gain's standard error (delta method, se(1/a) = se(a) / a^2): the residual variance of
    // the actual outputs (rows - 2 degrees of freedom) plus the ADC's quantization variance
    // step^2 / 12, which the residuals of a few samples can miss.
    const double ssr = (actual.col(j).array() - mx - a * di).square().sum();
    const double se = std::sqrt((ssr / (rows - 2) + delta * delta / 12) / sii) / (a * a);
    if (!(se <= kMaxGainStandardError)) continue;
    // A gain no further from 1 than its noise says nothing: the offset alone, with gain 1
    // (fitting it would add the estimate's error to every output).
    if (!(std::abs(gain - 1.0) > kGainSignificance * se)) continue;
    f.gain(j) = gain;
    f.offset(j) = offset;
    f.gain_fitted(j) = true;
  }
  return f;
}

ColumnFit identity_fit(int n) {
  return {Eigen::VectorXd::Ones(n), Eigen::VectorXd::Zero(n), Eigen::Array<bool, Eigen::Dynamic, 1>::Constant(n, false)};
}

namespace {
/// Stream id of the calibration-row picks (derived with calibration.seed and the image).
constexpr uint64_t kCalibrationRowStream = 0xCA1B;
}  // namespace

int calibration_rows_per_image(int max_samples, int images) { return std::max(1, max_samples / std::max(1, images) + 1); }

std::vector<Eigen::Index> calibration_row_picks(uint64_t seed, int image, int layer, Eigen::Index rows, int count) {
  if (rows < 1) throw InputError("a calibration image gave a layer no input vectors");
  if (image < 0 || layer < 0 || count < 0) throw InputError("calibration picks need an image, layer and count >= 0");
  std::mt19937_64 rng(derive_seed(seed, {kCalibrationRowStream, static_cast<uint64_t>(image)}));
  rng.discard(static_cast<unsigned long long>(layer) * static_cast<unsigned long long>(count));
  std::vector<Eigen::Index> picks(static_cast<size_t>(std::max(0, count)));
  for (Eigen::Index& p : picks) p = static_cast<Eigen::Index>(rng() % static_cast<uint64_t>(rows));
  return picks;
}

}  // namespace xbarsim
