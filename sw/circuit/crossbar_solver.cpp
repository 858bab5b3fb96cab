#include "sw/circuit/crossbar_solver.h"

#include <cmath>
#include <exception>
#include <mutex>
#include <sstream>
#include <thread>
#include <vector>

#include "sw/circuit/line_solver.h"
#include "sw/circuit/nodal_solver.h"

namespace xbarsim {

void CrossbarSolver::store_conductances(const Eigen::MatrixXd& g_s) {
  if (g_s.rows() < 1 || g_s.cols() < 1) throw InputError("conductance matrix is empty");
  for (Eigen::Index i = 0; i < g_s.rows(); ++i)
    for (Eigen::Index j = 0; j < g_s.cols(); ++j)
      if (!(std::isfinite(g_s(i, j)) && g_s(i, j) > 0)) {
        std::ostringstream os;
        os << "conductance at row " << i + 1 << ", column " << j + 1 << " is " << g_s(i, j)
           << " S; conductances must be finite and > 0";
        throw InputError(os.str());
      }
  g_ = g_s;
}

void CrossbarSolver::check_input(const Eigen::VectorXd& v_in) const {
  if (g_.size() == 0) throw InputError("crossbar solver used before program()");
  if (v_in.size() != g_.rows()) {
    std::ostringstream os;
    os << "input vector has " << v_in.size() << " voltages but the crossbar has " << g_.rows() << " rows";
    throw InputError(os.str());
  }
  for (Eigen::Index i = 0; i < v_in.size(); ++i)
    if (!std::isfinite(v_in(i))) throw InputError("input voltage " + std::to_string(i + 1) + " is not finite");
}

Eigen::MatrixXd CrossbarSolver::column_currents(const Eigen::MatrixXd& v_in) const {
  if (v_in.cols() != g_.rows()) {
    std::ostringstream os;
    os << "input vectors have " << v_in.cols() << " voltages but the crossbar has " << g_.rows() << " rows";
    throw InputError(os.str());
  }
  Eigen::MatrixXd out(v_in.rows(), g_.cols());
  if (params_.is_linear() && v_in.rows() > std::min(g_.rows(), g_.cols())) {
    out.noalias() = v_in * effective_matrix();
    return out;
  }
  parallel_for(static_cast<int>(v_in.rows()), resolve_threads(options_.threads), [&](int k) {
    out.row(k) = solve(v_in.row(k).transpose()).column_current.transpose();
  });
  return out;
}

void parallel_for(int count, int threads, const std::function<void(int)>& f) {
  threads = std::max(1, std::min(threads, count));
  if (threads == 1) {
    for (int k = 0; k < count; ++k) f(k);
    return;
  }
  std::exception_ptr error;
  std::mutex mu;
  std::vector<std::thread> pool;
  for (int t = 0; t < threads; ++t) {
    pool.emplace_back([&, t] {
      try {
        for (int k = t; k < count; k += threads) f(k);
      } catch (...) {
        std::lock_guard<std::mutex> lock(mu);
        if (!error) error = std::current_exception();
      }
    });
  }
  for (auto& th : pool) th.join();
  if (error) std::rethrow_exception(error);
}

std::unique_ptr<CrossbarSolver> make_crossbar_solver(const CrossbarParams& p, const SolverOptions& o) {
  if (o.method == "direct") return std::make_unique<NodalSolver>(p, o);
  return std::make_unique<LineSolver>(p, o);
}

}  // namespace xbarsim
