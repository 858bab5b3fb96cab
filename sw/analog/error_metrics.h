#pragma once
/// Error metrics exactly as the paper defines them (section "Optimize conversion signal"):
///   output error = (actual - ideal) / output range,   relative error = |output error|,
///   bit accuracy = log2(1 / relative error + 1),
/// where the output range of a column (kernel) is max - min of its ideal outputs.
#include <Eigen/Dense>
#include <vector>

namespace xbarsim {

struct ErrorStats {
  double mean_relative_error = 0;     ///< over all outputs
  double worst_relative_error = 0;    ///< max over all outputs
  Eigen::VectorXd column_mean;        ///< per column
  Eigen::VectorXd column_worst;       ///< per column
  double bit_accuracy_mean() const;   ///< log2(1/mean + 1)
  double bit_accuracy_worst() const;  ///< log2(1/worst + 1)
};

/// Statistics of `actual` against `ideal` (vectors x columns). Columns whose ideal output
/// range is zero use the largest range of the other columns (or 1 if all are constant).
ErrorStats relative_error(const Eigen::MatrixXd& actual, const Eigen::MatrixXd& ideal);

double bit_accuracy(double relative_error);

}  // namespace xbarsim
