#include "sw/hw/overhead.h"

#include <algorithm>

namespace xbarsim {

namespace {
long long ceil_div(long long a, long long b) { return (a + b - 1) / b; }
/// a * b, or InputError when the count does not fit in 64 bits.
long long mul(long long a, long long b) {
  long long r = 0;
  if (__builtin_mul_overflow(a, b, &r)) throw InputError("the mapping is too large to count (over 9.2e18 cells)");
  return r;
}
}  // namespace

HardwareSettings parse_hardware_settings(const ConfigTree& cfg) {
  HardwareSettings hw;
  hw.max_rows = require_size_or_unbounded(cfg, "mapping.max_rows");
  hw.max_cols = require_size_or_unbounded(cfg, "mapping.max_cols");
  hw.adc_bits = cfg.get_int32("components.adc_bits");
  hw.dac_bits = cfg.get_int32("components.dac_bits");
  return hw;
}

MappingCost& MappingCost::operator+=(const MappingCost& o) {
  for (auto f : {&MappingCost::rows, &MappingCost::cols, &MappingCost::crossbars, &MappingCost::adcs, &MappingCost::dacs,
                 &MappingCost::cells_used, &MappingCost::cells_present, &MappingCost::iterations})
    if (__builtin_add_overflow(this->*f, o.*f, &(this->*f)))
      throw InputError("the mapping is too large to count (a total exceeds 9.2e18)");
  xbar_power_mw += o.xbar_power_mw;
  xbar_area_mm2 += o.xbar_area_mm2;
  total_power_mw += o.total_power_mw;
  total_area_mm2 += o.total_area_mm2;
  return *this;
}

MappingCost mapping_cost(long long rows, long long cols, long long cells_used, long long iterations,
                         const HardwareSettings& hw, const ComponentLibrary& lib) {
  if (rows < 1 || cols < 1)
    throw InputError("cannot map a " + std::to_string(rows) + " x " + std::to_string(cols) + " matrix onto crossbars");
  MappingCost c;
  c.rows = rows;
  c.cols = cols;
  c.cells_used = cells_used;
  c.iterations = iterations;
  const long long pr = hw.max_rows ? ceil_div(rows, hw.max_rows) : 1;
  const long long pc = hw.max_cols ? ceil_div(cols, hw.max_cols) : 1;
  c.crossbars = mul(pr, pc);
  // Balanced column blocks: (cols % pc) blocks of ceil(cols/pc), the rest floor.
  const long long big = cols % pc, small = pc - big, cb = cols / pc;
  const long long adcs_per_row_block =
      big * ceil_div(cb + 1, lib.adc_columns_per_unit) + small * ceil_div(std::max(cb, 1LL), lib.adc_columns_per_unit);
  c.adcs = mul(pr, adcs_per_row_block);
  c.dacs = mul(rows, pc);
  const long long phys_rows = hw.max_rows ? hw.max_rows : rows;
  const long long phys_cols = hw.max_cols ? hw.max_cols : cols;
  c.cells_present = mul(mul(c.crossbars, phys_rows), phys_cols);
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
    if (L.is_conv && (L.in.h < L.k_h || L.in.w < L.k_w))
      throw InputError("layer '" + L.name + "': its " + std::to_string(L.in.h) + "x" + std::to_string(L.in.w) +
                       " input is smaller than its " + std::to_string(L.k_h) + "x" + std::to_string(L.k_w) +
                       " kernel, so the sparse (valid-convolution Toeplitz) mapping has no outputs; use a larger input");
    const long long oh = L.is_conv ? (L.in.h - L.k_h) / L.stride_h + 1 : 1;
    const long long ow = L.is_conv ? (L.in.w - L.k_w) / L.stride_w + 1 : 1;
    const long long rows = mul(mul(L.in.h, L.in.w), L.c_in);
    const long long cols = mul(mul(oh, ow), L.c_out);
    o.sparse = mapping_cost(rows, cols, mul(cols, L.rows()), 1, hw, lib);
    out.push_back(o);
  }
  return out;
}

}  // namespace xbarsim
