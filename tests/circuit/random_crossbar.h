#pragma once
// Seeded random conductances and inputs shared by the circuit and mitigation tests.
#include <Eigen/Dense>
#include <random>

#include "sw/circuit/crossbar_params.h"

namespace xbarsim::test {

/// m x n conductances uniform in [g_min, g_max].
inline Eigen::MatrixXd random_g(int m, int n, const CrossbarParams& p, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(p.g_min_s, p.g_max_s);
  Eigen::MatrixXd g(m, n);
  for (int i = 0; i < m; ++i)
    for (int j = 0; j < n; ++j) g(i, j) = u(rng);
  return g;
}

/// k x m values uniform in [lo, hi].
inline Eigen::MatrixXd random_v(int k, int m, double lo, double hi, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(lo, hi);
  Eigen::MatrixXd v(k, m);
  for (int a = 0; a < k; ++a)
    for (int i = 0; i < m; ++i) v(a, i) = u(rng);
  return v;
}

}  // namespace xbarsim::test
