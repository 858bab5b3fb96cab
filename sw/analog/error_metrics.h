#pragma once
/// Error metrics exactly as the paper defines them (section "Optimize conversion signal"):
///   output error = (actual - ideal) / output range,   relative error = |output error|,
///   bit accuracy = log2(1 / relative error + 1),
/// where the output range of a column (kernel) is max - min of its ideal outputs.
#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
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
/// range is below 1e-6 of the largest range use the largest (or 1 if all are constant).
ErrorStats relative_error(const Eigen::MatrixXd& actual, const Eigen::MatrixXd& ideal);

/// Sum, worst and count of relative errors |actual - ideal| / range(column), for streaming
/// (e.g. one image at a time against ranges fixed beforehand).
struct ErrorTally {
  double sum = 0, worst = 0;
  long long count = 0;
  ErrorTally& operator+=(const ErrorTally& o);
  double mean() const { return count ? sum / count : 0.0; }
};
/// The tally of one column's errors; `range` > 0.
template <typename A, typename B>
ErrorTally column_error(const A& actual, const B& ideal, double range) {
  ErrorTally t;
  for (Eigen::Index a = 0; a < ideal.size(); ++a) {
    const double e = std::abs(static_cast<double>(actual(a)) - static_cast<double>(ideal(a))) / range;
    t.sum += e;
    t.worst = std::max(t.worst, e);
  }
  t.count = ideal.size();
  return t;
}

double bit_accuracy(double relative_error);

}  // namespace xbarsim
