#pragma once
/// LineSolver's per-thread scratch buffers (shared by line_solver.cpp and line_solver_batch.cpp).
#include <vector>

#include "sw/circuit/line_solver.h"

namespace xbarsim {

constexpr int kGmresRestart = 30;

/// a . b with eight partial sums in a fixed order (line_solver.cpp).
double line_dot(const double* a, const double* b, int n);

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
