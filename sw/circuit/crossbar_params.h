#pragma once
/// Physical parameters of one 1T1M crossbar (configuration keys under `crossbar.`).
#include <string>

#include "sw/common/config.h"

namespace xbarsim {

enum class MemristorModel { Linear, Sinh };
enum class TransistorModel { None, Linear, Level1 };
/// How each column is read (crossbar.sensing). current: the column ends in r_out at the virtual
/// ground of a transimpedance amplifier and its current is the output. voltage: the column end is
/// open (a sampling capacitor draws no DC current, as NeuRRAM's neuron, Wan et al., Nature 608,
/// 504 (2022)); r_out carries no current and the output is the settled column voltage, with ideal
/// wires V_j = sum_i I_ij = 0, i.e. sum_i G_ij V_i / sum_i G_ij for linear cells.
enum class Sensing { Current, Voltage };

/// Largest k*V the sinh model accepts (at the read voltage, the input range and every input):
/// sinh overflows near 710.
constexpr double kMaxSinhArgument = 600;

/// Smallest crossbar.r_wire with nonlinear devices (ohm): below it the per-vector Newton's
/// updates stall at the rounding level of the wires' currents (1e-8 failed on an 8x4 array).
constexpr double kMinNonlinearWireOhm = 1e-6;

/// Memristor I-V. linear: I = G*V. sinh: I = G*v_read*sinh(k*V)/sinh(k*v_read), so that the
/// nominal conductance G is the chord conductance at the read voltage.
struct MemristorParams {
  MemristorModel model = MemristorModel::Linear;
  double k_per_v = 5.0;
  double v_read_v = 0.2;
};

/// Access transistor between the memristor (M) and the column wire (B).
/// none: ideal short. linear: r_on. level1: SPICE level-1 NMOS with the gate at vg,
/// symmetric source/drain, lambda = 0, no body effect:
/// triode I = kp((Vgs-Vth)Vds - Vds^2/2), saturation I = kp/2 (Vgs-Vth)^2.
struct TransistorParams {
  TransistorModel model = TransistorModel::None;
  double r_on_ohm = 1000.0;
  double vg_v = 3.3;
  double vth_v = 0.5;
  double kp_a_per_v2 = 1e-3;
};

/// Circuit of an m x n crossbar (see docs/physics.md "The circuit"): row i is driven by an ideal
/// source V_i through r_in, then r_wire segments between cells; column j runs through r_wire
/// segments to r_out and the virtual ground of the sense amplifier (current sensing) or to an
/// open end (voltage sensing).
struct CrossbarParams {
  double r_wire_ohm = 1.0;
  double r_in_ohm = 1.0;
  double r_out_ohm = 1.0;
  Sensing sensing = Sensing::Current;
  double g_min_s = 1.0 / 300e3;
  double g_max_s = 1.0 / 15e3;
  double v_in_max_v = 0.4;
  MemristorParams memristor;
  TransistorParams transistor;

  bool voltage_sensing() const { return sensing == Sensing::Voltage; }
  bool is_linear() const {
    return memristor.model == MemristorModel::Linear && transistor.model != TransistorModel::Level1;
  }
};

/// Reads and validates the `crossbar.` section.
CrossbarParams parse_crossbar_params(const ConfigTree& cfg);

const char* to_string(MemristorModel m);
const char* to_string(TransistorModel t);
const char* to_string(Sensing s);

enum class SolverMethod { Auto, Line, Direct };
const char* to_string(SolverMethod m);
/// auto | line | direct; InputError otherwise.
SolverMethod solver_method_from_name(const std::string& name);

/// Options of the circuit solvers (configuration keys under `solver.`).
struct SolverOptions {
  SolverMethod method = SolverMethod::Auto;  ///< auto (= line) | line | direct
  double tolerance = 1e-12;                  ///< relative preconditioned residual of linear solves
  int max_iterations = 2000;                 ///< iterations of the structured solver per linear solve
  int newton_max_iterations = 60;
  double newton_tolerance = 1e-12;  ///< max |dV| / max |V_in| at convergence (and KCL reltol)
  double newton_abstol_a = 1e-12;   ///< A, KCL residual allowed at every node at convergence
  double max_step_v = 0.2;          ///< Newton voltage limiting
  bool batched_nonlinear = true;    ///< many vectors with nonlinear devices: BatchNewtonSolver (else per-vector Newton)
  double nonlinear_tolerance = 1e-9;  ///< batched: column currents within this (relative) of the exact solution
  int threads = 0;                    ///< 0 = hardware concurrency
};

SolverOptions parse_solver_options(const ConfigTree& cfg);

/// Number of worker threads to use for `requested` (0 = all cores).
int resolve_threads(int requested);

}  // namespace xbarsim
