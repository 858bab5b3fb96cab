#include "sw/circuit/line_solver.h"
#include "sw/common/cancel.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "sw/circuit/line_solver_workspace.h"
#include "sw/common/errors.h"

namespace xbarsim {

namespace {
constexpr int kRowBlock = 16;  ///< row recurrences stepped together
}  // namespace

double line_dot(const double* a, const double* b, int n) {
  // Eight partial sums in a fixed order: vectorised (one add chain would wait on its own
  // latency at every element) and the same bits on every run.
  double part[8] = {0, 0, 0, 0, 0, 0, 0, 0};
  int k = 0;
  for (; k + 8 <= n; k += 8)
    for (int l = 0; l < 8; ++l) part[l] += a[k + l] * b[k + l];
  for (int l = 0; k < n; ++k, ++l) part[l] += a[k] * b[k];
  return ((part[0] + part[1]) + (part[2] + part[3])) + ((part[4] + part[5]) + (part[6] + part[7]));
}

LineSolver::LineSolver(const CrossbarParams& p, const SolverOptions& o)
    : CrossbarSolver(p, o), memristor_(p.memristor), transistor_(p.transistor) {
  g_w_ = 1.0 / p.r_wire_ohm;
  g_s_ = 1.0 / (p.r_in_ohm + p.r_wire_ohm);   // source -> r_in -> L_i -> r_wire -> T(i,0)
  // B(m-1,j) -> r_wire -> D_j -> r_out -> ground; voltage sensing: D_j is open.
  floating_ = p.voltage_sensing();
  g_d_ = floating_ ? 0.0 : 1.0 / (p.r_wire_ohm + p.r_out_ohm);
  out_gain_ = floating_ ? 1.0 : g_d_;
}

void LineSolver::factor_rows(const double* extra, double* p_inv) const {
  const double gw2 = g_w_ * g_w_;
  const int n = n_;
  for (int i0 = 0; i0 < m_; i0 += kRowBlock) {  // rows interleaved, as in row_solve
    const int i1 = std::min(m_, i0 + kRowBlock);
    for (int j = 0; j < n; ++j) {
      const double base = (j == 0 ? g_s_ : g_w_) + (j + 1 < n ? g_w_ : 0.0);  // R_i is open
      for (int i = i0; i < i1; ++i) {
        const int k = i * n + j;
        p_inv[k] = 1.0 / (base + extra[k] - (j ? gw2 * p_inv[k - 1] : 0.0));
      }
    }
  }
}

void LineSolver::factor_cols(const double* extra, System& s) const {
  double* q_diag = s.q_diag.data();
  double* q_inv = s.q_inv.data();
  if (floating_) {
    factor_floating_cols(extra, s);
    return;
  }
  const double gw2 = g_w_ * g_w_;
  for (int i = m_ - 1; i >= 0; --i) {
    const double up = i > 0 ? g_w_ : 0.0;  // U_j is open
    const double down = i + 1 < m_ ? g_w_ : g_d_;
    const int o = i * n_;
    for (int j = 0; j < n_; ++j) {
      const double d = up + down + extra[o + j];
      q_diag[o + j] = d;
      q_inv[o + j] = 1.0 / (d - (i + 1 < m_ ? gw2 * q_inv[o + n_ + j] : 0.0));
    }
  }
}

void LineSolver::factor_floating_cols(const double* extra, System& s) const {
  // Pivot of node i = the wire above it + e_i, e_i = the conductance to ground of node i and
  // everything below it with the wire above open: e_i = extra_i + (g_w in series with e_i+1).
  // q_diag holds e of the row below until the next row is done, then Q's diagonal.
  const double gw = g_w_;
  const int mn = m_ * n_;
  s.q_cell.assign(extra, extra + mn);
  double* q_diag = s.q_diag.data();
  double* q_inv = s.q_inv.data();
  for (int i = m_ - 1; i >= 0; --i) {
    const double up = i > 0 ? gw : 0.0;
    const int o = i * n_;
    for (int j = 0; j < n_; ++j) {
      double e = extra[o + j];
      if (i + 1 < m_) {
        const double below = q_diag[o + n_ + j];
        e += gw * below / (gw + below);
      }
      q_diag[o + j] = e;
      q_inv[o + j] = 1.0 / (up + e);
    }
    if (i + 1 < m_) {
      const double down = i + 2 < m_ ? gw : 0.0;
      for (int j = 0; j < n_; ++j) q_diag[o + n_ + j] = gw + down + extra[o + n_ + j];
    }
  }
  for (int j = 0; j < n_; ++j) q_diag[j] = (m_ > 1 ? gw : 0.0) + extra[j];
}

void LineSolver::row_solve(const double* p_inv, const double* r, double* x) const {
  // The row recurrences are independent: step a block of kRowBlock of them together so that
  // the CPU overlaps their latency chains. (All m at once would thrash L1: rows n doubles
  // apart map to few cache sets.)
  const double gw = g_w_;
  const int n = n_;
  for (int i0 = 0; i0 < m_; i0 += kRowBlock) {
    const int i1 = std::min(m_, i0 + kRowBlock);
    for (int i = i0; i < i1; ++i) x[i * n] = r[i * n];
    for (int j = 1; j < n; ++j)
      for (int i = i0; i < i1; ++i) {
        const int k = i * n + j;
        x[k] = r[k] + gw * p_inv[k - 1] * x[k - 1];
      }
    for (int i = i0; i < i1; ++i) x[i * n + n - 1] *= p_inv[i * n + n - 1];
    for (int j = n - 2; j >= 0; --j)
      for (int i = i0; i < i1; ++i) {
        const int k = i * n + j;
        x[k] = (x[k] + gw * x[k + 1]) * p_inv[k];
      }
  }
}

void LineSolver::col_solve(const double* q_inv, const double* r, double* x) const {
  const double gw = g_w_;
  // Forward sweep from the grounded end (bottom) to the open end (top), all columns at once.
  const int last = (m_ - 1) * n_;
  for (int j = 0; j < n_; ++j) x[last + j] = r[last + j];
  for (int i = m_ - 2; i >= 0; --i) {
    const int o = i * n_;
    for (int j = 0; j < n_; ++j) x[o + j] = r[o + j] + gw * q_inv[o + n_ + j] * x[o + n_ + j];
  }
  for (int j = 0; j < n_; ++j) x[j] *= q_inv[j];
  for (int i = 1; i < m_; ++i) {
    const int o = i * n_;
    for (int j = 0; j < n_; ++j) x[o + j] = (x[o + j] + gw * x[o - n_ + j]) * q_inv[o + j];
  }
}

void LineSolver::schur_apply(const System& s, const double* x, double* y, Workspace& w) const {
  const int mn = m_ * n_;
  double* a = w.a.data();
  double* b = w.b.data();
  for (int k = 0; k < mn; ++k) a[k] = s.cx[k] * x[k];
  row_solve(s.p_inv.data(), a, b);
  const double* cy = s.y();
  const double gw = g_w_;
  if (!s.q_cell.empty()) {  // floating columns: the wires on voltage differences
    for (int i = 0; i < m_; ++i) {
      const int o = i * n_;
      for (int j = 0; j < n_; ++j) {
        double v = s.q_cell[o + j] * x[o + j] - cy[o + j] * b[o + j];
        if (i > 0) v += gw * (x[o + j] - x[o - n_ + j]);
        if (i + 1 < m_) v += gw * (x[o + j] - x[o + n_ + j]);
        y[o + j] = v;
      }
    }
    return;
  }
  for (int i = 0; i < m_; ++i) {
    const int o = i * n_;
    for (int j = 0; j < n_; ++j) {
      double v = s.q_diag[o + j] * x[o + j] - cy[o + j] * b[o + j];
      if (i > 0) v -= gw * x[o - n_ + j];
      if (i + 1 < m_) v -= gw * x[o + n_ + j];
      y[o + j] = v;
    }
  }
}

int LineSolver::pcg(const System& s, const double* rhs, double* x, Workspace& w, double tol, double* t) const {
  // Preconditioned CG; stops when the residual in the Q^-1 norm, sqrt(r' Q^-1 r), has
  // dropped by `tolerance`. That norm is well conditioned (Q^-1 S ~ I), unlike |r|_2,
  // whose attainable floor is eps * cond(Q). Each step's S p computes P^-1 X p on the way
  // (w.b): subtracting alpha times it from t keeps t = P^-1 (r_T - X x) without a final
  // row solve.
  const int mn = m_ * n_;
  double *r = w.r.data(), *z = w.z.data(), *p = w.p.data(), *q = w.q.data();
  std::fill(x, x + mn, 0.0);
  std::copy(rhs, rhs + mn, r);
  col_solve(s.q_inv.data(), r, z);
  double rz = line_dot(r, z, mn);
  if (rz == 0) return 0;
  auto not_finite = [] {
    return SolverError("line solver (CG): the system or its right-hand side is not finite (overflow)");
  };
  if (!std::isfinite(rz)) throw not_finite();
  std::copy(z, z + mn, p);
  const double target2 = tol * tol * rz;
  for (int it = 1; it <= options_.max_iterations; ++it) {
    check_cancel();
    schur_apply(s, p, q, w);
    const double alpha = rz / line_dot(p, q, mn);
    for (int k = 0; k < mn; ++k) {
      x[k] += alpha * p[k];
      r[k] -= alpha * q[k];
    }
    if (t) {
      const double* pxp = w.b.data();
      for (int k = 0; k < mn; ++k) t[k] -= alpha * pxp[k];
    }
    col_solve(s.q_inv.data(), r, z);
    const double rz_new = line_dot(r, z, mn);
    if (rz_new <= target2) return it;
    if (!std::isfinite(rz_new)) throw not_finite();
    const double beta = rz_new / rz;
    rz = rz_new;
    for (int k = 0; k < mn; ++k) p[k] = z[k] + beta * p[k];
  }
  std::ostringstream os;
  os << "line solver (CG) did not reach relative residual " << tol << " in " << options_.max_iterations
     << " iterations (solver.max_iterations)";
  throw SolverError(os.str());
}

int LineSolver::gmres(const System& s, const double* rhs, double* x, Workspace& w) const {
  // Left-preconditioned restarted GMRES on Q^-1 S x = Q^-1 rhs (Q^-1 S ~ I, so the
  // preconditioned residual is a faithful measure of the error in x).
  const int mn = m_ * n_;
  const int R = kGmresRestart;
  double *r = w.r.data(), *z = w.z.data();
  std::fill(x, x + mn, 0.0);
  col_solve(s.q_inv.data(), rhs, r);
  const double b_norm = std::sqrt(line_dot(r, r, mn));
  if (b_norm == 0) return 0;
  if (!std::isfinite(b_norm))
    throw SolverError("line solver (GMRES): the system or its right-hand side is not finite (overflow)");
  const double target = options_.tolerance * b_norm;
  double h[kGmresRestart + 1][kGmresRestart];
  double cs[kGmresRestart], sn[kGmresRestart], g[kGmresRestart + 1], y[kGmresRestart];
  int total = 0;
  double prev_beta = 0;
  while (total < options_.max_iterations) {
    check_cancel();
    const double beta = std::sqrt(line_dot(r, r, mn));
    if (beta <= target) return total;
    if (!std::isfinite(beta) || (prev_beta > 0 && beta > 0.99 * prev_beta)) break;  // overflow, stagnation
    prev_beta = beta;
    double* v0 = w.v.data();
    for (int k = 0; k < mn; ++k) v0[k] = r[k] / beta;
    std::fill(g, g + R + 1, 0.0);
    g[0] = beta;
    int k_used = 0;
    bool done = false;
    for (int k = 0; k < R && total < options_.max_iterations; ++k) {
      ++total;
      double* vk = w.v.data() + static_cast<size_t>(k) * mn;
      double* vn = w.v.data() + static_cast<size_t>(k + 1) * mn;
      schur_apply(s, vk, z, w);
      col_solve(s.q_inv.data(), z, vn);
      for (int i = 0; i <= k; ++i) {
        const double* vi = w.v.data() + static_cast<size_t>(i) * mn;
        h[i][k] = line_dot(vn, vi, mn);
        for (int q = 0; q < mn; ++q) vn[q] -= h[i][k] * vi[q];
      }
      h[k + 1][k] = std::sqrt(line_dot(vn, vn, mn));
      if (h[k + 1][k] > 0)
        for (int q = 0; q < mn; ++q) vn[q] /= h[k + 1][k];
      for (int i = 0; i < k; ++i) {
        const double t = cs[i] * h[i][k] + sn[i] * h[i + 1][k];
        h[i + 1][k] = -sn[i] * h[i][k] + cs[i] * h[i + 1][k];
        h[i][k] = t;
      }
      const double den = std::hypot(h[k][k], h[k + 1][k]);
      cs[k] = h[k][k] / den;
      sn[k] = h[k + 1][k] / den;
      h[k][k] = den;
      h[k + 1][k] = 0;
      g[k + 1] = -sn[k] * g[k];
      g[k] = cs[k] * g[k];
      k_used = k + 1;
      if (std::abs(g[k + 1]) <= target) {
        done = true;
        break;
      }
    }
    for (int i = k_used - 1; i >= 0; --i) {
      double t = g[i];
      for (int c = i + 1; c < k_used; ++c) t -= h[i][c] * y[c];
      y[i] = t / h[i][i];
    }
    for (int i = 0; i < k_used; ++i) {
      const double* vi = w.v.data() + static_cast<size_t>(i) * mn;
      for (int q = 0; q < mn; ++q) x[q] += y[i] * vi[q];
    }
    if (done) return total;
    // Restart from the true preconditioned residual.
    schur_apply(s, x, z, w);
    for (int q = 0; q < mn; ++q) z[q] = rhs[q] - z[q];
    col_solve(s.q_inv.data(), z, r);
  }
  std::ostringstream os;
  os << "line solver (GMRES) did not reach relative residual " << options_.tolerance << " within "
     << options_.max_iterations << " iterations (solver.max_iterations), stagnated or overflowed";
  throw SolverError(os.str());
}

int LineSolver::solve_tb(const System& s, const double* r_t, const double* r_b, double* t, double* b, Workspace& w,
                         double tol) const {
  const int mn = m_ * n_;
  // Schur right-hand side: r_B - Y P^-1 r_T (t as scratch).
  std::vector<double>& schur_rhs = w.s;
  row_solve(s.p_inv.data(), r_t, t);
  const double* cy = s.y();
  for (int k = 0; k < mn; ++k) schur_rhs[k] = r_b[k] - cy[k] * t[k];
  // CG updates t = P^-1 (r_T - X b) as it goes; after GMRES, back-substitute the row wires.
  if (s.symmetric) return pcg(s, schur_rhs.data(), b, w, tol, t);
  const int its = gmres(s, schur_rhs.data(), b, w);
  for (int k = 0; k < mn; ++k) schur_rhs[k] = r_t[k] - s.cx[k] * b[k];
  row_solve(s.p_inv.data(), schur_rhs.data(), t);
  return its;
}

void LineSolver::program(const Eigen::MatrixXd& g_s) {
  store_conductances(g_s);
  const double mn_d = static_cast<double>(g_s.rows()) * static_cast<double>(g_s.cols());
  if (mn_d > 2e9) throw InputError("a crossbar of " + std::to_string(g_s.size()) + " cells is too large");
  check_memory(8.0 * memory_doubles(static_cast<int>(g_s.rows()), static_cast<int>(g_s.cols())),
               "the line solver on a " + std::to_string(g_s.rows()) + " x " + std::to_string(g_s.cols()) + " crossbar");
  m_ = static_cast<int>(g_s.rows());
  n_ = static_cast<int>(g_s.cols());
  const int mn = m_ * n_;
  {
    std::lock_guard<std::mutex> lock(geff_mutex_);
    geff_cache_.resize(0, 0);
  }
  g_cell_.assign(mn, 0.0);
  for (int i = 0; i < m_; ++i)
    for (int j = 0; j < n_; ++j) g_cell_[i * n_ + j] = linear_cell_conductance(params_, g_(i, j));
  if (!params_.is_linear()) return;  // Newton builds its systems per iteration
  linear_.resize(mn, true);
  for (int k = 0; k < mn; ++k) linear_.cx[k] = -g_cell_[k];
  factor_rows(g_cell_.data(), linear_.p_inv.data());
  factor_cols(g_cell_.data(), linear_);
}

double LineSolver::memory_doubles(int m, int n) const {
  const double mn = static_cast<double>(m) * n;
  const bool newton = !params_.is_linear();
  const int threads = std::max(1, std::min(resolve_threads(options_.threads), std::min(m, n)));
  // g, cell conductances, the linear system (5), one solution (5 matrices), G_eff; per
  // thread a workspace; Newton adds its ~20 per-node arrays.
  return (1 + 1 + 5 + 5 + 1) * mn + threads * (Workspace::doubles(m * n, newton) + 4 * mn) + (newton ? 20 * mn : 0.0);
}

CircuitSolution LineSolver::solve(const Eigen::VectorXd& v_in) const {
  check_input(v_in);
  Workspace w(m_ * n_, !params_.is_linear());
  return params_.is_linear() ? solve_linear(v_in, w) : solve_newton(v_in, w);
}

void LineSolver::column_outputs(const double* b, CircuitSolution& s) const {
  for (int j = 0; j < n_; ++j) {
    const double vb = b[(m_ - 1) * n_ + j];
    s.column_current(j) = g_d_ * vb;
    s.column_voltage(j) = floating_ ? vb : g_d_ * vb * params_.r_out_ohm;
  }
}

CircuitSolution LineSolver::solve_linear(const Eigen::VectorXd& v_in, Workspace& w) const {
  const int mn = m_ * n_;
  std::vector<double> r_t(mn, 0.0), r_b(mn, 0.0), t(mn), b(mn);
  for (int i = 0; i < m_; ++i) r_t[i * n_] = g_s_ * v_in(i);
  CircuitSolution s = CircuitSolution::sized(m_, n_);
  s.linear_iterations = solve_tb(linear_, r_t.data(), r_b.data(), t.data(), b.data(), w, options_.tolerance);
  for (int i = 0; i < m_; ++i)
    for (int j = 0; j < n_; ++j) {
      const int k = i * n_ + j;
      const double ic = g_cell_[k] * (t[k] - b[k]);
      s.v_top(i, j) = t[k];
      s.v_bottom(i, j) = b[k];
      s.v_mid(i, j) = t[k] - ic / g_(i, j);
      s.cell_current(i, j) = ic;
    }
  column_outputs(b.data(), s);
  return s;
}

/// Node voltages, KCL residuals and device derivatives of one Newton solve (T, M, B nodes).
struct LineSolver::NewtonState {
  explicit NewtonState(int mn)
      : vt(mn, 0.0),
        vm(mn, 0.0),
        vb(mn, 0.0),
        ft(mn),
        fm(mn),
        fb(mn),
        gm(mn),
        ga(mn),
        gb(mn),
        jtt(mn),
        jbb(mn),
        rt(mn),
        rb(mn),
        dt(mn),
        db(mn),
        dm(mn),
        tt(mn),
        tm(mn),
        tb(mn),
        tft(mn),
        tfm(mn),
        tfb(mn) {
    sys.resize(mn, false);
  }
  std::vector<double> vt, vm, vb;                    ///< V, current iterate
  std::vector<double> ft, fm, fb;                    ///< A, KCL residuals at the iterate
  std::vector<double> gm, ga, gb;                    ///< memristor dI/dV, transistor dI/dV_M, dI/dV_B
  std::vector<double> jtt, jbb, rt, rb, dt, db, dm;  ///< condensed Jacobian, right-hand sides, update
  std::vector<double> tt, tm, tb, tft, tfm, tfb;     ///< trial iterate of the line search and its residuals
  System sys;
  double max_residual() const {
    double f = 0;
    for (size_t k = 0; k < ft.size(); ++k) f = std::max({f, std::abs(ft[k]), std::abs(fm[k]), std::abs(fb[k])});
    return f;
  }
};

double LineSolver::newton_residual(const Eigen::VectorXd& v_in, NewtonState& st, bool trial, bool deriv) const {
  const bool short_tr = transistor_.is_short();
  const std::vector<double>&t = trial ? st.tt : st.vt, &mid = trial ? st.tm : st.vm, &b = trial ? st.tb : st.vb;
  std::vector<double>&rT = trial ? st.tft : st.ft, &rM = trial ? st.tfm : st.fm, &rB = trial ? st.tfb : st.fb;
  double norm2 = 0;
  for (int i = 0; i < m_; ++i)
    for (int j = 0; j < n_; ++j) {
      const int k = i * n_ + j;
      const double tk = t[k], bk = b[k];
      double ft_k =
          (j == 0 ? g_s_ * (tk - v_in(i)) : g_w_ * (tk - t[k - 1])) + (j + 1 < n_ ? g_w_ * (tk - t[k + 1]) : 0.0);
      double fb_k = (i > 0 ? g_w_ * (bk - b[k - n_]) : 0.0) + (i + 1 < m_ ? g_w_ * (bk - b[k + n_]) : g_d_ * bk);
      const double mk = short_tr ? bk : mid[k];
      double im, dim, it = 0, dia = 0, dib = 0;
      memristor_.eval(g_(i, j), tk - mk, im, dim);
      ft_k += im;
      if (short_tr) {
        fb_k -= im;
      } else {
        transistor_.eval(mk, bk, it, dia, dib);
        fb_k -= it;
      }
      const double fm_k = short_tr ? 0.0 : im - it;
      if (deriv) {
        st.gm[k] = dim;
        st.ga[k] = dia;
        st.gb[k] = dib;
      }
      rT[k] = ft_k;
      rM[k] = fm_k;
      rB[k] = fb_k;
      norm2 += ft_k * ft_k + fm_k * fm_k + fb_k * fb_k;
    }
  return std::sqrt(norm2);
}

int LineSolver::newton_direction(NewtonState& st, Workspace& w) const {
  // Condense the middle nodes into 2x2 cell Jacobians between T and B, then solve for the
  // update of T and B and recover the middle nodes'.
  const int mn = m_ * n_;
  const bool short_tr = transistor_.is_short();
  for (int k = 0; k < mn; ++k) {
    if (short_tr) {
      st.jtt[k] = st.jbb[k] = st.gm[k];
      st.sys.cx[k] = st.sys.cy[k] = -st.gm[k];
      st.rt[k] = -st.ft[k];
      st.rb[k] = -st.fb[k];
    } else {
      const double den = st.gm[k] + st.ga[k], c = st.gm[k] / den;
      st.jtt[k] = st.ga[k] * c;
      st.jbb[k] = -st.gb[k] * c;
      st.sys.cx[k] = st.gb[k] * c;
      st.sys.cy[k] = -st.ga[k] * c;
      st.rt[k] = -st.ft[k] + c * st.fm[k];
      st.rb[k] = -st.fb[k] + (st.ga[k] / den) * st.fm[k];
    }
  }
  factor_rows(st.jtt.data(), st.sys.p_inv.data());
  factor_cols(st.jbb.data(), st.sys);
  const int inner = solve_tb(st.sys, st.rt.data(), st.rb.data(), st.dt.data(), st.db.data(), w, options_.tolerance);
  if (short_tr)
    st.dm = st.db;
  else
    middle_update(mn, st.gm.data(), st.ga.data(), st.gb.data(), st.fm.data(), st.dt.data(), st.db.data(), st.dm.data());
  return inner;
}

double LineSolver::newton_update(const Eigen::VectorXd& v_in, NewtonState& st, double f_norm) const {
  // Voltage limiting to solver.max_step, then halving until the residual does not grow.
  const int mn = m_ * n_;
  double dmax = 0;
  for (int k = 0; k < mn; ++k) dmax = std::max({dmax, std::abs(st.dt[k]), std::abs(st.db[k]), std::abs(st.dm[k])});
  if (!std::isfinite(dmax)) throw SolverError("Newton-Raphson (line solver) produced a non-finite update");
  double scale = dmax > options_.max_step_v ? options_.max_step_v / dmax : 1.0;
  for (int ls = 0; ls < 20; ++ls) {
    for (int k = 0; k < mn; ++k) {
      st.tt[k] = st.vt[k] + scale * st.dt[k];
      st.tm[k] = st.vm[k] + scale * st.dm[k];
      st.tb[k] = st.vb[k] + scale * st.db[k];
    }
    if (newton_residual(v_in, st, true, false) <= f_norm || scale * dmax < 1e-9) break;
    scale *= 0.5;
  }
  st.vt.swap(st.tt);
  st.vm.swap(st.tm);
  st.vb.swap(st.tb);
  return scale * dmax;
}

CircuitSolution LineSolver::newton_solution(const NewtonState& st) const {
  CircuitSolution s = CircuitSolution::sized(m_, n_);
  for (int i = 0; i < m_; ++i)
    for (int j = 0; j < n_; ++j) {
      const int k = i * n_ + j;
      s.v_top(i, j) = st.vt[k];
      s.v_bottom(i, j) = st.vb[k];
      s.v_mid(i, j) = transistor_.is_short() ? st.vb[k] : st.vm[k];
      double im, d;
      memristor_.eval(g_(i, j), s.v_top(i, j) - s.v_mid(i, j), im, d);
      s.cell_current(i, j) = im;
    }
  column_outputs(st.vb.data(), s);
  return s;
}

CircuitSolution LineSolver::solve_newton(const Eigen::VectorXd& v_in, Workspace& w) const {
  NewtonState st(m_ * n_);
  const double v_scale = std::max(v_in.cwiseAbs().maxCoeff(), 1e-3);
  const double kcl_tol = kcl_tolerance(v_scale);
  double f_norm = newton_residual(v_in, st, false, true);
  double last_step = 0;
  int inner_total = 0;
  for (int it = 1; it <= options_.newton_max_iterations; ++it) {
    check_cancel();
    inner_total += newton_direction(st, w);
    last_step = newton_update(v_in, st, f_norm);
    f_norm = newton_residual(v_in, st, false, true);
    // Converged only when the update is small AND every node balances its currents: a
    // tiny step alone (e.g. a small solver.max_step) says nothing about the solution.
    if (last_step <= options_.newton_tolerance * v_scale && st.max_residual() <= kcl_tol) {
      CircuitSolution s = newton_solution(st);
      s.newton_iterations = it;
      s.linear_iterations = inner_total;
      return s;
    }
  }
  std::ostringstream os;
  os << "Newton-Raphson (line solver) did not converge in " << options_.newton_max_iterations
     << " iterations (solver.newton_max_iterations): last update " << last_step << " V, KCL residual "
     << st.max_residual() << " A (needs <= " << options_.newton_tolerance * v_scale << " V and <= " << kcl_tol << " A)";
  if (options_.max_step_v * options_.newton_max_iterations < 2 * v_scale)
    os << "; every step moves a node by at most solver.max_step = " << options_.max_step_v
       << " V, too little for inputs up to " << v_scale << " V in that many iterations";
  throw SolverError(os.str());
}

Eigen::MatrixXd LineSolver::effective_matrix() const {
  if (!params_.is_linear()) throw SolverError("the effective conductance matrix exists only for linear devices");
  if (g_.size() == 0) throw InputError("crossbar solver used before program()");
  std::lock_guard<std::mutex> lock(geff_mutex_);
  if (geff_cache_.size() == 0) geff_cache_ = compute_effective_matrix();
  return geff_cache_;
}

Eigen::MatrixXd LineSolver::compute_effective_matrix() const {
  const int mn = m_ * n_;
  Eigen::MatrixXd geff(m_, n_);
  const int threads = resolve_threads(options_.threads);
  const bool by_rows = m_ < n_;  // min(m, n) solves
  const int count = by_rows ? m_ : n_;
  const int nthreads = std::max(1, std::min(threads, count));
  std::vector<Workspace> ws;
  ws.reserve(nthreads);
  for (int t = 0; t < nthreads; ++t) ws.emplace_back(mn, false);
  parallel_for(nthreads, nthreads, [&](int tid) {
    Workspace& w = ws[tid];
    std::vector<double> r_t(mn), r_b(mn), t(mn), b(mn);
    for (int c = tid; c < count; c += nthreads) {
      check_cancel();
      std::fill(r_t.begin(), r_t.end(), 0.0);
      std::fill(r_b.begin(), r_b.end(), 0.0);
      if (by_rows) {
        // Unit source on row c: row c of G_eff is g_d * b(m-1, :) (of A: b(m-1, :)).
        r_t[c * n_] = g_s_;
        solve_tb(linear_, r_t.data(), r_b.data(), t.data(), b.data(), w, options_.tolerance);
        for (int j = 0; j < n_; ++j) geff(c, j) = out_gain_ * b[(m_ - 1) * n_ + j];
      } else {
        // Adjoint (reciprocity, symmetric K): unit current into B(m-1, c);
        // G_eff(i, c) = g_s * g_d * t(i, 0) (A(i, c) = g_s * t(i, 0)).
        r_b[(m_ - 1) * n_ + c] = 1.0;
        solve_tb(linear_, r_t.data(), r_b.data(), t.data(), b.data(), w, options_.tolerance);
        for (int i = 0; i < m_; ++i) geff(i, c) = g_s_ * out_gain_ * t[i * n_];
      }
    }
  });
  return geff;
}

}  // namespace xbarsim
