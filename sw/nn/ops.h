#pragma once
/// The network's operations (OpKind, sw/nn/model.h), each described once, in one table
/// (ops.cpp): what it computes on one image, which operation of a tile's digital units
/// performs it and what an output row of it costs them, whether its output can be negative
/// given its inputs, and how a pipeline stage streams its input rows. The ONNX reader
/// (onnx_model.cpp) keeps the other table: ONNX op types, their attributes and shapes, and the
/// operations each lowers to. A new operation is an OpKind, its row in ops.cpp and the ONNX
/// reader that produces it; a new ONNX op that lowers to existing operations is one entry of
/// the reader's table.
#include <vector>

#include "sw/nn/model.h"

namespace xbarsim {

/// How a pipeline stage streams an operation's input rows (platform/Pipeline.cpp): the rows
/// of an input that output row r needs, and how many its buffer holds when sized
/// automatically for groups of `grain` rows.
enum class RowRule {
  Layer,        ///< a linear layer: its kernel's rows (the layer's geometry, not the op's)
  Window,       ///< pooling: k_h rows from r s_h - p_t; the window plus a stride and a row per grain
  RowWise,      ///< row r of its input; two groups buffered
  Elementwise,  ///< row r of each input (an input of one row: that row); the whole map buffered,
                ///< the other branch may be late
  Channels,     ///< row r of every input (Concat); the whole map buffered
  Whole,        ///< every row (global pooling, flatten); the whole map buffered
  Pad,          ///< row r - pad_lo[1] (none in the padding); two groups buffered
  Slice,        ///< row start[1] + r step[1]; two groups buffered
};

/// One image's values of an operation's inputs (in op.in order) and its output.
using OpInputs = std::vector<const std::vector<float>*>;

struct OpInfo {
  /// The operation of a tile's digital units that performs it (an architecture's
  /// tile.units.<unit>.ops), "" when none does (data movement, or a tile's crossbars).
  const char* unit_op;
  RowRule rows;
  /// The digital unit operations of one output row (`out` the output's shape, `in0` the
  /// first input's).
  long long (*row_ops)(const Op& op, const Shape& out, const Shape& in0);
  /// Its output is non-negative, given which of its inputs are (`in_nonneg[k]` for op.in[k]).
  bool (*nonnegative)(const Op& op, const std::vector<bool>& in_nonneg);
  /// Computes it on one image (`shapes`: every value's, Model::values); nullptr for a linear
  /// layer, whose multiply a backend performs (sw/nn/network.h).
  void (*run)(const Op& op, const std::vector<Shape>& shapes, const OpInputs& xs, std::vector<float>& y);
};

/// The row of `k` in the table.
const OpInfo& op_info(OpKind k);

}  // namespace xbarsim
