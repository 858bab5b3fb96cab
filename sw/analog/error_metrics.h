#pragma once
/// Error metrics exactly as the paper defines them (section "Optimize conversion signal"):
///   output error = (actual - ideal) / output range,   relative error = |output error|,
///   bit accuracy = log2(1 / relative error + 1),
/// where the output range of a column (kernel) is max - min of its ideal outputs.
#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <string>
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

/// A network layer's errors (eval, xbarsim.torch.evaluate; docs/physics.md, "Per-layer errors"):
/// each output's |actual - ideal| relative to the layer's output range R, the range of all its
/// ideal outputs (every channel) over the calibration images. One scale for the whole layer:
/// a channel that barely varies (a ReLU that silenced it, a folded batch norm) has a near-zero
/// range of its own, and errors relative to that range grow without bound (1e9 and more) while
/// the layer is fine. R is the largest of `hi` minus the smallest of `lo` (per channel: the
/// calibration outputs' extremes); 1 when the layer's outputs never varied (errors absolute).
double layer_output_range(const Eigen::VectorXd& lo, const Eigen::VectorXd& hi);

/// The tally of |actual - ideal| / `range` over every element of two equally sized arrays
/// (a layer's outputs: any layout, the same in both); `range` > 0 (layer_output_range).
template <typename A, typename B>
ErrorTally layer_error(const A& actual, const B& ideal, double range) {
  ErrorTally t;
  for (Eigen::Index c = 0; c < ideal.cols(); ++c) t += column_error(actual.col(c), ideal.col(c), range);
  return t;
}

/// A layer whose mean error (layer_error) passes this fraction of its output range is warned
/// about: one output in ten off by a tenth of everything the layer can output is no longer a
/// small perturbation (the default design's layers stay under 1.5 %, docs/results.md).
constexpr double kLayerErrorWarning = 0.10;
/// The warning's sentence for layer `name` with mean error `mean`.
std::string layer_error_warning(const std::string& name, double mean);

}  // namespace xbarsim
