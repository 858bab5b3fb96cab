#include "sw/analog/error_metrics.h"

#include <cmath>
#include <cstdio>
#include <limits>

namespace xbarsim {

double bit_accuracy(double re) { return re > 0 ? std::log2(1.0 / re + 1.0) : std::numeric_limits<double>::infinity(); }
double ErrorStats::bit_accuracy_mean() const { return bit_accuracy(mean_relative_error); }
double ErrorStats::bit_accuracy_worst() const { return bit_accuracy(worst_relative_error); }

ErrorTally& ErrorTally::operator+=(const ErrorTally& o) {
  sum += o.sum;
  worst = std::max(worst, o.worst);
  count += o.count;
  return *this;
}

ErrorStats relative_error(const Eigen::MatrixXd& actual, const Eigen::MatrixXd& ideal) {
  const Eigen::Index k = ideal.rows(), n = ideal.cols();
  ErrorStats s;
  s.column_mean = Eigen::VectorXd::Zero(n);
  s.column_worst = Eigen::VectorXd::Zero(n);
  if (k == 0 || n == 0) return s;
  Eigen::VectorXd range(n);
  double fallback = 0;
  for (Eigen::Index j = 0; j < n; ++j) {
    range(j) = ideal.col(j).maxCoeff() - ideal.col(j).minCoeff();
    fallback = std::max(fallback, range(j));
  }
  if (fallback == 0) fallback = 1;
  double total = 0;
  for (Eigen::Index j = 0; j < n; ++j) {
    const ErrorTally t = column_error(actual.col(j), ideal.col(j), range(j) > 1e-6 * fallback ? range(j) : fallback);
    s.column_mean(j) = t.mean();
    s.column_worst(j) = t.worst;
    total += t.sum;
    s.worst_relative_error = std::max(s.worst_relative_error, t.worst);
  }
  s.mean_relative_error = total / (static_cast<double>(k) * n);
  return s;
}

double layer_output_range(const Eigen::VectorXd& lo, const Eigen::VectorXd& hi) {
  if (lo.size() == 0 || hi.size() == 0) return 1.0;
  const double r = hi.maxCoeff() - lo.minCoeff();
  return r > 0 && std::isfinite(r) ? r : 1.0;
}

std::string layer_error_warning(const std::string& name, double mean) {
  char text[256];
  std::snprintf(text, sizeof text,
                "layer %s: mean error %.3g of its output range (over %.2g): its outputs differ from software's far "
                "more than converters and parasitics usually make them (docs/physics.md, per-layer errors)",
                name.c_str(), mean, kLayerErrorWarning);
  return text;
}

}  // namespace xbarsim
