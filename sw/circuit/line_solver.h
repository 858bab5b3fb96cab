#pragma once
/// Fast structured solver for the crossbar circuit.
///
/// The middle nodes M(i,j) are condensed into their cell and the dangling/series boundary
/// nodes (L_i, R_i, U_j, D_j) are eliminated exactly, leaving the row-wire nodes T and the
/// column-wire nodes B. In that ordering the nodal (or Newton) matrix is
///     [ P  X ] [t]   [r_T]      P: one tridiagonal block per row wire (+ cell terms)
///     [ Y  Q ] [b] = [r_B]      Q: one tridiagonal block per column wire (+ cell terms)
/// with X, Y diagonal (the cells). The row wires are eliminated exactly (Thomas algorithm),
/// and the Schur complement S = Q - Y P^-1 X on the column nodes is solved by Krylov
/// iteration preconditioned with Q^-1 (line relaxation as a preconditioner): CG for linear
/// devices (S is SPD), GMRES for Newton steps (level-1 transistors make it nonsymmetric).
/// Every step is O(mn) and allocation-free; the preconditioned operator is I - Q^-1 Y P^-1 X,
/// whose spectrum is close to 1 because the cells are weak compared with the wires.
/// Column chains are eliminated from their grounded end, which keeps the pivots well
/// conditioned (a floating chain eliminated from its open end loses digits).
#include <mutex>
#include <vector>

#include "sw/circuit/crossbar_solver.h"
#include "sw/circuit/device_models.h"

namespace xbarsim {

class LineSolver : public CrossbarSolver {
 public:
  LineSolver(const CrossbarParams& p, const SolverOptions& o);

  void program(const Eigen::MatrixXd& g_s) override;
  CircuitSolution solve(const Eigen::VectorXd& v_in) const override;
  Eigen::MatrixXd effective_matrix() const override;

  /// Scratch buffers for one thread (sized for the programmed array).
  struct Workspace;

 private:
  /// Operator data of one linear system in the T/B form above.
  struct System {
    std::vector<double> p_inv;   ///< inverse pivots of the row tridiagonals (P)
    std::vector<double> q_diag;  ///< diagonal of Q
    std::vector<double> q_inv;   ///< inverse pivots of the column tridiagonals (Q, from the grounded end)
    std::vector<double> cx;      ///< X diagonal (row equation, column unknown)
    std::vector<double> cy;      ///< Y diagonal (column equation, row unknown)
    bool symmetric = true;
  };
  void factor_rows(const double* extra, double* p_inv) const;
  void factor_cols(const double* extra, double* q_diag, double* q_inv) const;
  void row_solve(const double* p_inv, const double* r, double* x) const;
  void col_solve(const double* q_inv, const double* r, double* x) const;
  void schur_apply(const System& s, const double* x, double* y, Workspace& w) const;
  /// Solves [P X; Y Q][t; b] = [r_T; r_B]; returns inner iterations.
  int solve_tb(const System& s, const double* r_t, const double* r_b, double* t, double* b, Workspace& w) const;
  int pcg(const System& s, const double* rhs, double* x, Workspace& w) const;
  int gmres(const System& s, const double* rhs, double* x, Workspace& w) const;
  CircuitSolution solve_linear(const Eigen::VectorXd& v_in, Workspace& w) const;
  CircuitSolution solve_newton(const Eigen::VectorXd& v_in, Workspace& w) const;
  // Steps of one Newton solve (damped, voltage-limited, on the condensed T/B system).
  struct NewtonState;
  /// KCL residuals (and device derivatives when `deriv`) at the iterate (or the trial); the 2-norm.
  double newton_residual(const Eigen::VectorXd& v_in, NewtonState& st, bool trial, bool deriv) const;
  /// The Newton update of every node; returns the inner Krylov iterations.
  int newton_direction(NewtonState& st, Workspace& w) const;
  /// Applies the limited, line-searched update; returns the largest voltage change taken.
  double newton_update(const Eigen::VectorXd& v_in, NewtonState& st, double f_norm) const;
  CircuitSolution newton_solution(const NewtonState& st) const;
  Eigen::MatrixXd compute_effective_matrix() const;
  /// Estimated peak memory (in doubles) of programming and solving an m x n array.
  double memory_doubles(int m, int n) const;

  int m_ = 0, n_ = 0;
  double g_w_ = 1, g_s_ = 0.5, g_d_ = 0.5;  ///< wire, source-side and ground-side conductances (S)
  MemristorDevice memristor_;
  TransistorDevice transistor_;
  System linear_;               ///< linear devices: the nodal system itself
  std::vector<double> g_cell_;  ///< linear cell conductances (S)
  mutable std::mutex geff_mutex_;
  mutable Eigen::MatrixXd geff_cache_;
};

}  // namespace xbarsim
