#pragma once
/// Reference solver: modified nodal analysis of the full crossbar circuit with every node
/// of the topology as an unknown (3mn+2m+2n; 2mn+2m+2n when the transistor is a short).
/// Linear devices: sparse symmetric positive-definite system, factorized once per
/// programming (Eigen SimplicialLDLT, AMD ordering) and reused for every input vector.
/// Nonlinear devices: damped Newton-Raphson with voltage limiting, sparse LU per iteration.
/// This is the general sparse direct baseline; LineSolver is the fast structured solver.
/// Voltage sensing leaves the columns grounded only through their cells, far weaker than the
/// wires: there the KCL residuals take each wire's current from its voltage difference (the
/// assembled matrix times x would lose the cells' currents against the wires'), and linear
/// solves are refined with that residual until the correction stops shrinking.
#include <Eigen/Sparse>
#include <memory>
#include <vector>

#include "sw/circuit/crossbar_solver.h"
#include "sw/circuit/device_models.h"

namespace xbarsim {

class NodalSolver : public CrossbarSolver {
 public:
  NodalSolver(const CrossbarParams& p, const SolverOptions& o);
  ~NodalSolver() override;

  void program(const Eigen::MatrixXd& g_s) override;
  CircuitSolution solve(const Eigen::VectorXd& v_in) const override;
  Eigen::MatrixXd effective_matrix() const override;

  /// Number of unknown node voltages of the full system.
  int unknowns() const { return unknowns_; }

  // Node indices (after merging M into B when the transistor is a short).
  int node_top(int i, int j) const { return i * n_ + j; }
  int node_mid(int i, int j) const { return short_transistor_ ? node_bottom(i, j) : m_ * n_ + i * n_ + j; }
  int node_bottom(int i, int j) const { return (short_transistor_ ? 1 : 2) * m_ * n_ + i * n_ + j; }
  int node_row_left(int i) const { return base_ + i; }
  int node_row_right(int i) const { return base_ + m_ + i; }
  int node_col_top(int j) const { return base_ + 2 * m_ + j; }
  int node_col_bottom(int j) const { return base_ + 2 * m_ + n_ + j; }

 private:
  void add_conductance(std::vector<Eigen::Triplet<double>>& t, int a, int b, double g) const;
  /// A wire (or r_in, r_out: b = -1 for ground) of the linear part.
  void add_wire(int a, int b, double g);
  /// The linear part's currents leaving each node minus the sources': k_wire x - rhs, with
  /// voltage sensing summed branch by branch on voltage differences.
  void wire_residual(const Eigen::VectorXd& x, const Eigen::VectorXd& rhs, Eigen::VectorXd& f) const;
  /// Linear devices: the factor's solution of K x = rhs, refined with `residual` (voltage sensing).
  Eigen::VectorXd solve_factored(const Eigen::VectorXd& rhs) const;
  Eigen::VectorXd source_rhs(const Eigen::VectorXd& v_in) const;
  CircuitSolution extract(const Eigen::VectorXd& x) const;
  CircuitSolution solve_nonlinear(const Eigen::VectorXd& v_in) const;
  /// Residual of KCL (sum of currents leaving each node) and optionally the Jacobian.
  void residual(const Eigen::VectorXd& x, const Eigen::VectorXd& rhs, Eigen::VectorXd& f,
                std::vector<Eigen::Triplet<double>>* jac) const;

  int m_ = 0, n_ = 0, base_ = 0, unknowns_ = 0;
  bool short_transistor_ = false;
  MemristorDevice memristor_;
  TransistorDevice transistor_;
  std::vector<Eigen::Triplet<double>> wire_triplets_;  ///< linear part (wires, r_in, r_out)
  struct Branch {
    int a, b;  ///< nodes (b = -1: ground)
    double g;  ///< S
  };
  std::vector<Branch> wire_branches_;  ///< the same, branch by branch
  Eigen::SparseMatrix<double> k_wire_;
  struct Factor;
  std::unique_ptr<Factor> factor_;
};

}  // namespace xbarsim
