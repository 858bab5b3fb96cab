#pragma once
/// Weight mapping: one block of a weight matrix as target conductances of one crossbar
/// (section mapping.): the shift method (A = W - w_lo >= 0, removed digitally with sum(X))
/// or differential column pairs, an optional sum(X) reference column of equal conductance,
/// and the conductance headroom left above the weights for conversion. With quantized
/// weights on multi-level cells (mapping.weight_bits, crossbar.cell_bits) each polarity of a
/// weight is an integer code whose cell_bits-wide digits sit in adjacent columns, digit t
/// (place 2^(t cell_bits)) as a level of its cell; shift-and-add recombines them.
///
/// Physical column layout: weight column j, polarity p (0 = positive / shift, 1 = negative),
/// slice t is column (j * polarities + p) * slices + t; the sum(X) column is the last.
#include <Eigen/Dense>
#include <functional>

#include "sw/analog/analog_spec.h"
#include "sw/analog/ranging.h"
#include "sw/analog/partition.h"
#include "sw/circuit/crossbar_params.h"

namespace xbarsim {

struct MappedWeights {
  Block blk;
  int pcols = 0;             ///< physical columns (MappingSpec::physical_columns(blk.cols))
  int per_weight = 1;        ///< physical columns of one weight column (polarities x slices)
  double w_lo = 0;           ///< shift: A = W - w_lo (0 for differential)
  double a_sum = 0;          ///< analog sum column: its constant A
  /// The ADC's offset subtraction also removes the shift w_lo (analog cells with the shift
  /// method: the ADC converts the signed product); otherwise it removes only g_min sum(X).
  bool offset_has_w_lo = false;
  Eigen::MatrixXd a;         ///< non-negative mapped matrix, rows x pcols, in weight units
  Eigen::VectorXd s;         ///< per physical column: S per weight unit (g = g_min + s a)
  Eigen::VectorXd sign;      ///< per physical column: +1, or -1 for the negative column of a pair
  Eigen::MatrixXd g_target;  ///< S, g_min + a diag(s)
};

/// The range of weight values each weight column maps onto the conductance span (ranging.weights):
/// lo <= 0 <= hi per column. Differential pairs map max(-lo, hi) to the top of each polarity's span;
/// the shift maps [min lo, hi] of a crossbar's columns (one offset per crossbar, a span per column).
/// Weights outside are clipped to it.
struct WeightRanges {
  Eigen::VectorXd lo, hi;
  long long clipped = 0;  ///< weights outside their column's range
};

/// The variance (S^2) around its target g (S) of a cell's conductance as the network reads it
/// (the device's spread); null = exact cells.
using CellVariance = std::function<double(double)>;

/// The ranges of the columns of `w` (a crossbar's block, or a whole layer), with one range for
/// all of them (crossbar and layer scale) or one per column (column scale), by ranging.weights:
/// max (the columns' extremes), a percentile of |w|, or the mse clip: the clip c of |w| that
/// minimises the summed squared error of the weights as the cells hold them: the weight code's
/// rounding (mapping.weight_bits on cell levels), the clipping, and the cells' variance `var`
/// scaled to weight units (docs/physics.md, "Ranging").
WeightRanges weight_ranges(const Eigen::MatrixXd& w, const MappingSpec& mapping, const RangingSpec& ranging,
                           const CrossbarParams& xbar, const CellVariance& var = nullptr);

/// Maps `wb` (the weights of block `blk`) onto [g_min, g_max (1 - g_headroom)]; `ranges` (of the
/// block's columns) from weight_ranges; empty: the block's own extremes (nothing clipped).
MappedWeights map_weights(const Eigen::MatrixXd& wb, const Block& blk, const MappingSpec& mapping,
                          const CrossbarParams& xbar, const WeightRanges& ranges = {});

/// The crossbar blocks of a rows x cols weight matrix: the inventory's partition rule
/// (max_rows, and the weight columns one array of max_cols physical columns holds).
std::vector<Block> crossbar_blocks(int rows, int cols, const MappingSpec& mapping);

}  // namespace xbarsim
