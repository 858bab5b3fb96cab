#include "sw/analog/weight_mapping.h"

#include <algorithm>
#include <cmath>

namespace xbarsim {

MappedWeights map_weights(const Eigen::MatrixXd& wb, const Block& blk, const MappingSpec& mapping,
                          const CrossbarParams& xbar) {
  MappedWeights m;
  m.blk = blk;
  // Conductance span for weights; the headroom above it is left for conversion.
  const double g_span = xbar.g_max_s * (1 - mapping.g_headroom) - xbar.g_min_s;
  const int P = mapping.polarities(), T = mapping.weight_slices(), q_bits = mapping.code_bits();
  m.per_weight = P * T;
  m.pcols = mapping.physical_columns(blk.cols);
  m.offset_has_w_lo = !mapping.differential() && mapping.cell_bits == 0;
  // Each polarity as a non-negative matrix in weight units, and the range it spans.
  Eigen::MatrixXd pol[2];
  double range;
  if (mapping.differential()) {
    range = std::max(wb.cwiseAbs().maxCoeff(), 1e-300);
    pol[0] = wb.cwiseMax(0.0);
    pol[1] = (-wb).cwiseMax(0.0);
  } else {
    m.w_lo = std::min(wb.minCoeff(), 0.0);
    range = wb.maxCoeff() - m.w_lo;
    if (!(range > 0)) range = 1.0;
    pol[0] = wb.array() - m.w_lo;
  }
  const double code_max = q_bits ? std::ldexp(1.0, q_bits) - 1 : 0;
  const double dw = q_bits ? range / code_max : 0;  // weight units per code
  m.a.setZero(blk.rows, m.pcols);
  m.s.setConstant(m.pcols, g_span / range);
  m.sign.setOnes(m.pcols);
  for (int j = 0; j < blk.cols; ++j)
    for (int p = 0; p < P; ++p) {
      const int c0 = (j * P + p) * T;
      if (p == 1) m.sign.segment(c0, T).setConstant(-1.0);
      if (!q_bits) {
        m.a.col(c0) = pol[p].col(j);
        continue;
      }
      for (int r = 0; r < blk.rows; ++r) {
        const long code = static_cast<long>(std::min(std::floor(pol[p](r, j) / dw + 0.5), code_max));
        if (T == 1) {
          m.a(r, c0) = code * dw;
          continue;
        }
        for (int t = 0; t < T; ++t) {
          const long digit = (code >> (t * mapping.cell_bits)) & ((1L << mapping.cell_bits) - 1);
          m.a(r, c0 + t) = std::ldexp(dw, t * mapping.cell_bits) * digit;
        }
      }
      // Slice t's cell holds its digit as a level: g - g_min = digit x g_span / (2^cell_bits - 1).
      if (T > 1)
        for (int t = 0; t < T; ++t)
          m.s(c0 + t) = g_span / (std::ldexp(1.0, mapping.cell_bits) - 1) / std::ldexp(dw, t * mapping.cell_bits);
    }
  if (mapping.analog_sum()) {
    const int c = m.pcols - 1;
    // Mid-range conductance; with multi-level cells the level 2^(cell_bits - 1).
    const double fraction =
        mapping.cell_bits ? std::ldexp(1.0, mapping.cell_bits - 1) / (std::ldexp(1.0, mapping.cell_bits) - 1) : 0.5;
    m.a_sum = fraction * g_span / m.s(c);
    m.a.col(c).setConstant(m.a_sum);
  }
  m.g_target = ((m.a * m.s.asDiagonal()).array() + xbar.g_min_s).matrix();
  return m;
}

std::vector<Block> crossbar_blocks(int rows, int cols, const MappingSpec& mapping) {
  return partition(rows, cols, mapping.max_rows, mapping.logical_columns_per_crossbar());
}

}  // namespace xbarsim
