#pragma once
/// Common interface of the crossbar circuit solvers.
#include <Eigen/Dense>
#include <functional>
#include <memory>
#include <string>

#include "sw/circuit/crossbar_params.h"

namespace xbarsim {

/// DC operating point of a crossbar for one input vector.
struct CircuitSolution {
  Eigen::MatrixXd v_top;           ///< V, T(i,j): row-wire node of cell (i,j)
  Eigen::MatrixXd v_mid;           ///< V, M(i,j): between memristor and access transistor
  Eigen::MatrixXd v_bottom;        ///< V, B(i,j): column-wire node of cell (i,j)
  Eigen::MatrixXd cell_current;    ///< A, memristor current T -> M
  Eigen::VectorXd column_current;  ///< A, current through r_out of each column (0 with voltage sensing)
  /// V, the column-end node D_j: the output with voltage sensing (the settled open column);
  /// r_out times the column current with current sensing.
  Eigen::VectorXd column_voltage;
  int newton_iterations = 0;  ///< 0 for linear circuits
  /// A solution of an m x n crossbar with every matrix sized (values unset).
  static CircuitSolution sized(int m, int n) {
    CircuitSolution s;
    s.v_top.resize(m, n);
    s.v_mid.resize(m, n);
    s.v_bottom.resize(m, n);
    s.cell_current.resize(m, n);
    s.column_current.resize(n);
    s.column_voltage.resize(n);
    return s;
  }
  int linear_iterations = 0;  ///< total inner iterations (structured solver)
};

/// Solves the m x n 1T1M crossbar circuit for programmed conductances.
class CrossbarSolver {
 public:
  static constexpr int kMaxDimension = 1 << 20;       ///< rows or columns of one crossbar
  static constexpr double kMaxCellToWireRatio = 1e4;  ///< cell conductance / wire conductance
  static constexpr double kMaxInputVoltage = 1e3;     ///< V

  virtual ~CrossbarSolver() = default;

  /// Programs the nominal conductances (S), m x n. Throws InputError for values that are not
  /// finite, not positive or above kMaxCellToWireRatio / r_wire, and for arrays whose
  /// estimated memory this machine cannot hold. Precomputes what is reused across vectors.
  virtual void program(const Eigen::MatrixXd& g_s) = 0;

  /// Operating point for one input vector of m row voltages (V).
  virtual CircuitSolution solve(const Eigen::VectorXd& v_in) const = 0;

  /// Column currents (A) for a batch of input vectors: k x m voltages -> k x n currents.
  /// Linear devices use the effective matrix when it is cheaper; batches run on all threads.
  /// With voltage sensing the columns carry no current: InputError (use column_voltages).
  virtual Eigen::MatrixXd column_currents(const Eigen::MatrixXd& v_in) const;

  /// Column-end voltages (V, CircuitSolution::column_voltage) for a batch of input vectors:
  /// k x m voltages -> k x n voltages; the outputs with voltage sensing (r_out times the
  /// column currents with current sensing). Computed as column_currents is.
  virtual Eigen::MatrixXd column_voltages(const Eigen::MatrixXd& v_in) const;

  /// The sensed outputs: column_currents (A) with current sensing, column_voltages (V) with
  /// voltage sensing.
  Eigen::MatrixXd column_outputs(const Eigen::MatrixXd& v_in) const {
    return params_.voltage_sensing() ? column_voltages(v_in) : column_currents(v_in);
  }

  /// Effective matrix of the sensed outputs, for linear devices only (throws SolverError
  /// otherwise), exact up to the solver's tolerance: current sensing, the conductances G_eff
  /// (m x n, S) with I = V * G_eff; voltage sensing, the gains A (m x n, dimensionless) with
  /// V_col = V * A (with ideal wires A_ij = G_ij / sum_k G_kj).
  virtual Eigen::MatrixXd effective_matrix() const = 0;

  int rows() const { return static_cast<int>(g_.rows()); }
  int cols() const { return static_cast<int>(g_.cols()); }
  const Eigen::MatrixXd& conductances() const { return g_; }
  const CrossbarParams& params() const { return params_; }
  const SolverOptions& options() const { return options_; }

 protected:
  CrossbarSolver(const CrossbarParams& p, const SolverOptions& o) : params_(p), options_(o) {}
  /// Validates and stores g; shared by implementations.
  void store_conductances(const Eigen::MatrixXd& g_s);
  void check_input(const Eigen::VectorXd& v_in) const;
  /// The column voltages or currents of a batch (InputError unless it has one voltage per
  /// row): through the effective matrix for linear devices when that is cheaper, else vector
  /// by vector on all threads.
  Eigen::MatrixXd solved_outputs(const Eigen::MatrixXd& v_in, bool voltages) const;
  /// A, the largest KCL residual (any node) that Newton accepts at convergence, for inputs
  /// of magnitude up to `v_scale`: abstol + newton_tolerance * v_scale * largest wire conductance.
  double kcl_tolerance(double v_scale) const;
  /// Throws InputError when `bytes` (the solver's estimate for `what`) exceeds what this
  /// machine can hold; prints a note on stderr for estimates above 1 GB.
  static void check_memory(double bytes, const std::string& what);

  CrossbarParams params_;
  SolverOptions options_;
  Eigen::MatrixXd g_;
};

/// Power (W) dissipated in the memristors of a solution: sum over cells of
/// cell_current * (v_top - v_mid). The access transistors' share, cell_current *
/// (v_mid - v_bottom), is not included. With ideal wires and linear cells it is
/// sum_ij G_ij (V_i - V_col,j)^2 (voltage sensing) or sum_ij G_ij V_i^2 (current sensing).
double cell_power_w(const CircuitSolution& s);

/// Power (W) the row sources deliver to a solution for inputs `v_in`: sum over rows of
/// V_i x the current the row's cells draw (by KCL, what flows in through r_in): the cells',
/// transistors' and wires' dissipation together. With ideal wires it is cell_power_w.
double source_power_w(const CircuitSolution& s, const Eigen::VectorXd& v_in);

/// The solver selected by options.method: "auto"/"line" -> LineSolver, "direct" -> NodalSolver.
std::unique_ptr<CrossbarSolver> make_crossbar_solver(const CrossbarParams& p, const SolverOptions& o);

/// Runs f(k) for k in [0, count) on `threads` threads (k = t, t + threads, ...). Exceptions
/// propagate. Called from inside another parallel_for it runs inline: the cores are taken.
void parallel_for(int count, int threads, const std::function<void(int)>& f);

}  // namespace xbarsim
