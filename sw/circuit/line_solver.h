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
/// Voltage sensing (crossbar.sensing = voltage) leaves both ends of a column open: the chain is
/// then grounded only through its cells, far weaker than its wires. Its pivots are computed as
/// wire + (conductance to ground seen below), the latter by series/parallel combination without
/// subtraction, and the Schur operator applies the column wires to voltage differences
/// (g_w (b_i - b_i+1) ...), so that neither loses the cells' currents against the wires'.
///
/// Many vectors with nonlinear devices (column_currents, solver.nonlinear = batched) use a
/// leaner inexact Newton (line_solver_batch.cpp) than the per-vector reference solve():
///  - it starts at the ideal operating point (row wires at the source voltage, column wires at
///    0 V, middle nodes dividing the cell voltage between memristor and transistor) plus one
///    Jacobi step through the wires (the ideal cell currents' drops along the rows and rises
///    up the columns, by suffix and prefix sums);
///  - the devices are evaluated over the whole array at once: sinh from one vectorised exp,
///    the level-1 transistor branch-free;
///  - each step condenses the middle node into a 2x2 cell block and replaces the block's small
///    nonsymmetric part (the transistor's dependence on its source voltage, ~kp V_ds against
///    ~kp V_gst) by the smaller of its off-diagonal terms (which keeps the block PSD). The step
///    is then an SPD problem solved by PCG to a loose tolerance (its preconditioner leaves
///    ~1e-3 per iteration, so one or two iterations); the approximation only slows the outer iteration
///    by a factor of ~V_ds / V_gst per step, because the residual is always the exact KCL of
///    the full circuit;
///  - its buffers are allocated once per thread and reused for every vector.
/// A vector is done when the Newton error estimate of its column currents (last change x
/// contraction) is below solver.nonlinear_tolerance x its largest column current and every
/// node's KCL residual meets the per-vector Newton's tolerance. A vector it does not converge
/// on is solved again by the per-vector Newton; if that fails too, the error names it.
/// Interleaving 8 vectors for SIMD was measured slower: its 15 MB working set falls out of
/// the 2 MB L2 cache that one vector's fits in.
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
  /// Nonlinear devices: the batched inexact Newton above (solver.nonlinear = batched), falling
  /// back to the per-vector Newton for a vector it does not converge on; otherwise as CrossbarSolver.
  Eigen::MatrixXd column_currents(const Eigen::MatrixXd& v_in) const override;
  /// As column_currents, for the column-end voltages.
  Eigen::MatrixXd column_voltages(const Eigen::MatrixXd& v_in) const override;
  Eigen::MatrixXd effective_matrix() const override;

  /// Scratch buffers for one thread (sized for the programmed array).
  struct Workspace;

 private:
  /// Operator data of one linear system in the T/B form above.
  struct System {
    std::vector<double> p_inv;   ///< inverse pivots of the row tridiagonals (P)
    std::vector<double> q_diag;  ///< diagonal of Q
    std::vector<double> q_inv;   ///< inverse pivots of the column tridiagonals (Q, from the grounded end)
    std::vector<double> q_cell;  ///< voltage sensing: Q's cell terms (Q = column-wire Laplacian + diag(q_cell))
    std::vector<double> cx;      ///< X diagonal (row equation, column unknown)
    std::vector<double> cy;      ///< Y diagonal (column equation, row unknown); empty: Y = X
    bool symmetric = true;
    const double* y() const { return cy.empty() ? cx.data() : cy.data(); }
    /// Zeroed operator for `mn` cells; a symmetric one keeps cy empty (Y = X).
    void resize(size_t mn, bool is_symmetric) {
      for (auto* v : {&p_inv, &q_diag, &q_inv, &cx}) v->assign(mn, 0.0);
      q_cell.clear();
      cy.assign(is_symmetric ? 0 : mn, 0.0);
      symmetric = is_symmetric;
    }
  };
  void factor_rows(const double* extra, double* p_inv) const;
  void factor_cols(const double* extra, System& s) const;
  /// factor_cols for floating columns (voltage sensing); also fills s.q_cell.
  void factor_floating_cols(const double* extra, System& s) const;
  /// The solution's column currents and voltages from the column-wire voltages b.
  void column_outputs(const double* b, CircuitSolution& s) const;
  void row_solve(const double* p_inv, const double* r, double* x) const;
  void col_solve(const double* q_inv, const double* r, double* x) const;
  void schur_apply(const System& s, const double* x, double* y, Workspace& w) const;
  /// Solves [P X; Y Q][t; b] = [r_T; r_B]; returns inner iterations.
  /// `tol`: relative residual of the Schur solve (PCG; GMRES uses solver.tolerance).
  int solve_tb(const System& s, const double* r_t, const double* r_b, double* t, double* b, Workspace& w,
               double tol) const;
  /// CG on S x = rhs; when `t` (holding P^-1 r_T) is given, it ends as P^-1 (r_T - X x).
  int pcg(const System& s, const double* rhs, double* x, Workspace& w, double tol, double* t = nullptr) const;
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
  // The batched inexact Newton (line_solver_batch.cpp).
  struct BatchState;
  /// The batched outputs of many vectors: column voltages (`voltages`) or currents.
  Eigen::MatrixXd batch_outputs(const Eigen::MatrixXd& v_in, bool voltages) const;
  /// Column outputs (out_gain_ x the column's last B node: currents or voltages) of v_in into
  /// `out` (n); false when it did not converge.
  bool batch_solve(const double* v_in, BatchState& st, Workspace& w, double* out) const;
  /// The ideal operating point plus one Jacobi step through the wires.
  void batch_start(const double* v_in, BatchState& st, Workspace& w) const;
  /// Cell currents (w.b memristor, w.s transistor) and derivatives at the iterate.
  void batch_devices(BatchState& st, Workspace& w) const;
  /// Exact KCL residuals and device derivatives at the iterate; the residuals' 2-norm and max.
  void batch_residual(const double* v_in, BatchState& st, Workspace& w, double& norm, double& fmax) const;
  /// The Newton update (dt, db, dm) of the condensed, symmetrised step; its largest |entry|.
  double batch_direction(BatchState& st, Workspace& w, double step_tol) const;
  Eigen::MatrixXd compute_effective_matrix() const;
  /// Estimated peak memory (in doubles) of programming and solving an m x n array.
  double memory_doubles(int m, int n) const;

  int m_ = 0, n_ = 0;
  double g_w_ = 1, g_s_ = 0.5, g_d_ = 0.5;  ///< wire, source-side and ground-side (0: voltage sensing) conductances (S)
  bool floating_ = false;                   ///< voltage sensing: the columns' ends are open
  double out_gain_ = 0.5;  ///< the sensed output per volt at B(m-1, j): g_d (A/V, current sensing) or 1 (voltage)
  MemristorDevice memristor_;
  TransistorDevice transistor_;
  System linear_;               ///< linear devices: the nodal system itself
  std::vector<double> g_cell_;  ///< linear cell conductances (S)
  mutable std::mutex geff_mutex_;
  mutable Eigen::MatrixXd geff_cache_;
};

}  // namespace xbarsim
