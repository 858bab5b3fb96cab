#include "sw/analog/calibration.h"

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

}  // namespace xbarsim
