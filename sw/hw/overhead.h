#pragma once
/// Hardware cost of mapping a network's Conv/Gemm layers onto crossbars: dense mapping
/// (one unrolled 3-D kernel per column, one iteration per output pixel) versus sparse
/// (Toeplitz, valid convolution, one iteration per image), after partitioning.
#include <string>
#include <vector>

#include "sw/hw/component_library.h"
#include "sw/nn/model.h"

namespace xbarsim {

struct HardwareSettings {
  int max_rows = 0, max_cols = 0;  ///< 0 = unbounded (one crossbar per layer)
  int adc_bits = 8, dac_bits = 8;
};

/// Reads mapping.max_rows/max_cols and components.adc_bits/dac_bits.
HardwareSettings parse_hardware_settings(const ConfigTree& cfg);

/// Cost of one logical rows x cols matrix on crossbars.
/// Counting rules: crossbars = ceil(rows/R) * ceil(cols/C) with balanced blocks; one DAC
/// per used crossbar row, one ADC per `adc_columns_per_unit` used columns of each
/// crossbar; cells present = physical arrays (R x C each, or exactly rows x cols when
/// unbounded); power/area = cells present x per-cell figures + converters (scaled to
/// their bits) + one accumulator per crossbar.
struct MappingCost {
  long long rows = 0, cols = 0, crossbars = 0, adcs = 0, dacs = 0;
  long long cells_used = 0, cells_present = 0, iterations = 0;
  double xbar_power_mw = 0, xbar_area_mm2 = 0, total_power_mw = 0, total_area_mm2 = 0;
  double utilization() const { return cells_present ? static_cast<double>(cells_used) / cells_present : 0.0; }
  MappingCost& operator+=(const MappingCost& o);
};

MappingCost mapping_cost(long long rows, long long cols, long long cells_used, long long iterations,
                         const HardwareSettings& hw, const ComponentLibrary& lib);

struct LayerOverhead {
  std::string name;
  int k_h = 1, k_w = 1, c_in = 0, c_out = 0;
  Shape input;
  MappingCost dense, sparse;
};

/// Dense and sparse costs of every linear layer of `m`.
std::vector<LayerOverhead> overhead_study(const Model& m, const HardwareSettings& hw, const ComponentLibrary& lib);

}  // namespace xbarsim
