#include "sw/analog/synthetic.h"

#include <random>

#include "sw/common/errors.h"

namespace xbarsim {

Eigen::MatrixXd synthetic_kernel(const std::string& type, int rows, int cols, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> n01(0.0, 1.0), n05(0.0, 0.5);
  std::uniform_int_distribution<int> tri(-1, 1), sign(0, 1);
  Eigen::MatrixXd w(rows, cols);
  for (int i = 0; i < rows; ++i)
    for (int j = 0; j < cols; ++j) {
      if (type == "gaussian")
        w(i, j) = n01(rng);
      else if (type == "bimodal")
        w(i, j) = (sign(rng) ? 1.0 : -1.0) * (0.5 + std::abs(n05(rng)));
      else if (type == "ternary")
        w(i, j) = tri(rng);
      else
        throw InputError("kernel type '" + type + "' is not one of: gaussian, bimodal, ternary");
    }
  return w;
}

Eigen::MatrixXd synthetic_inputs(int count, int rows, double sparsity, double x_max, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  Eigen::MatrixXd x(count, rows);
  for (int a = 0; a < count; ++a)
    for (int i = 0; i < rows; ++i) x(a, i) = u(rng) < sparsity ? 0.0 : x_max * u(rng);
  return x;
}

}  // namespace xbarsim
