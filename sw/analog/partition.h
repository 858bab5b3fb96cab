#pragma once
/// Partitioning of a weight matrix onto crossbars of bounded size; the partial outputs of
/// row blocks are summed digitally.
#include <cstddef>
#include <vector>

namespace xbarsim {

struct Block {
  int row0, rows, col0, cols;
};

/// Balanced split (block sizes differ by at most one) of rows x cols into blocks of at
/// most max_rows x max_cols; 0 = unbounded (one block along that dimension).
std::vector<Block> partition(int rows, int cols, int max_rows, int max_cols);

/// Number of parts of a balanced split of `size` into parts of at most `max_part`.
inline int parts(int size, int max_part) { return max_part <= 0 ? 1 : (size + max_part - 1) / max_part; }

}  // namespace xbarsim
