#pragma once
/// Synthetic kernels and inputs for single-crossbar studies (paper Fig. "Three kernel types").
#include <Eigen/Dense>
#include <cstdint>
#include <string>

namespace xbarsim {

/// rows x cols weights: gaussian N(0,1); bimodal +-(0.5 + |N(0, 0.5)|) (no near-zero
/// weights, as pruning-style training produces); ternary -1/0/1 with equal probability.
Eigen::MatrixXd synthetic_kernel(const std::string& type, int rows, int cols, uint64_t seed);

/// count x rows inputs uniform in [0, x_max] with a fraction `sparsity` of exact zeros.
Eigen::MatrixXd synthetic_inputs(int count, int rows, double sparsity, double x_max, uint64_t seed);

}  // namespace xbarsim
