#pragma once
/// Calibration (paper section "Calibration"): a per-column first-order fit from crossbar
/// output to ideal output over a few calibration vectors, applied digitally.
#include <Eigen/Dense>

namespace xbarsim {

struct ColumnFit {
  Eigen::VectorXd gain;    ///< per column
  Eigen::VectorXd offset;  ///< per column: corrected = gain * actual + offset
  Eigen::MatrixXd apply(const Eigen::MatrixXd& actual) const;
};

/// Least-squares fit ideal ~ gain * actual + offset per column (closed form). A column
/// whose actual outputs do not vary gets gain 1 and the mean difference as offset.
ColumnFit fit_columns(const Eigen::MatrixXd& actual, const Eigen::MatrixXd& ideal);

/// Identity fit (no calibration) for n columns.
ColumnFit identity_fit(int n);

}  // namespace xbarsim
