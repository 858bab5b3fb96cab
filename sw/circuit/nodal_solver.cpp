#include "sw/circuit/nodal_solver.h"
#include "sw/common/cancel.h"

#include <Eigen/SparseCholesky>
#include <Eigen/SparseLU>
#include <algorithm>
#include <cmath>
#include <sstream>

#include "sw/common/errors.h"

namespace xbarsim {

struct NodalSolver::Factor {
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt;
};

NodalSolver::NodalSolver(const CrossbarParams& p, const SolverOptions& o)
    : CrossbarSolver(p, o), memristor_(p.memristor), transistor_(p.transistor) {
  short_transistor_ = p.transistor.model == TransistorModel::None;
}

NodalSolver::~NodalSolver() = default;

void NodalSolver::add_conductance(std::vector<Eigen::Triplet<double>>& t, int a, int b, double g) const {
  if (a >= 0) t.emplace_back(a, a, g);
  if (b >= 0) t.emplace_back(b, b, g);
  if (a >= 0 && b >= 0) {
    t.emplace_back(a, b, -g);
    t.emplace_back(b, a, -g);
  }
}

void NodalSolver::add_wire(int a, int b, double g) {
  add_conductance(wire_triplets_, a, b, g);
  wire_branches_.push_back({a, b, g});
}

void NodalSolver::wire_residual(const Eigen::VectorXd& x, const Eigen::VectorXd& rhs, Eigen::VectorXd& f) const {
  if (!params_.voltage_sensing()) {
    f.noalias() = k_wire_ * x - rhs;
    return;
  }
  f = -rhs;
  for (const Branch& w : wire_branches_) {
    const double i = w.g * (x(w.a) - (w.b >= 0 ? x(w.b) : 0.0));
    f(w.a) += i;
    if (w.b >= 0) f(w.b) -= i;
  }
}

Eigen::VectorXd NodalSolver::solve_factored(const Eigen::VectorXd& rhs) const {
  Eigen::VectorXd x = factor_->ldlt.solve(rhs);
  if (factor_->ldlt.info() != Eigen::Success) throw SolverError("sparse Cholesky solve failed");
  if (!params_.voltage_sensing()) return x;
  // Iterative refinement: the factor's error on the floating columns' common mode shrinks by
  // ~eps x (wire / cell conductance) per step; stop when a step no longer halves it.
  Eigen::VectorXd f(unknowns_);
  double last = HUGE_VAL;
  for (int step = 0; step < 8; ++step) {
    residual(x, rhs, f, nullptr);
    const Eigen::VectorXd dx = factor_->ldlt.solve(f);
    const double d = dx.cwiseAbs().maxCoeff();
    if (!(d < 0.5 * last)) break;
    x -= dx;
    last = d;
  }
  return x;
}

void NodalSolver::program(const Eigen::MatrixXd& g_s) {
  store_conductances(g_s);
  {
    // Unknowns, the wire matrix and its sparse factor (fill grows with the shorter side).
    const double nodes = 3.0 * g_s.size() + 2.0 * (g_s.rows() + g_s.cols());
    const double fill = std::min<double>(g_s.rows(), g_s.cols()) + 16;
    check_memory(nodes * (12.0 * 8 + 12.0 * fill + 64), "the direct solver on a " + std::to_string(g_s.rows()) + " x " +
                                                            std::to_string(g_s.cols()) + " crossbar");
  }
  m_ = static_cast<int>(g_s.rows());
  n_ = static_cast<int>(g_s.cols());
  base_ = (short_transistor_ ? 2 : 3) * m_ * n_;
  unknowns_ = base_ + 2 * m_ + 2 * n_;
  const double gw = 1.0 / params_.r_wire_ohm;
  wire_triplets_.clear();
  wire_branches_.clear();
  for (int i = 0; i < m_; ++i) {
    add_wire(node_row_left(i), -1, 1.0 / params_.r_in_ohm);  // source side
    add_wire(node_row_left(i), node_top(i, 0), gw);
    for (int j = 0; j + 1 < n_; ++j) add_wire(node_top(i, j), node_top(i, j + 1), gw);
    add_wire(node_top(i, n_ - 1), node_row_right(i), gw);
  }
  for (int j = 0; j < n_; ++j) {
    add_wire(node_col_top(j), node_bottom(0, j), gw);
    for (int i = 0; i + 1 < m_; ++i) add_wire(node_bottom(i, j), node_bottom(i + 1, j), gw);
    add_wire(node_bottom(m_ - 1, j), node_col_bottom(j), gw);
    // Voltage sensing: D_j is open (r_out leads to a node with nothing else on it).
    if (!params_.voltage_sensing()) add_wire(node_col_bottom(j), -1, 1.0 / params_.r_out_ohm);
  }
  k_wire_.resize(unknowns_, unknowns_);
  k_wire_.setFromTriplets(wire_triplets_.begin(), wire_triplets_.end());

  factor_.reset();
  if (params_.is_linear()) {
    std::vector<Eigen::Triplet<double>> t = wire_triplets_;
    for (int i = 0; i < m_; ++i)
      for (int j = 0; j < n_; ++j) {
        if (short_transistor_) {
          add_conductance(t, node_top(i, j), node_bottom(i, j), g_(i, j));
        } else {
          add_conductance(t, node_top(i, j), node_mid(i, j), g_(i, j));
          add_conductance(t, node_mid(i, j), node_bottom(i, j), 1.0 / params_.transistor.r_on_ohm);
        }
      }
    Eigen::SparseMatrix<double> k(unknowns_, unknowns_);
    k.setFromTriplets(t.begin(), t.end());
    factor_ = std::make_unique<Factor>();
    factor_->ldlt.compute(k);
    if (factor_->ldlt.info() != Eigen::Success)
      throw SolverError("sparse Cholesky factorization of the crossbar nodal matrix failed");
  }
}

Eigen::VectorXd NodalSolver::source_rhs(const Eigen::VectorXd& v_in) const {
  Eigen::VectorXd rhs = Eigen::VectorXd::Zero(unknowns_);
  for (int i = 0; i < m_; ++i) rhs(node_row_left(i)) = v_in(i) / params_.r_in_ohm;
  return rhs;
}

CircuitSolution NodalSolver::extract(const Eigen::VectorXd& x) const {
  CircuitSolution s = CircuitSolution::sized(m_, n_);
  for (int i = 0; i < m_; ++i)
    for (int j = 0; j < n_; ++j) {
      s.v_top(i, j) = x(node_top(i, j));
      s.v_mid(i, j) = x(node_mid(i, j));
      s.v_bottom(i, j) = x(node_bottom(i, j));
      double c, d;
      memristor_.eval(g_(i, j), s.v_top(i, j) - s.v_mid(i, j), c, d);
      s.cell_current(i, j) = c;
    }
  const bool open = params_.voltage_sensing();
  for (int j = 0; j < n_; ++j) {
    s.column_voltage(j) = x(node_col_bottom(j));
    s.column_current(j) = open ? 0.0 : x(node_col_bottom(j)) / params_.r_out_ohm;
  }
  return s;
}

CircuitSolution NodalSolver::solve(const Eigen::VectorXd& v_in) const {
  check_input(v_in);
  if (!params_.is_linear()) return solve_nonlinear(v_in);
  return extract(solve_factored(source_rhs(v_in)));
}

Eigen::MatrixXd NodalSolver::effective_matrix() const {
  if (!params_.is_linear()) throw SolverError("the effective conductance matrix exists only for linear devices");
  // Unit input on each row: row i of G_eff is the column-current response (of A, the
  // column-end voltages').
  Eigen::MatrixXd rhs = Eigen::MatrixXd::Zero(unknowns_, m_);
  for (int i = 0; i < m_; ++i) rhs(node_row_left(i), i) = 1.0 / params_.r_in_ohm;
  Eigen::MatrixXd x(unknowns_, m_);
  if (params_.voltage_sensing())
    for (int i = 0; i < m_; ++i) x.col(i) = solve_factored(rhs.col(i));
  else
    x = factor_->ldlt.solve(rhs);
  Eigen::MatrixXd geff(m_, n_);
  for (int i = 0; i < m_; ++i)
    for (int j = 0; j < n_; ++j)
      geff(i, j) = params_.voltage_sensing() ? x(node_col_bottom(j), i) : x(node_col_bottom(j), i) / params_.r_out_ohm;
  return geff;
}

void NodalSolver::residual(const Eigen::VectorXd& x, const Eigen::VectorXd& rhs, Eigen::VectorXd& f,
                           std::vector<Eigen::Triplet<double>>* jac) const {
  wire_residual(x, rhs, f);
  if (jac) *jac = wire_triplets_;
  for (int i = 0; i < m_; ++i)
    for (int j = 0; j < n_; ++j) {
      const int t = node_top(i, j), mid = node_mid(i, j), b = node_bottom(i, j);
      double im, gm;
      memristor_.eval(g_(i, j), x(t) - x(mid), im, gm);
      f(t) += im;
      f(mid) -= im;
      if (jac) add_conductance(*jac, t, mid, gm);
      if (!short_transistor_) {
        double it, ga, gb;
        transistor_.eval(x(mid), x(b), it, ga, gb);
        f(mid) += it;
        f(b) -= it;
        if (jac) {
          jac->emplace_back(mid, mid, ga);
          jac->emplace_back(mid, b, gb);
          jac->emplace_back(b, mid, -ga);
          jac->emplace_back(b, b, -gb);
        }
      }
    }
}

CircuitSolution NodalSolver::solve_nonlinear(const Eigen::VectorXd& v_in) const {
  const Eigen::VectorXd rhs = source_rhs(v_in);
  const double v_scale = std::max(v_in.cwiseAbs().maxCoeff(), 1e-3);
  const double kcl_tol = kcl_tolerance(v_scale);
  Eigen::VectorXd x = Eigen::VectorXd::Zero(unknowns_), f(unknowns_), f_new(unknowns_), x_new;
  std::vector<Eigen::Triplet<double>> trip;
  Eigen::SparseMatrix<double> jac(unknowns_, unknowns_);
  Eigen::SparseLU<Eigen::SparseMatrix<double>, Eigen::COLAMDOrdering<int>> lu;
  bool analyzed = false;
  double last_step = 0;
  residual(x, rhs, f, &trip);
  for (int it = 1; it <= options_.newton_max_iterations; ++it) {
    check_cancel();
    jac.setFromTriplets(trip.begin(), trip.end());
    if (!analyzed) {
      lu.analyzePattern(jac);
      analyzed = true;
    }
    lu.factorize(jac);
    if (lu.info() != Eigen::Success) throw SolverError("sparse LU factorization of the Newton Jacobian failed");
    Eigen::VectorXd dx = lu.solve(-f);
    const double dmax = dx.cwiseAbs().maxCoeff();
    if (dmax > options_.max_step_v) dx *= options_.max_step_v / dmax;
    double alpha = 1.0;
    const double f_norm = f.norm();
    for (int ls = 0; ls < 20; ++ls) {
      x_new = x + alpha * dx;
      residual(x_new, rhs, f_new, nullptr);
      if (f_new.norm() <= f_norm || alpha * dmax < 1e-9) break;
      alpha *= 0.5;
    }
    x = x_new;
    last_step = alpha * std::min(dmax, options_.max_step_v);
    residual(x, rhs, f, &trip);
    // Converged only when the update is small AND every node balances its currents.
    if (last_step <= options_.newton_tolerance * v_scale && f.cwiseAbs().maxCoeff() <= kcl_tol) {
      CircuitSolution s = extract(x);
      s.newton_iterations = it;
      return s;
    }
  }
  std::ostringstream os;
  os << "Newton-Raphson (direct solver) did not converge in " << options_.newton_max_iterations
     << " iterations (solver.newton_max_iterations): last update " << last_step << " V, KCL residual "
     << f.cwiseAbs().maxCoeff() << " A (needs <= " << options_.newton_tolerance * v_scale << " V and <= " << kcl_tol
     << " A)";
  throw SolverError(os.str());
}

}  // namespace xbarsim
