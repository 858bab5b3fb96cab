#include "sw/analog/partition.h"

namespace xbarsim {

std::vector<Block> partition(int rows, int cols, int max_rows, int max_cols) {
  const int pr = parts(rows, max_rows), pc = parts(cols, max_cols);
  std::vector<Block> out;
  out.reserve(static_cast<size_t>(pr) * pc);
  int r0 = 0;
  for (int a = 0; a < pr; ++a) {
    const int rn = rows / pr + (a < rows % pr ? 1 : 0);
    int c0 = 0;
    for (int b = 0; b < pc; ++b) {
      const int cn = cols / pc + (b < cols % pc ? 1 : 0);
      out.push_back({r0, rn, c0, cn});
      c0 += cn;
    }
    r0 += rn;
  }
  return out;
}

}  // namespace xbarsim
