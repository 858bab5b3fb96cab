#include "sw/circuit/crossbar_solver.h"

#include "sw/common/cancel.h"
#include "sw/common/task_graph.h"

#include <unistd.h>

#include <algorithm>
#include <cstdio>

#include <cmath>
#include <condition_variable>
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
  if (g_s.rows() > kMaxDimension || g_s.cols() > kMaxDimension)
    throw InputError("a crossbar of " + std::to_string(g_s.rows()) + " x " + std::to_string(g_s.cols()) +
                     " is larger than " + std::to_string(kMaxDimension) + " rows or columns");
  // A cell far stronger than the wires makes the circuit singular in floating point (the
  // Krylov solvers then fail); physical memristors are many orders weaker than a wire.
  const double g_wire = 1.0 / std::min({params_.r_wire_ohm, params_.r_in_ohm, params_.r_out_ohm});
  const double g_hi = kMaxCellToWireRatio * g_wire, g_lo = 1e-30;
  for (Eigen::Index i = 0; i < g_s.rows(); ++i)
    for (Eigen::Index j = 0; j < g_s.cols(); ++j)
      if (!(std::isfinite(g_s(i, j)) && g_s(i, j) >= g_lo && g_s(i, j) <= g_hi)) {
        std::ostringstream os;
        os << "conductance at row " << i + 1 << ", column " << j + 1 << " is " << g_s(i, j)
           << " S; conductances must lie in [" << g_lo << ", " << g_hi << "] S (at most " << kMaxCellToWireRatio
           << " x the wire conductance 1/r_wire)";
        throw InputError(os.str());
      }
  g_ = g_s;
}

double CrossbarSolver::kcl_tolerance(double v_scale) const {
  const double g_wire = 1.0 / std::min({params_.r_wire_ohm, params_.r_in_ohm, params_.r_out_ohm});
  return options_.newton_abstol_a + options_.newton_tolerance * v_scale * g_wire;
}

void CrossbarSolver::check_memory(double bytes, const std::string& what) {
  const double page = static_cast<double>(sysconf(_SC_PAGESIZE));
  const double total = page * static_cast<double>(sysconf(_SC_PHYS_PAGES));
  std::ostringstream os;
  os.precision(3);
  os << what << " needs an estimated " << bytes / 1e9 << " GB of memory";
  if (total > 0 && bytes > 0.8 * total) {
    os << ", more than this machine can hold (" << total / 1e9 << " GB)";
    throw InputError(os.str());
  }
  if (bytes > 1e9) std::fprintf(stderr, "xbarsim: note: %s\n", os.str().c_str());
}

void CrossbarSolver::check_input(const Eigen::VectorXd& v_in) const {
  if (g_.size() == 0) throw InputError("crossbar solver used before program()");
  if (v_in.size() != g_.rows()) {
    std::ostringstream os;
    os << "input vector has " << v_in.size() << " voltages but the crossbar has " << g_.rows() << " rows";
    throw InputError(os.str());
  }
  const double k = params_.memristor.model == MemristorModel::Sinh ? params_.memristor.k_per_v : 0.0;
  for (Eigen::Index i = 0; i < v_in.size(); ++i) {
    if (!std::isfinite(v_in(i)) || std::abs(v_in(i)) > kMaxInputVoltage)
      throw InputError("input voltage " + std::to_string(i + 1) + " is " + std::to_string(v_in(i)) +
                       " V; inputs must be finite and within +-" + std::to_string(kMaxInputVoltage) + " V");
    if (k * std::abs(v_in(i)) > kMaxSinhArgument)
      throw InputError("input voltage " + std::to_string(i + 1) + " (" + std::to_string(v_in(i)) +
                       " V) times the sinh nonlinearity crossbar.memristor.k overflows the device model");
  }
}

Eigen::MatrixXd CrossbarSolver::solved_outputs(const Eigen::MatrixXd& v_in, bool voltages) const {
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
    const CircuitSolution s = solve(v_in.row(k).transpose());
    out.row(k) = (voltages ? s.column_voltage : s.column_current).transpose();
  });
  return out;
}

Eigen::MatrixXd CrossbarSolver::column_currents(const Eigen::MatrixXd& v_in) const {
  if (params_.voltage_sensing())
    throw InputError(
        "crossbar.sensing is voltage: the columns end open and carry no current; their outputs are the column "
        "voltages");
  return solved_outputs(v_in, false);
}

Eigen::MatrixXd CrossbarSolver::column_voltages(const Eigen::MatrixXd& v_in) const {
  if (!params_.voltage_sensing()) return column_currents(v_in) * params_.r_out_ohm;
  return solved_outputs(v_in, true);
}

double cell_power_w(const CircuitSolution& s) {
  return (s.cell_current.array() * (s.v_top - s.v_mid).array()).sum();
}

double source_power_w(const CircuitSolution& s, const Eigen::VectorXd& v_in) {
  return v_in.dot(s.cell_current.rowwise().sum());
}

void parallel_for(int count, int threads, const std::function<void(int)>& f) {
  threads = std::max(1, std::min(threads, count));
  if (threads == 1 || on_worker_thread()) {  // nested (e.g. a solve inside a parallel image loop): inline
    for (int k = 0; k < count; ++k) {
      check_cancel();
      f(k);
    }
    return;
  }
  std::exception_ptr error;
  std::mutex mu;
  std::condition_variable done_cv;
  int running = threads;
  CancelScope* const scope = CancelScope::current();  // the workers stop when it asks to
  std::vector<std::thread> pool;
  for (int t = 0; t < threads; ++t) {
    pool.emplace_back([&, t] {
      on_worker_thread() = true;
      CancelScope::Adopt adopt(scope);
      try {
        for (int k = t; k < count; k += threads) {
          check_cancel();
          f(k);
        }
      } catch (...) {
        std::lock_guard<std::mutex> lock(mu);
        if (!error) error = std::current_exception();
      }
      std::lock_guard<std::mutex> lock(mu);
      if (--running == 0) done_cv.notify_all();
    });
  }
  if (scope && scope->owned_here()) {  // the owner keeps checking while the workers run
    std::unique_lock<std::mutex> lock(mu);
    do {
      lock.unlock();
      try {
        scope->poll();  // calls the check when due
      } catch (...) {   // a stop: the workers see it at their next check
        lock.lock();
        if (!error) error = std::current_exception();
        continue;
      }
      lock.lock();
    } while (!done_cv.wait_for(lock, scope->interval(), [&] { return running == 0; }));
  }
  for (auto& th : pool) th.join();
  if (error) std::rethrow_exception(error);
}

std::unique_ptr<CrossbarSolver> make_crossbar_solver(const CrossbarParams& p, const SolverOptions& o) {
  if (o.method == SolverMethod::Direct) return std::make_unique<NodalSolver>(p, o);
  return std::make_unique<LineSolver>(p, o);
}

}  // namespace xbarsim
