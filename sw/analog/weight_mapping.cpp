#include "sw/analog/weight_mapping.h"

#include <algorithm>

namespace xbarsim {

MappedWeights map_weights(const Eigen::MatrixXd& wb, const Block& blk, const MappingSpec& mapping,
                          const CrossbarParams& xbar) {
  MappedWeights m;
  m.blk = blk;
  // Conductance span for weights; the headroom above it is left for conversion.
  const double g_span = xbar.g_max_s * (1 - mapping.g_headroom) - xbar.g_min_s;
  if (mapping.differential()) {
    const double wmax = std::max(wb.cwiseAbs().maxCoeff(), 1e-300);
    m.s = g_span / wmax;
    m.a.resize(blk.rows, 2 * blk.cols);
    for (int j = 0; j < blk.cols; ++j) {
      m.a.col(2 * j) = wb.col(j).cwiseMax(0.0);
      m.a.col(2 * j + 1) = (-wb.col(j)).cwiseMax(0.0);
    }
  } else {
    m.w_lo = std::min(wb.minCoeff(), 0.0);
    double span = wb.maxCoeff() - m.w_lo;
    if (!(span > 0)) span = 1.0;
    m.s = g_span / span;
    m.a = wb.array() - m.w_lo;
  }
  if (mapping.analog_sum()) {
    m.a_sum = 0.5 * g_span / m.s;  // mid-range conductance
    m.a.conservativeResize(Eigen::NoChange, m.a.cols() + 1);
    m.a.col(m.a.cols() - 1).setConstant(m.a_sum);
  }
  m.pcols = static_cast<int>(m.a.cols());
  m.g_target = (xbar.g_min_s + m.s * m.a.array()).matrix();
  return m;
}

std::vector<Block> crossbar_blocks(int rows, int cols, const MappingSpec& mapping) {
  return partition(rows, cols, mapping.max_rows, mapping.logical_columns_per_crossbar());
}

}  // namespace xbarsim
