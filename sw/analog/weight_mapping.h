#pragma once
/// Weight mapping: one block of a weight matrix as target conductances of one crossbar
/// (section mapping.): the shift method (A = W - w_lo >= 0, removed digitally with sum(X))
/// or differential column pairs, an optional sum(X) reference column of equal conductance,
/// and the conductance headroom left above the weights for conversion.
#include <Eigen/Dense>

#include "sw/analog/analog_spec.h"
#include "sw/analog/partition.h"
#include "sw/circuit/crossbar_params.h"

namespace xbarsim {

struct MappedWeights {
  Block blk;
  int pcols = 0;             ///< physical columns (MappingSpec::physical_columns(blk.cols))
  double s = 1;              ///< S per weight unit
  double w_lo = 0;           ///< shift: A = W - w_lo
  double a_sum = 0;          ///< analog sum column: its constant A
  Eigen::MatrixXd a;         ///< non-negative mapped matrix, rows x pcols
  Eigen::MatrixXd g_target;  ///< S, g_min + s * a
};

/// Maps `wb` (the weights of block `blk`) onto [g_min, g_max (1 - g_headroom)].
MappedWeights map_weights(const Eigen::MatrixXd& wb, const Block& blk, const MappingSpec& mapping,
                          const CrossbarParams& xbar);

/// The crossbar blocks of a rows x cols weight matrix: the inventory's partition rule
/// (max_rows, and the weight columns one array of max_cols physical columns holds).
std::vector<Block> crossbar_blocks(int rows, int cols, const MappingSpec& mapping);

}  // namespace xbarsim
