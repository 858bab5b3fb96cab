#include "sw/mitigation/conversion.h"

#include <cmath>
#include <limits>

#include "sw/circuit/device_models.h"
#include "sw/circuit/wire_voltages.h"

namespace xbarsim {

ConversionResult convert_signal_impl(const CrossbarParams& p, const Eigen::MatrixXd& g, const Eigen::VectorXd& v_conv,
                                     bool clip, const Eigen::VectorXd* v_target = nullptr);

namespace {

/// V_M such that the access transistor passes current `i` from M to B (closed forms of
/// the level-1 equations); NaN when no V_M can (saturation limit or cutoff).
double level1_mid_voltage(const TransistorParams& t, double vb, double i) {
  const double kp = t.kp_a_per_v2;
  if (i >= 0) {
    const double vgst = t.vg_v - vb - t.vth_v;  // B is the source
    if (vgst <= 0) return std::numeric_limits<double>::quiet_NaN();
    const double disc = vgst * vgst - 2 * i / kp;  // triode: i = kp (vgst x - x^2/2)
    if (disc < 0) return std::numeric_limits<double>::quiet_NaN();
    return vb + (vgst - std::sqrt(disc));
  }
  const double c = t.vg_v - vb - t.vth_v;  // M is the source: always triode when c > 0
  if (c <= 0) return std::numeric_limits<double>::quiet_NaN();
  const double y = -c + std::sqrt(c * c + 2 * (-i) / kp);
  return vb - y;
}

}  // namespace

ConversionResult convert_signal(const CrossbarParams& p, const Eigen::MatrixXd& g, const Eigen::VectorXd& v_conv) {
  return convert_signal_impl(p, g, v_conv, true);
}

ConversionResult convert_signal(const CrossbarParams& p, const Eigen::MatrixXd& g, const Eigen::VectorXd& v_conv,
                                const Eigen::VectorXd& v_target) {
  return convert_signal_impl(p, g, v_conv, true, &v_target);
}

ConversionResult convert_signal_impl(const CrossbarParams& p, const Eigen::MatrixXd& g, const Eigen::VectorXd& v_conv,
                                     bool clip, const Eigen::VectorXd* v_target) {
  const int m = static_cast<int>(g.rows()), n = static_cast<int>(g.cols());
  if (v_conv.size() != m) throw InputError("conversion signal must have one voltage per crossbar row");
  if (v_target && v_target->size() != m) throw InputError("conversion target must have one voltage per crossbar row");
  const Eigen::VectorXd& v_ideal = v_target ? *v_target : v_conv;
  ConversionResult r;
  r.g_prime.resize(m, n);
  // Target cell currents and the node voltages they imply.
  using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  RowMajor cur(m, n), vt(m, n), vb(m, n);
  for (int i = 0; i < m; ++i)
    for (int j = 0; j < n; ++j) cur(i, j) = v_ideal(i) * g(i, j);
  wire_voltages(p, m, n, v_conv.data(), cur.data(), vt.data(), vb.data());
  const MemristorDevice mem(p.memristor);
  for (int i = 0; i < m; ++i)
    for (int j = 0; j < n; ++j) {
      const double c = cur(i, j);
      if (c == 0) {
        ++r.undetermined;
        r.g_prime(i, j) = std::min(std::max(g(i, j), p.g_min_s), p.g_max_s);
        continue;
      }
      double vm = vb(i, j);
      if (p.transistor.model == TransistorModel::Linear) vm = vb(i, j) + c * p.transistor.r_on_ohm;
      if (p.transistor.model == TransistorModel::Level1) vm = level1_mid_voltage(p.transistor, vb(i, j), c);
      const double u = vt(i, j) - vm;
      double gp = std::numeric_limits<double>::infinity();
      if (std::isfinite(u) && u * c > 0) gp = c / mem.current_per_siemens(u);
      if (!(gp <= p.g_max_s)) {
        ++r.above_max;
        if (clip) gp = p.g_max_s;
      } else if (gp < p.g_min_s) {
        ++r.below_min;
        if (clip) gp = p.g_min_s;
      }
      r.g_prime(i, j) = gp;
    }
  return r;
}

namespace {

/// Linear matrix conversion on cell conductances for a linear crossbar `lin`.
/// Target T(:,j) = c_floor + beta_j (c_target(:,j) - c_floor), beta_j = 1 unless scaling.
ConversionResult matrix_linear(const CrossbarParams& lin, const SolverOptions& o, const Eigen::MatrixXd& c_target,
                               const Eigen::MatrixXd& c_start, const Eigen::MatrixXd& c_lo, const Eigen::MatrixXd& c_hi,
                               double c_floor, const MatrixConversionOptions& mo,
                               const Eigen::VectorXd& beta_start = Eigen::VectorXd()) {
  const int m = static_cast<int>(c_target.rows()), n = static_cast<int>(c_target.cols());
  ConversionResult r;
  Eigen::VectorXd beta = beta_start.size() == n ? beta_start : Eigen::VectorXd::Ones(n);
  Eigen::MatrixXd target = c_target;
  for (int j = 0; j < n; ++j) target.col(j) = (c_floor + beta(j) * (c_target.col(j).array() - c_floor)).matrix();
  Eigen::MatrixXd gp = c_start.cwiseMax(c_lo).cwiseMin(c_hi);
  auto solver = make_crossbar_solver(lin, o);
  double best = std::numeric_limits<double>::infinity();
  Eigen::MatrixXd best_g = gp;
  Eigen::VectorXd best_beta = beta;
  for (int it = 1; it <= mo.max_iterations; ++it) {
    solver->program(gp);
    const Eigen::MatrixXd geff = solver->effective_matrix();
    const double res = (geff - target).cwiseAbs().maxCoeff() / target.cwiseAbs().maxCoeff();
    r.iterations = it;
    if (res < best) {
      best = res;
      best_g = gp;
      best_beta = beta;
    }
    if (res <= mo.tolerance) break;
    // Over-relaxed multiplicative update: raising a cell also raises its column's IR drop,
    // which the plain ratio ignores; an exponent 1 < omega < 2 compensates.
    Eigen::MatrixXd desired = gp.cwiseProduct(target.cwiseQuotient(geff).array().pow(mo.relaxation).matrix());
    if (mo.column_scaling) {
      // Per-column gain controller: keep the most demanding cell of each column just inside
      // g_max. Decrease at once when a cell would clip; recover slowly when there is room.
      for (int j = 0; j < n; ++j) {
        double ratio = 0;
        for (int i = 0; i < m; ++i) ratio = std::max(ratio, desired(i, j) / c_hi(i, j));
        double b_new = beta(j);
        if (ratio > 1.0)
          b_new = beta(j) * 0.995 / ratio;
        else if (ratio < 0.97 && beta(j) < 1.0)
          b_new = std::min(1.0, beta(j) * std::sqrt(0.985 / ratio));
        if (b_new == beta(j)) continue;
        for (int i = 0; i < m; ++i) {
          const double t = c_floor + b_new * (c_target(i, j) - c_floor);
          desired(i, j) *= t / target(i, j);
          target(i, j) = t;
        }
        beta(j) = b_new;
      }
    }
    const Eigen::MatrixXd next = desired.cwiseMax(c_lo).cwiseMin(c_hi);
    if ((next - gp).cwiseAbs().maxCoeff() <= 1e-15 * c_hi.maxCoeff()) break;  // bounded fixed point reached
    gp = next;
  }
  r.g_prime = best_g;
  r.residual = best;
  r.column_gain = best_beta;
  return r;
}

}  // namespace

ConversionResult convert_matrix(const CrossbarParams& p, const SolverOptions& o, const Eigen::MatrixXd& g,
                                const Eigen::VectorXd& v_operating, const MatrixConversionOptions& mo) {
  const int m = static_cast<int>(g.rows()), n = static_cast<int>(g.cols());
  if (v_operating.size() != m) throw InputError("operating-point signal must have one voltage per crossbar row");
  const Eigen::MatrixXd lo = Eigen::MatrixXd::Constant(m, n, p.g_min_s);
  const Eigen::MatrixXd hi = Eigen::MatrixXd::Constant(m, n, p.g_max_s);
  // Start from the signal conversion with a constant signal (exact where inputs are uniform).
  const Eigen::VectorXd v_start = Eigen::VectorXd::Constant(m, 0.1 * p.v_in_max_v);
  ConversionResult start = convert_signal(p, g, v_start);
  ConversionResult r;
  if (p.is_linear()) {
    // A linear transistor is in series with the memristor: iterate on cell conductances.
    CrossbarParams lin = p;
    lin.transistor.model = TransistorModel::None;
    auto cell = [&](const Eigen::MatrixXd& gm) {
      return gm.unaryExpr([&](double x) { return linear_cell_conductance(p, x); }).eval();
    };
    auto uncell = [&](const Eigen::MatrixXd& c) {
      if (p.transistor.model != TransistorModel::Linear) return c;
      return c.unaryExpr([&](double x) { return 1.0 / (1.0 / x - p.transistor.r_on_ohm); }).eval();
    };
    Eigen::MatrixXd g_start = start.g_prime;
    Eigen::VectorXd beta0 = Eigen::VectorXd::Ones(n);
    if (mo.column_scaling && start.above_max > 0) {
      // Cheap first guess of the column gains: signal conversions (O(mn) each) of the scaled
      // targets, adjusting each column until its most demanding cell fits g_max.
      for (int round = 0; round < 40; ++round) {
        Eigen::MatrixXd t = g;
        for (int j = 0; j < n; ++j) t.col(j) = (p.g_min_s + beta0(j) * (g.col(j).array() - p.g_min_s)).matrix();
        const ConversionResult raw = convert_signal_impl(p, t, v_start, false);
        bool done = true;
        for (int j = 0; j < n; ++j) {
          double worst = 0;
          for (int i = 0; i < m; ++i) worst = std::max(worst, raw.g_prime(i, j) / p.g_max_s);
          if (!std::isfinite(worst)) worst = 10;
          if (worst > 0.99 || worst < 0.9) {
            beta0(j) = std::min(1.0, beta0(j) * std::pow(0.95 / worst, 0.8));
            done = false;
          }
        }
        g_start = raw.g_prime.cwiseMax(lo).cwiseMin(hi);
        if (done) break;
      }
    }
    r = matrix_linear(lin, o, g, cell(g_start), cell(lo), cell(hi), p.g_min_s, mo, beta0);
    r.g_prime = uncell(r.g_prime);
  } else {
    // Nonlinear devices: linearise around the operating signal with chord conductances
    // kappa_ij = I_cell / (G'_ij * (V_T - V_B)), run the linear matrix conversion on the
    // cell conductances, map back, and repeat (the chords move with G').
    auto solver = make_crossbar_solver(p, o);
    CrossbarParams lin = p;
    lin.memristor.model = MemristorModel::Linear;
    lin.transistor.model = TransistorModel::None;
    Eigen::MatrixXd gp = start.g_prime;
    for (int outer = 0; outer < 4; ++outer) {
      solver->program(gp);
      const CircuitSolution s = solver->solve(v_operating);
      Eigen::MatrixXd kappa(m, n);
      for (int i = 0; i < m; ++i)
        for (int j = 0; j < n; ++j) {
          const double dv = s.v_top(i, j) - s.v_bottom(i, j);
          kappa(i, j) = std::abs(dv) > 1e-12 ? s.cell_current(i, j) / (gp(i, j) * dv)
                                             : linear_cell_conductance(p, gp(i, j)) / gp(i, j);
        }
      r = matrix_linear(lin, o, g, gp.cwiseProduct(kappa), lo.cwiseProduct(kappa), hi.cwiseProduct(kappa), p.g_min_s,
                        mo);
      gp = r.g_prime.cwiseQuotient(kappa).cwiseMax(lo).cwiseMin(hi);
    }
    r.g_prime = gp;
  }
  r.above_max = r.below_min = 0;
  for (int i = 0; i < m; ++i)
    for (int j = 0; j < n; ++j) {
      if (r.g_prime(i, j) >= p.g_max_s * (1 - 1e-12)) ++r.above_max;
      if (r.g_prime(i, j) <= p.g_min_s * (1 + 1e-12)) ++r.below_min;
    }
  return r;
}

}  // namespace xbarsim
