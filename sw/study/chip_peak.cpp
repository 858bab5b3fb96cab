#include "sw/study/chip_peak.h"

#include <algorithm>
#include <optional>

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

ChipPeak chip_peak(const HardwareContext& hw) {
  const Architecture& a = hw.arch;
  const std::optional<Bill> read = a.machine ? a.core().core_read(hw) : std::nullopt;
  if (!read)
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
  r.per_read = *read;  // one core's read: every column a neuron read, every cell read; leakage over the read
  r.tops = r.ops_per_read * static_cast<double>(r.cores) / r.steps.time_ns * 1e-3;  // ops/ns = 1e9 ops/s; TOPS
  for (const auto& [part, pj] : r.per_read.energy_pj) r.fj_per_op[part] = pj * 1e3 / r.ops_per_read;
  r.tops_per_w = r.ops_per_read / r.per_read.total_energy_pj();  // ops/pJ = TOPS/W
  r.core_area_mm2 = r.per_read.total_area_mm2();
  for (const auto& [part, mm2] : r.per_read.area_mm2) r.area_share[part] = mm2 / r.core_area_mm2;
  return r;
}

}  // namespace xbarsim
