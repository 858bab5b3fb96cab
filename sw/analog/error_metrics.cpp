#include "sw/analog/error_metrics.h"

#include <cmath>
#include <limits>

namespace xbarsim {

double bit_accuracy(double re) { return re > 0 ? std::log2(1.0 / re + 1.0) : std::numeric_limits<double>::infinity(); }
double ErrorStats::bit_accuracy_mean() const { return bit_accuracy(mean_relative_error); }
double ErrorStats::bit_accuracy_worst() const { return bit_accuracy(worst_relative_error); }

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
    const double r = range(j) > 0 ? range(j) : fallback;
    double sum = 0, worst = 0;
    for (Eigen::Index a = 0; a < k; ++a) {
      const double e = std::abs(actual(a, j) - ideal(a, j)) / r;
      sum += e;
      worst = std::max(worst, e);
    }
    s.column_mean(j) = sum / k;
    s.column_worst(j) = worst;
    total += sum;
    s.worst_relative_error = std::max(s.worst_relative_error, worst);
  }
  s.mean_relative_error = total / (static_cast<double>(k) * n);
  return s;
}

}  // namespace xbarsim
