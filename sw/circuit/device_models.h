#pragma once
/// Device I-V evaluations shared by all circuit solvers (SystemC-free, allocation-free).
#include <cmath>

#include "sw/circuit/crossbar_params.h"

namespace xbarsim {

/// Memristor of nominal conductance g_s (S) with voltage v (V) across it (top minus middle).
class MemristorDevice {
 public:
  explicit MemristorDevice(const MemristorParams& p)
      : sinh_(p.model == MemristorModel::Sinh),
        k_(p.k_per_v),
        scale_(sinh_ ? p.v_read_v / std::sinh(p.k_per_v * p.v_read_v) : 1.0) {}

  /// Current (A) and its derivative dI/dv (S).
  void eval(double g_s, double v, double& i, double& di_dv) const {
    if (!sinh_) {
      i = g_s * v;
      di_dv = g_s;
    } else {
      const double kv = k_ * v;
      i = g_s * scale_ * std::sinh(kv);
      di_dv = g_s * scale_ * k_ * std::cosh(kv);
    }
  }
  /// Small-signal conductance at v = 0 (S).
  double g0(double g_s) const { return sinh_ ? g_s * scale_ * k_ : g_s; }
  bool linear() const { return !sinh_; }
  double k_per_v() const { return k_; }
  /// v_read / sinh(k v_read) for sinh (I = G scale sinh(kV)); 1 for linear.
  double scale() const { return scale_; }
  /// h(v) = I / G at voltage v: v (linear) or scale sinh(k v).
  double current_per_siemens(double v) const { return sinh_ ? scale_ * std::sinh(k_ * v) : v; }
  /// The voltage at which I / G = u: the inverse of current_per_siemens.
  double voltage_for(double u) const { return sinh_ ? std::asinh(u / scale_) / k_ : u; }

 private:
  bool sinh_;
  double k_;
  double scale_;
};

/// Access transistor from terminal a (memristor side, M) to terminal b (column, B).
class TransistorDevice {
 public:
  explicit TransistorDevice(const TransistorParams& p) : p_(p), g_on_(1.0 / p.r_on_ohm) {}

  /// Current a->b (A) and partial derivatives with respect to V_a and V_b (S).
  void eval(double va, double vb, double& i, double& di_dva, double& di_dvb) const {
    if (p_.model == TransistorModel::Linear) {
      i = g_on_ * (va - vb);
      di_dva = g_on_;
      di_dvb = -g_on_;
      return;
    }
    eval_level1(va, vb, i, di_dva, di_dvb);
  }
  /// The level-1 model, branch-free (selects only) so that a loop over cells vectorises.
  /// Symmetric: the lower terminal is the source.
  void eval_level1(double va, double vb, double& i, double& di_dva, double& di_dvb) const {
    const double kp = p_.kp_a_per_v2;
    const bool a_is_drain = va >= vb;
    const double vs = a_is_drain ? vb : va;
    const double vds = a_is_drain ? va - vb : vb - va;
    const double vgst = p_.vg_v - vs - p_.vth_v;
    const bool on = vgst > 0, triode = vds < vgst;
    const double id = on ? (triode ? kp * (vgst * vds - 0.5 * vds * vds) : 0.5 * kp * vgst * vgst) : 0.0;
    const double did_dvd = on && triode ? kp * (vgst - vds) : 0.0;  // saturation: lambda = 0
    const double did_dvs = on ? -kp * vgst : 0.0;
    i = a_is_drain ? id : -id;
    di_dva = a_is_drain ? did_dvd : -did_dvs;
    di_dvb = a_is_drain ? did_dvs : -did_dvd;
  }
  /// Small-signal conductance at V_a = V_b = 0 (S).
  double g0() const {
    double i, a, b;
    eval(0.0, 0.0, i, a, b);
    return a;
  }
  bool is_short() const { return p_.model == TransistorModel::None; }
  bool linear() const { return p_.model != TransistorModel::Level1; }

 private:
  TransistorParams p_;
  double g_on_;
};

/// Conductance of a linear cell (memristor in series with a linear/absent transistor), S.
inline double linear_cell_conductance(const CrossbarParams& p, double g_s) {
  if (p.transistor.model == TransistorModel::Linear) return 1.0 / (1.0 / g_s + p.transistor.r_on_ohm);
  return g_s;
}

}  // namespace xbarsim
