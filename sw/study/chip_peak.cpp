#include "sw/study/chip_peak.h"

#include <algorithm>
#include <cmath>
#include <random>

#include "sw/circuit/crossbar_solver.h"
#include "sw/common/seed.h"

namespace xbarsim {

nlohmann::json ChipPeak::to_json() const {
  return {{"architecture", architecture},
          {"input_bits", input_bits},
          {"output_bits", output_bits},
          {"read", steps.to_json()},
          {"cores", cores},
          {"ops_per_read", ops_per_read},
          {"peak_tops", tops},
          {"peak_tops_per_w", tops_per_w},
          {"energy_fj_per_op", fj_per_op},
          {"input_pulse_pj_per_bit", pulse_pj_per_bit},
          {"core_read_energy_pj", per_read.energy_pj},
          {"core_area_mm2", core_area_mm2},
          {"core_area_share", area_share},
          {"area_mm2", core_area_mm2 * static_cast<double>(cores)}};
}

double input_pulse_pj_per_bit(const Architecture& arch, const AnalogConfig& given) {
  const AnalogConfig ac = with_device_range(given);
  const InputSpec& in = arch.input;
  const int rows = arch.crossbar.rows, cols = arch.crossbar.cols;
  const int per_weight = ac.mapping.columns_per_weight();
  const double g_lo = ac.xbar.g_min_s, g_hi = ac.xbar.g_max_s * (1 - ac.mapping.g_headroom);
  const int code_bits = ac.mapping.code_bits();
  const double levels = code_bits > 0 ? std::exp2(code_bits) - 1 : 0;  // 0: analog cells
  std::mt19937_64 rng(derive_seed(static_cast<uint64_t>(in.seed), {42}));
  std::normal_distribution<double> normal(0, 1);
  std::uniform_real_distribution<double> uniform(0, 1);
  // Weights: Gaussian, clipped, quantized to the mapping's magnitude codes; a differential
  // weight's cells on adjacent rows driven with opposite pulses (pairs: rows) or in adjacent
  // columns (pairs: columns; the other cell of a pair at g_min); a shift mapping's one cell
  // holding w - w_lo.
  auto level = [&](double x) { return levels > 0 ? std::round(x * levels) / levels : x; };  // x in [0, 1]
  auto cell = [&](double x) { return g_lo + (g_hi - g_lo) * level(x); };
  const bool rows_paired = ac.mapping.differential() && in.pairs_on_rows;
  Eigen::MatrixXd g = Eigen::MatrixXd::Constant(rows, cols, g_lo);
  if (rows_paired) {
    for (int j = 0; j < cols; ++j)
      for (int i = 0; i + 1 < rows; i += 2) {
        const double w = std::clamp(normal(rng) / in.weight_clip_sigma, -1.0, 1.0);
        g(i, j) = cell(std::max(w, 0.0));
        g(i + 1, j) = cell(std::max(-w, 0.0));
      }
  } else {
    for (int j0 = 0; j0 + per_weight <= cols; j0 += per_weight)
      for (int i = 0; i < rows; ++i) {
        const double w = std::clamp(normal(rng) / in.weight_clip_sigma, -1.0, 1.0);
        if (ac.mapping.differential()) {
          g(i, j0) = cell(std::max(w, 0.0));
          g(i, j0 + 1) = cell(std::max(-w, 0.0));
        } else {
          g(i, j0) = cell((w + 1) / 2);
        }
      }
  }
  CrossbarParams p = ac.xbar;
  p.sensing = Sensing::Voltage;  // each column settles onto its neuron's sampling capacitor
  const auto solver = make_crossbar_solver(p, ac.solver);
  solver->program(g);
  double joules = 0;
  for (int k = 0; k < in.vectors; ++k) {
    Eigen::VectorXd v(rows);
    v.setZero();
    if (rows_paired) {  // an input's pulse: +v_read on the G+ row, -v_read on the G- row
      for (int i = 0; i + 1 < rows; i += 2)
        if (uniform(rng) < in.bit_density) v(i) = in.v_read_v, v(i + 1) = -in.v_read_v;
    } else {
      for (int i = 0; i < rows; ++i) v(i) = uniform(rng) < in.bit_density ? in.v_read_v : 0.0;
    }
    // What the drivers deliver: the cells', wires' and access transistors' dissipation.
    joules += source_power_w(solver->solve(v), v) * in.pulse_ns * 1e-9;
  }
  return joules / in.vectors * 1e12;
}

ChipPeak chip_peak(const HardwareContext& hw) {
  const Architecture& a = hw.arch;
  if (!a.machine || !a.neuron_cores())
    throw InputError("give --model or --preset: without a network simulate reports the peak figures of a machine "
                     "of neuron cores (e.g. --config configs/neurram.yaml), and architecture.machine " + a.name +
                     " has none");
  ChipPeak r;
  r.architecture = a.name;
  r.input_bits = hw.converters.activation_bits();  // both set: make_hardware_context checked them
  r.output_bits = hw.converters.adc_bits;
  r.steps = hw.read_steps;
  r.cores = a.chip.tiles * static_cast<long long>(a.tile.imas) * a.ima.crossbars;
  // Two operations per weight (a MAC), a weight per columns_per_weight cells (on rows or columns).
  r.ops_per_read = 2.0 * a.crossbar.rows * a.crossbar.cols / std::max(1, hw.mapping.columns_per_weight()) *
                   a.ima.crossbars;
  r.pulse_pj_per_bit = hw.core_pulse_pj_per_bit * a.ima.crossbars;
  // One core's read: every column a neuron read, every cell read; leakage over the read.
  const double xbars = a.ima.crossbars;
  r.per_read = price(hw.lib.named, a.ima.components,
                     neuron_read_ledger(hw, hw.read_steps, xbars * a.crossbar.cols, xbars * a.crossbar.rows * a.crossbar.cols),
                     r.steps.time_ns);
  r.tops = r.ops_per_read * static_cast<double>(r.cores) / r.steps.time_ns * 1e-3;  // ops/ns = 1e9 ops/s; TOPS
  for (const auto& [part, pj] : r.per_read.energy_pj) r.fj_per_op[part] = pj * 1e3 / r.ops_per_read;
  r.tops_per_w = r.ops_per_read / r.per_read.total_energy_pj();  // ops/pJ = TOPS/W
  r.core_area_mm2 = r.per_read.total_area_mm2();
  for (const auto& [part, mm2] : r.per_read.area_mm2) r.area_share[part] = mm2 / r.core_area_mm2;
  return r;
}

}  // namespace xbarsim
