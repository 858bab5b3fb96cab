// LineSolver: the batched inexact Newton for many vectors with nonlinear devices (see
// line_solver.h). It shares the linear algebra (factorizations, PCG on the Schur complement)
// of the linear and per-vector Newton solves.
#include <algorithm>
#include <cmath>

#include "sw/circuit/line_solver.h"
#include "sw/common/cancel.h"
#include "sw/circuit/line_solver_workspace.h"
#include "sw/circuit/wire_voltages.h"
#include "sw/common/errors.h"

namespace xbarsim {

namespace {
/// Relative residual of each Newton step's PCG solve (the preconditioner leaves ~1e-3 per
/// iteration, so this is one or two iterations).
constexpr double kStepTolerance = 1e-4;
/// The first step's error is dominated by the quadratic term: a looser solve costs nothing.
constexpr double kFirstStepTolerance = 1e-2;
using Arr = Eigen::Map<Eigen::ArrayXd>;

// The per-cell loops of a Newton step, with restrict-qualified parameters so that they
// vectorise (through the state's std::vectors GCC cannot prove the arrays distinct).

/// No transistor: the memristor alone between T and B; right-hand sides negated in place.
void condense_short(int mn, const double* __restrict gm, double* __restrict jtt, double* __restrict jbb,
                    double* __restrict cx, double* __restrict ft, double* __restrict fb) {
  for (int k = 0; k < mn; ++k) {
    jtt[k] = gm[k];
    jbb[k] = gm[k];
    cx[k] = -gm[k];
    ft[k] = -ft[k];
    fb[k] = -fb[k];
  }
}

/// Middle node condensed into a 2x2 block; its off-diagonal made symmetric with the smaller
/// term (which keeps the block PSD); ft, fb become the condensed right-hand sides in place.
void condense_cell(int mn, const double* __restrict gm, const double* __restrict ga, const double* __restrict gb,
                   const double* __restrict fm, double* __restrict jtt, double* __restrict jbb, double* __restrict cx,
                   double* __restrict ft, double* __restrict fb) {
  for (int k = 0; k < mn; ++k) {
    const double inv = 1.0 / (gm[k] + ga[k]), c = gm[k] * inv;
    const double gs = ga[k] < -gb[k] ? ga[k] : -gb[k];
    jtt[k] = ga[k] * c;
    jbb[k] = -gb[k] * c;
    cx[k] = -c * gs;
    ft[k] = -ft[k] + c * fm[k];
    fb[k] = -fb[k] + ga[k] * inv * fm[k];
  }
}

}  // namespace

/// One thread's iterate, residuals, device derivatives and Newton system (reused per vector).
struct LineSolver::BatchState {
  BatchState(int mn, const double* g_cells, const double* start_ratio)
      : vt(mn),
        vm(mn),
        vb(mn),
        ft(mn),
        fm(mn),
        fb(mn),
        gm(mn),
        ga(mn),
        gb(mn),
        dt(mn),
        db(mn),
        dm(mn),
        g(g_cells),
        ratio(start_ratio),
        exp_kv(mn) {
    sys.resize(mn, true);
  }
  std::vector<double> vt, vm, vb;  ///< V, iterate (T, M, B nodes)
  std::vector<double> ft, fm, fb;  ///< A, KCL residuals; ft, fb become the step's right-hand sides
  std::vector<double> gm, ga, gb;  ///< memristor dI/dV, transistor dI/dV_M, dI/dV_B
  std::vector<double> dt, db, dm;  ///< V, Newton update
  const double* g;                 ///< S, conductances (row-major like the node arrays; shared)
  const double* ratio;             ///< (V_M - V_B) / (V_T - V_B) of each cell at small signal (shared)
  Eigen::ArrayXd exp_kv;           ///< exp(k V) of every memristor
  System sys;
};

Eigen::MatrixXd LineSolver::column_currents(const Eigen::MatrixXd& v_in) const {
  if (floating_ || params_.is_linear() || !options_.batched_nonlinear || v_in.rows() == 0 || v_in.cols() != m_)
    return CrossbarSolver::column_currents(v_in);
  return batch_outputs(v_in, false);
}

Eigen::MatrixXd LineSolver::column_voltages(const Eigen::MatrixXd& v_in) const {
  if (!floating_ || params_.is_linear() || !options_.batched_nonlinear || v_in.rows() == 0 || v_in.cols() != m_)
    return CrossbarSolver::column_voltages(v_in);
  return batch_outputs(v_in, true);
}

Eigen::MatrixXd LineSolver::batch_outputs(const Eigen::MatrixXd& v_in, bool voltages) const {
  for (Eigen::Index k = 0; k < v_in.rows(); ++k) check_input(v_in.row(k).transpose());
  const int count = static_cast<int>(v_in.rows());
  const int threads = std::max(1, std::min(resolve_threads(options_.threads), count));
  // Row-major inputs and outputs: one contiguous vector each.
  const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> v = v_in;
  Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> out(count, n_);
  const int mn = m_ * n_;
  // Read-only for every thread: the conductances and the starting point's voltage divider.
  std::vector<double> g(mn), ratio(mn, 0.0);
  const double g_t0 = transistor_.is_short() ? 0.0 : transistor_.g0();
  for (int i = 0; i < m_; ++i)
    for (int j = 0; j < n_; ++j) {
      const int k = i * n_ + j;
      g[k] = g_(i, j);
      const double g_m0 = memristor_.g0(g[k]);
      if (!transistor_.is_short()) ratio[k] = g_m0 / (g_m0 + g_t0);
    }
  parallel_for(threads, threads, [&](int tid) {
    BatchState st(mn, g.data(), ratio.data());
    Workspace w(mn, false);
    for (int k = tid; k < count; k += threads) {
      check_cancel();
      try {
        if (batch_solve(v.row(k).data(), st, w, out.row(k).data())) continue;
      } catch (const SolverError&) {  // an inner solve failed: as for non-convergence
      }
      try {  // the reference per-vector Newton
        const CircuitSolution s = solve(v.row(k).transpose());
        out.row(k) = (voltages ? s.column_voltage : s.column_current).transpose();
      } catch (const SolverError& e) {
        throw SolverError("input vector " + std::to_string(k + 1) +
                          ": neither the batched nor the per-vector Newton converged: " + e.what());
      }
    }
  });
  return out;
}

void LineSolver::batch_start(const double* v_in, BatchState& st, Workspace& w) const {
  // Ideal wires: T at the source voltage, B at 0 V, the middle node dividing the cell voltage
  // between memristor and transistor (small signal).
  const bool short_tr = transistor_.is_short();
  const double* ratio = st.ratio;
  // Open columns (voltage sensing): each at the voltage where its cells' small-signal currents
  // cancel, sum_i g0_ij (V_i - V_j) = 0 (st.dt as scratch).
  double* v_end = floating_ ? st.dt.data() : nullptr;
  if (floating_) {
    double* den = st.db.data();
    std::fill(v_end, v_end + n_, 0.0);
    std::fill(den, den + n_, 0.0);
    const double g_t0 = transistor_.is_short() ? 0.0 : transistor_.g0();
    for (int i = 0; i < m_; ++i)
      for (int j = 0; j < n_; ++j) {
        const double g_m0 = memristor_.g0(st.g[i * n_ + j]);
        const double g0 = transistor_.is_short() ? g_m0 : g_m0 * g_t0 / (g_m0 + g_t0);
        v_end[j] += g0 * v_in[i];
        den[j] += g0;
      }
    for (int j = 0; j < n_; ++j) v_end[j] /= den[j];
  }
  for (int i = 0; i < m_; ++i)
    for (int j = 0; j < n_; ++j) {
      const int k = i * n_ + j;
      const double vb = floating_ ? v_end[j] : 0.0;
      st.vt[k] = v_in[i];
      st.vb[k] = vb;
      st.vm[k] = vb + ratio[k] * (v_in[i] - vb);
    }
  // One Jacobi step through the wires: the node voltages that the ideal cell currents imply.
  batch_devices(st, w);
  wire_voltages(params_, m_, n_, v_in, w.b.data(), st.vt.data(), st.vb.data(), v_end);
  const int mn = m_ * n_;
  for (int k = 0; k < mn; ++k) st.vm[k] = short_tr ? st.vb[k] : st.vb[k] + ratio[k] * (st.vt[k] - st.vb[k]);
}

void LineSolver::batch_devices(BatchState& st, Workspace& w) const {
  const int mn = m_ * n_;
  const bool short_tr = transistor_.is_short();
  double* im = w.b.data();
  double* it = w.s.data();
  // Memristors, all cells at once.
  const double* vlow = short_tr ? st.vb.data() : st.vm.data();
  const double* g = st.g;
  double* gm = st.gm.data();
  if (memristor_.linear()) {
    for (int k = 0; k < mn; ++k) {
      im[k] = g[k] * (st.vt[k] - vlow[k]);
      gm[k] = g[k];
    }
  } else {
    const double k_v = memristor_.k_per_v(), scale = memristor_.scale();
    // exp(k V), vectorised. Eigen's own aligned array: Eigen evaluates exp with SIMD on an
    // aligned body and with std::exp on the rest, so an alignment that varied with the
    // allocation would change the last bits from one thread (or run) to another.
    Eigen::ArrayXd& e = st.exp_kv;
    e = k_v * (Eigen::Map<const Eigen::ArrayXd>(st.vt.data(), mn) - Eigen::Map<const Eigen::ArrayXd>(vlow, mn));
    e = e.exp();
    for (int k = 0; k < mn; ++k) {
      const double x = k_v * (st.vt[k] - vlow[k]), ek = e[k], eik = 1.0 / ek;
      // sinh(kV) = (e - 1/e)/2 loses relative digits for tiny kV: there, kV + (kV)^3/6.
      const double sh = std::abs(x) < 1e-3 ? x * (1.0 + x * x * (1.0 / 6.0)) : 0.5 * (ek - eik);
      im[k] = g[k] * scale * sh;
      gm[k] = g[k] * (scale * k_v * 0.5) * (ek + eik);
    }
  }
  // Access transistors M -> B.
  if (transistor_.linear()) {
    if (!short_tr) {
      const double g_on = 1.0 / params_.transistor.r_on_ohm;
      for (int k = 0; k < mn; ++k) {
        it[k] = g_on * (st.vm[k] - st.vb[k]);
        st.ga[k] = g_on;
        st.gb[k] = -g_on;
      }
    }
  } else {
    // A local copy: GCC cannot prove the member's parameters distinct from the outputs and
    // would not vectorise the loop.
    const TransistorDevice tr = transistor_;
    for (int k = 0; k < mn; ++k) tr.eval_level1(st.vm[k], st.vb[k], it[k], st.ga[k], st.gb[k]);
  }
}

void LineSolver::batch_residual(const double* v_in, BatchState& st, Workspace& w, double& norm, double& fmax) const {
  const bool short_tr = transistor_.is_short();
  batch_devices(st, w);
  const double* im = w.b.data();
  const double* it = w.s.data();
  // KCL at every node, one row or one pair of rows at a time (vectorised inner loops).
  const double gw = g_w_;
  const int n = n_, mn = m_ * n_;
  for (int i = 0; i < m_; ++i) {
    const double* t = st.vt.data() + i * n;
    const double* c = im + i * n;
    double* f = st.ft.data() + i * n;
    f[0] = g_s_ * (t[0] - v_in[i]) + (n > 1 ? gw * (t[0] - t[1]) : 0.0) + c[0];
    for (int j = 1; j + 1 < n; ++j) f[j] = gw * ((t[j] - t[j - 1]) + (t[j] - t[j + 1])) + c[j];
    if (n > 1) f[n - 1] = gw * (t[n - 1] - t[n - 2]) + c[n - 1];
  }
  const double* out = short_tr ? im : it;  // current leaving the cell into B
  for (int i = 0; i < m_; ++i) {
    const double* b = st.vb.data() + i * n;
    const double* up = b - n;
    const double* down = b + n;
    const double* c = out + i * n;
    double* f = st.fb.data() + i * n;
    if (i > 0 && i + 1 < m_) {
      for (int j = 0; j < n; ++j) f[j] = gw * ((b[j] - up[j]) + (b[j] - down[j])) - c[j];
    } else {
      for (int j = 0; j < n; ++j)
        f[j] = (i > 0 ? gw * (b[j] - up[j]) : 0.0) + (i + 1 < m_ ? gw * (b[j] - down[j]) : g_d_ * b[j]) - c[j];
    }
  }
  Arr ft(st.ft.data(), mn), fb(st.fb.data(), mn), fm(st.fm.data(), mn);
  if (short_tr)
    fm.setZero();
  else
    fm = Eigen::Map<const Eigen::ArrayXd>(im, mn) - Eigen::Map<const Eigen::ArrayXd>(it, mn);
  // Fixed summation order whatever the buffers' alignment (Eigen's reductions peel to it).
  norm = std::sqrt(line_dot(st.ft.data(), st.ft.data(), mn) + line_dot(st.fb.data(), st.fb.data(), mn) +
                   line_dot(st.fm.data(), st.fm.data(), mn));
  fmax = std::max({ft.abs().maxCoeff(), fb.abs().maxCoeff(), fm.abs().maxCoeff()});
}

double LineSolver::batch_direction(BatchState& st, Workspace& w, double step_tol) const {
  const int mn = m_ * n_;
  const bool short_tr = transistor_.is_short();
  double* jtt = w.r.data();  // free until the PCG
  double* jbb = w.z.data();
  if (short_tr)
    condense_short(mn, st.gm.data(), jtt, jbb, st.sys.cx.data(), st.ft.data(), st.fb.data());
  else
    condense_cell(mn, st.gm.data(), st.ga.data(), st.gb.data(), st.fm.data(), jtt, jbb, st.sys.cx.data(), st.ft.data(),
                  st.fb.data());
  factor_rows(jtt, st.sys.p_inv.data());
  factor_cols(jbb, st.sys);
  solve_tb(st.sys, st.ft.data(), st.fb.data(), st.dt.data(), st.db.data(), w, step_tol);
  if (short_tr)
    std::copy(st.db.begin(), st.db.end(), st.dm.begin());
  else
    middle_update(mn, st.gm.data(), st.ga.data(), st.gb.data(), st.fm.data(), st.dt.data(), st.db.data(), st.dm.data());
  // Vectorised maxima (a single max chain would wait on its latency at every element).
  const Eigen::Map<const Eigen::ArrayXd> dt(st.dt.data(), mn), db(st.db.data(), mn), dm(st.dm.data(), mn);
  return std::max({dt.abs().maxCoeff(), db.abs().maxCoeff(), dm.abs().maxCoeff()});
}

bool LineSolver::batch_solve(const double* v_in, BatchState& st, Workspace& w, double* out) const {
  const int mn = m_ * n_, bottom = (m_ - 1) * n_;
  double v_scale = 1e-3;
  for (int i = 0; i < m_; ++i) v_scale = std::max(v_scale, std::abs(v_in[i]));
  const double kcl_tol = kcl_tolerance(v_scale);
  batch_start(v_in, st, w);
  double f_norm, f_max;
  batch_residual(v_in, st, w, f_norm, f_max);
  double last_change = -1;  // largest column-current change of the previous full step
  bool converged = false;
  for (int it = 1; it <= options_.newton_max_iterations && !converged; ++it) {
    const double dmax = batch_direction(st, w, it == 1 ? kFirstStepTolerance : kStepTolerance);
    if (!std::isfinite(dmax)) return false;
    double scale = dmax > options_.max_step_v ? options_.max_step_v / dmax : 1.0;
    auto step = [&](double f) {
      auto axpy = [mn, f](double* __restrict y, const double* __restrict x) {
        for (int k = 0; k < mn; ++k) y[k] += f * x[k];
      };
      axpy(st.vt.data(), st.dt.data());
      axpy(st.vm.data(), st.dm.data());
      axpy(st.vb.data(), st.db.data());
    };
    step(scale);
    double new_norm;
    batch_residual(v_in, st, w, new_norm, f_max);
    for (int ls = 0; ls < 20 && new_norm > f_norm && scale * dmax > 1e-9; ++ls) {  // backtrack (rare)
      step(-0.5 * scale);
      scale *= 0.5;
      batch_residual(v_in, st, w, new_norm, f_max);
    }
    if (!std::isfinite(new_norm)) return false;  // the devices overflowed: the per-vector Newton limits its steps
    f_norm = new_norm;
    // Error of the column currents: the last change times the observed contraction
    // theta / (1 - theta) (Newton's error estimate); without two full steps to measure
    // theta, ten times the change.
    double change = 0, i_max = 0;
    for (int j = 0; j < n_; ++j) {
      change = std::max(change, out_gain_ * std::abs(scale * st.db[bottom + j]));
      i_max = std::max(i_max, out_gain_ * std::abs(st.vb[bottom + j]));
    }
    double estimate = 10 * change;
    if (scale == 1.0 && last_change > 0) {
      const double theta = change / last_change;
      estimate = theta < 1 ? change * theta / (1 - theta) : HUGE_VAL;
    }
    last_change = scale == 1.0 ? change : -1;
    converged = estimate <= options_.nonlinear_tolerance * i_max && f_max <= kcl_tol;
  }
  for (int j = 0; j < n_; ++j) out[j] = out_gain_ * st.vb[bottom + j];
  return converged;
}

}  // namespace xbarsim
