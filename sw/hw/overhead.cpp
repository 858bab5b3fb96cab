#include "sw/hw/overhead.h"

#include <algorithm>

namespace xbarsim {

namespace {
int parse_bits_key(const ConfigTree& cfg, const std::string& key) {
  const long long v = cfg.get_int(key);
  if (v < 1 || v > 24)
    throw InputError("configuration key '" + key + "' must be 1..24 bits, got '" + cfg.get_string(key) + "'");
  return static_cast<int>(v);
}
long long ceil_div(long long a, long long b) { return (a + b - 1) / b; }
}  // namespace

HardwareSettings parse_hardware_settings(const ConfigTree& cfg) {
  HardwareSettings hw;
  hw.max_rows = require_size_or_unbounded(cfg, "mapping.max_rows");
  hw.max_cols = require_size_or_unbounded(cfg, "mapping.max_cols");
  hw.adc_bits = parse_bits_key(cfg, "components.adc_bits");
  hw.dac_bits = parse_bits_key(cfg, "components.dac_bits");
  return hw;
}

MappingCost& MappingCost::operator+=(const MappingCost& o) {
  rows += o.rows;
  cols += o.cols;
  crossbars += o.crossbars;
  adcs += o.adcs;
  dacs += o.dacs;
  cells_used += o.cells_used;
  cells_present += o.cells_present;
  iterations += o.iterations;
  xbar_power_mw += o.xbar_power_mw;
  xbar_area_mm2 += o.xbar_area_mm2;
  total_power_mw += o.total_power_mw;
  total_area_mm2 += o.total_area_mm2;
  return *this;
}

MappingCost mapping_cost(long long rows, long long cols, long long cells_used, long long iterations,
                         const HardwareSettings& hw, const ComponentLibrary& lib) {
  MappingCost c;
  c.rows = rows;
  c.cols = cols;
  c.cells_used = cells_used;
  c.iterations = iterations;
  const long long pr = hw.max_rows ? ceil_div(rows, hw.max_rows) : 1;
  const long long pc = hw.max_cols ? ceil_div(cols, hw.max_cols) : 1;
  c.crossbars = pr * pc;
  // Balanced column blocks: (cols % pc) blocks of ceil(cols/pc), the rest floor.
  const long long big = cols % pc, small = pc - big, cb = cols / pc;
  const long long adcs_per_row_block =
      big * ceil_div(cb + 1, lib.adc_columns_per_unit) + small * ceil_div(std::max(cb, 1LL), lib.adc_columns_per_unit);
  c.adcs = pr * adcs_per_row_block;
  c.dacs = rows * pc;
  const long long phys_rows = hw.max_rows ? hw.max_rows : rows;
  const long long phys_cols = hw.max_cols ? hw.max_cols : cols;
  c.cells_present = c.crossbars * phys_rows * phys_cols;
  c.xbar_power_mw = c.cells_present * lib.cell_power_mw;
  c.xbar_area_mm2 = c.cells_present * lib.cell_area_mm2;
  c.total_power_mw = c.xbar_power_mw + c.adcs * lib.adc.power_at(hw.adc_bits) + c.dacs * lib.dac.power_at(hw.dac_bits) +
                     c.crossbars * lib.accumulator_power_mw;
  c.total_area_mm2 = c.xbar_area_mm2 + c.adcs * lib.adc.area_at(hw.adc_bits) + c.dacs * lib.dac.area_at(hw.dac_bits) +
                     c.crossbars * lib.accumulator_area_mm2;
  return c;
}

std::vector<LayerOverhead> overhead_study(const Model& m, const HardwareSettings& hw, const ComponentLibrary& lib) {
  std::vector<LayerOverhead> out;
  for (const LinearLayer& L : m.linear) {
    LayerOverhead o;
    o.name = L.name;
    o.k_h = L.k_h;
    o.k_w = L.k_w;
    o.c_in = L.c_in;
    o.c_out = L.c_out;
    o.input = L.in;
    o.dense = mapping_cost(L.rows(), L.c_out, static_cast<long long>(L.rows()) * L.c_out, L.iterations(), hw, lib);
    // Toeplitz of the valid convolution on the layer's input: every output (pixel, channel)
    // is one column holding the K weights of its window.
    const long long oh = L.is_conv ? (L.in.h - L.k_h) / L.stride_h + 1 : 1;
    const long long ow = L.is_conv ? (L.in.w - L.k_w) / L.stride_w + 1 : 1;
    const long long rows = static_cast<long long>(L.in.h) * L.in.w * L.c_in;
    const long long cols = oh * ow * L.c_out;
    o.sparse = mapping_cost(rows, cols, cols * L.rows(), 1, hw, lib);
    out.push_back(o);
  }
  return out;
}

}  // namespace xbarsim
