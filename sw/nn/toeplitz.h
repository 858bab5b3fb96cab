#pragma once
/// Sparse (Toeplitz) mapping of a convolution for a given input size: one crossbar row per
/// input element and one column per output element, so a whole image is one
/// vector-matrix product (one iteration) at the cost of a huge, mostly empty array.
#include <Eigen/Sparse>

#include "sw/nn/model.h"

namespace xbarsim {

/// Rows: input elements in C x H x W order, r = (c*H + y)*W + x (in_h*in_w*c_in rows).
/// Columns: outputs, col = (oy*out_w + ox)*c_out + o. Uses the layer's stride and
/// padding (taps that fall into the padding are dropped); `valid` ignores the padding
/// (valid convolution, as in the paper's overhead table).
Eigen::SparseMatrix<float> toeplitz_matrix(const LinearLayer& L, bool valid = false);

}  // namespace xbarsim
