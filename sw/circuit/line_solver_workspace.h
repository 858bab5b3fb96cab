#pragma once
/// LineSolver internals shared by line_solver.cpp and line_solver_batch.cpp: per-thread scratch
/// buffers and two kernels.
#include <vector>

#include "sw/circuit/line_solver.h"

namespace xbarsim {

constexpr int kGmresRestart = 30;

/// a . b with eight partial sums in a fixed order (line_solver.cpp).
double line_dot(const double* a, const double* b, int n);

/// A Newton step's middle-node update from the node's own KCL row (both Newton solvers);
/// restrict-qualified so that it vectorises.
inline void middle_update(int mn, const double* __restrict gm, const double* __restrict ga, const double* __restrict gb,
                          const double* __restrict fm, const double* __restrict dt, const double* __restrict db,
                          double* __restrict dm) {
  for (int k = 0; k < mn; ++k) dm[k] = (fm[k] + gm[k] * dt[k] - gb[k] * db[k]) / (gm[k] + ga[k]);
}

struct LineSolver::Workspace {
  /// `krylov_basis`: GMRES (Newton steps) needs its restart basis; CG does not.
  Workspace(int mn, bool krylov_basis)
      : a(mn),
        b(mn),
        s(mn),
        r(mn),
        z(mn),
        p(mn),
        q(mn),
        v(krylov_basis ? (kGmresRestart + 1) * static_cast<size_t>(mn) : 0) {}
  static double doubles(int mn, bool krylov_basis) { return (7.0 + (krylov_basis ? kGmresRestart + 1 : 0)) * mn; }
  std::vector<double> a, b;        // schur_apply scratch
  std::vector<double> s;           // Schur right-hand side
  std::vector<double> r, z, p, q;  // Krylov vectors
  std::vector<double> v;           // GMRES basis
};

}  // namespace xbarsim
