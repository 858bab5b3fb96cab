#pragma once
/// Node voltages of the wires when every cell's current is known (SystemC-free, allocation-free).
#include "sw/circuit/crossbar_params.h"

namespace xbarsim {

/// Row-wire voltages T and column-wire voltages B of an m x n crossbar (row-major arrays, cell
/// (i, j) at i * n + j) when cell (i, j) draws cur from T(i, j) into B(i, j). The wires are the
/// only other elements, so the currents fix every node: the row-wire segment into T(i, j)
/// carries the currents at and beyond j (a suffix sum) from the source v_in[i] through r_in;
/// the column-wire segment below B(i, j) carries the currents at and above i (a prefix sum) to
/// the virtual ground through r_out. O(mn), no scratch (the sums are built in the outputs).
/// `vb_end` (n, not aliasing vb): the column-end voltages instead, for open columns (voltage
/// sensing, where the currents cannot fix them): B(m-1, j) = vb_end[j], and up from there.
inline void wire_voltages(const CrossbarParams& p, int m, int n, const double* v_in, const double* cur, double* vt,
                          double* vb, const double* vb_end = nullptr) {
  const double r_w = p.r_wire_ohm, r_s = p.r_in_ohm + p.r_wire_ohm, r_d = p.r_wire_ohm + p.r_out_ohm;
  for (int i = 0; i < m; ++i) {
    const double* c = cur + static_cast<long>(i) * n;
    double* t = vt + static_cast<long>(i) * n;
    double acc = 0;
    for (int j = n - 1; j >= 0; --j) t[j] = acc += c[j];  // suffix sums
    double v = v_in[i] - r_s * t[0];
    t[0] = v;
    for (int j = 1; j < n; ++j) t[j] = v -= r_w * t[j];
  }
  for (int j = 0; j < n; ++j) vb[j] = cur[j];  // prefix sums down each column
  for (int i = 1; i < m; ++i) {
    const long o = static_cast<long>(i) * n;
    for (int j = 0; j < n; ++j) vb[o + j] = vb[o - n + j] + cur[o + j];
  }
  const long bottom = static_cast<long>(m - 1) * n;
  for (int j = 0; j < n; ++j) vb[bottom + j] = vb_end ? vb_end[j] : vb[bottom + j] * r_d;
  for (int i = m - 2; i >= 0; --i) {
    const long o = static_cast<long>(i) * n;
    for (int j = 0; j < n; ++j) vb[o + j] = vb[o + n + j] + r_w * vb[o + j];
  }
}

}  // namespace xbarsim
