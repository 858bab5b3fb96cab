#include "sw/analog/calibration.h"

#include <algorithm>
#include <random>

#include "sw/common/errors.h"
#include "sw/common/seed.h"

namespace xbarsim {

Eigen::MatrixXd ColumnFit::apply(const Eigen::MatrixXd& actual) const {
  return ((actual.array().rowwise() * gain.transpose().array()).rowwise() + offset.transpose().array()).matrix();
}

ColumnFit fit_columns(const Eigen::MatrixXd& actual, const Eigen::MatrixXd& ideal) {
  const Eigen::Index n = actual.cols();
  ColumnFit f;
  f.gain.resize(n);
  f.offset.resize(n);
  for (Eigen::Index j = 0; j < n; ++j) {
    const double mx = actual.col(j).mean(), my = ideal.col(j).mean();
    const Eigen::ArrayXd dx = actual.col(j).array() - mx;
    const double sxx = dx.square().sum();
    const double sxy = (dx * (ideal.col(j).array() - my)).sum();
    if (sxx > 1e-300 && actual.rows() > 1) {
      f.gain(j) = sxy / sxx;
      f.offset(j) = my - f.gain(j) * mx;
    } else {
      f.gain(j) = 1.0;
      f.offset(j) = my - mx;
    }
  }
  return f;
}

ColumnFit identity_fit(int n) { return {Eigen::VectorXd::Ones(n), Eigen::VectorXd::Zero(n)}; }

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
