#include "sw/circuit/crossbar_params.h"

#include <sstream>
#include <thread>

namespace xbarsim {

CrossbarParams parse_crossbar_params(const ConfigTree& cfg) {
  CrossbarParams p;
  p.r_wire_ohm = cfg.get_double("crossbar.r_wire");
  p.r_in_ohm = cfg.get_double("crossbar.r_in");
  p.r_out_ohm = cfg.get_double("crossbar.r_out");
  p.sensing = require_enum<Sensing>(cfg, "crossbar.sensing", {{"current", Sensing::Current}, {"voltage", Sensing::Voltage}});
  p.g_min_s = cfg.get_double("crossbar.g_min");
  p.g_max_s = cfg.get_double("crossbar.g_max");
  if (!(p.g_max_s > p.g_min_s)) {
    std::ostringstream os;
    os << "configuration key 'crossbar.g_max' (" << p.g_max_s << ") must exceed 'crossbar.g_min' (" << p.g_min_s << ")";
    throw InputError(os.str());
  }
  p.v_in_max_v = cfg.get_double("crossbar.v_in_max");
  const std::string mem = require_one_of(cfg, "crossbar.memristor.model", {"linear", "sinh"});
  p.memristor.model = mem == "sinh" ? MemristorModel::Sinh : MemristorModel::Linear;
  p.memristor.k_per_v = cfg.get_double("crossbar.memristor.k");
  p.memristor.v_read_v = cfg.get_double("crossbar.memristor.v_read");
  if (p.memristor.model == MemristorModel::Sinh) {
    // sinh overflows near 710: I = G v_read sinh(kV) / sinh(k v_read) would be 0 or NaN.
    auto check = [&](const char* key, double v) {
      if (p.memristor.k_per_v * v <= kMaxSinhArgument) return;
      std::ostringstream os;
      os << "crossbar.memristor.k (" << p.memristor.k_per_v << " 1/V) times " << key << " (" << v << " V) is "
         << p.memristor.k_per_v * v << "; the sinh memristor model needs at most " << kMaxSinhArgument
         << " (sinh overflows near 710)";
      throw InputError(os.str());
    };
    check("crossbar.memristor.v_read", p.memristor.v_read_v);
    check("crossbar.v_in_max", p.v_in_max_v);
  }
  const std::string tr = require_one_of(cfg, "crossbar.transistor.model", {"none", "linear", "level1"});
  p.transistor.model = tr == "none"     ? TransistorModel::None
                       : tr == "linear" ? TransistorModel::Linear
                                        : TransistorModel::Level1;
  p.transistor.r_on_ohm = cfg.get_double("crossbar.transistor.r_on");
  p.transistor.vg_v = cfg.get_double("crossbar.transistor.vg");
  p.transistor.vth_v = cfg.get_double("crossbar.transistor.vth");
  p.transistor.kp_a_per_v2 = cfg.get_double("crossbar.transistor.kp");
  if (!p.is_linear() && p.r_wire_ohm < kMinNonlinearWireOhm) {
    std::ostringstream os;
    os << "crossbar.r_wire (" << p.r_wire_ohm << " ohm) must be at least " << kMinNonlinearWireOhm
       << " ohm with nonlinear devices: against wires that much stiffer than the cells the Newton solve cannot "
          "resolve the cells in double precision (and the wires are ideal for every purpose at "
       << kMinNonlinearWireOhm << " ohm)";
    throw InputError(os.str());
  }
  if (p.transistor.model == TransistorModel::Level1 && !(p.transistor.vg_v - p.transistor.vth_v > p.v_in_max_v)) {
    std::ostringstream os;
    os << "crossbar.transistor: vg - vth (" << p.transistor.vg_v - p.transistor.vth_v
       << " V) must exceed crossbar.v_in_max (" << p.v_in_max_v
       << " V), otherwise access transistors cut off inside the input range";
    throw InputError(os.str());
  }
  return p;
}

const char* to_string(MemristorModel m) { return m == MemristorModel::Sinh ? "sinh" : "linear"; }
const char* to_string(TransistorModel t) {
  return t == TransistorModel::None ? "none" : t == TransistorModel::Linear ? "linear" : "level1";
}

const char* to_string(Sensing s) {
  switch (s) {
    case Sensing::Current:
      return "current";
    case Sensing::Voltage:
      return "voltage";
  }
  return "current";  // unreachable: every enumerator returns above
}

const char* to_string(SolverMethod m) {
  return m == SolverMethod::Line ? "line" : m == SolverMethod::Direct ? "direct" : "auto";
}

SolverMethod solver_method_from_name(const std::string& name) {
  if (name == "auto") return SolverMethod::Auto;
  if (name == "line") return SolverMethod::Line;
  if (name == "direct") return SolverMethod::Direct;
  throw InputError("configuration key 'solver.method': '" + name + "' is not one of: auto, line, direct");
}

SolverOptions parse_solver_options(const ConfigTree& cfg) {
  SolverOptions o;
  o.method = solver_method_from_name(cfg.get_string("solver.method"));
  o.tolerance = cfg.get_double("solver.tolerance");
  o.max_iterations = cfg.get_int32("solver.max_iterations");
  o.newton_max_iterations = cfg.get_int32("solver.newton_max_iterations");
  o.newton_tolerance = cfg.get_double("solver.newton_tolerance");
  o.max_step_v = cfg.get_double("solver.max_step");
  o.newton_abstol_a = cfg.get_double("solver.newton_abstol");
  o.threads = cfg.get_int32("solver.threads");
  o.batched_nonlinear = require_enum<bool>(cfg, "solver.nonlinear", {{"batched", true}, {"newton", false}});
  o.nonlinear_tolerance = cfg.get_double("solver.nonlinear_tolerance");
  return o;
}

int resolve_threads(int requested) {
  if (requested > 0) return requested;
  const unsigned hc = std::thread::hardware_concurrency();
  return hc ? static_cast<int>(hc) : 1;
}

}  // namespace xbarsim
