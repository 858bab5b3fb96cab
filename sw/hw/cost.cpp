#include "sw/hw/cost.h"

namespace xbarsim {

namespace {
constexpr double kKiB = 1024.0;
}

ComponentBreakdown& ComponentBreakdown::operator+=(const ComponentBreakdown& o) {
  crossbar += o.crossbar;
  adc += o.adc;
  dac += o.dac;
  accumulator += o.accumulator;
  shift_register += o.shift_register;
  buffer += o.buffer;
  interconnect += o.interconnect;
  digital += o.digital;
  memory += o.memory;
  return *this;
}

ComponentBreakdown ComponentBreakdown::operator*(double k) const {
  return {crossbar * k, adc * k,          dac * k,     accumulator * k, shift_register * k,
          buffer * k,   interconnect * k, digital * k, memory * k};
}

nlohmann::json ComponentBreakdown::to_json() const {
  return {{"crossbar", crossbar},
          {"adc", adc},
          {"dac", dac},
          {"accumulator", accumulator},
          {"shift_register", shift_register},
          {"buffer", buffer},
          {"interconnect", interconnect},
          {"digital", digital},
          {"memory", memory},
          {"total", total()}};
}

ActionCounts& ActionCounts::operator+=(const ActionCounts& o) {
  dac_conversions += o.dac_conversions;
  adc_conversions += o.adc_conversions;
  cell_reads += o.cell_reads;
  accumulates += o.accumulates;
  shifts += o.shifts;
  buffer_read_bytes += o.buffer_read_bytes;
  buffer_write_bytes += o.buffer_write_bytes;
  bus_bytes += o.bus_bytes;
  digital_ops += o.digital_ops;
  memory_bytes += o.memory_bytes;
  return *this;
}

ComponentBreakdown CostModel::area_mm2(const LayerInventory& v) const {
  ComponentBreakdown a;
  a.crossbar = v.cells_present * lib.cell.area_mm2;
  a.adc = v.adcs * lib.adc.area_at(adc_bits_priced());
  a.dac = v.dacs * (lib.dac.area_at(dac_bits_priced()) + (dac_lut ? lib.dac_lut.area_mm2 : 0.0));
  a.accumulator = v.accumulators * lib.accumulator.area_mm2;
  a.shift_register = v.shift_register_entries * lib.shift_register.area_mm2_per_entry;
  a.buffer = v.buffer_bytes / kKiB * lib.buffer.area_mm2_per_kib;
  return a;
}

ComponentBreakdown CostModel::leakage_mw(const LayerInventory& v) const {
  ComponentBreakdown p;
  p.crossbar = v.cells_present * lib.cell.leakage_mw;
  p.adc = v.adcs * lib.adc.leakage_mw;
  p.dac = v.dacs * (lib.dac.leakage_mw + (dac_lut ? lib.dac_lut.leakage_mw : 0.0));
  p.accumulator = v.accumulators * lib.accumulator.leakage_mw;
  p.shift_register = v.shift_register_entries * lib.shift_register.leakage_mw_per_entry;
  p.buffer = v.buffer_bytes / kKiB * lib.buffer.leakage_mw_per_kib;
  return p;
}

ComponentBreakdown CostModel::peak_power_mw(const LayerInventory& v) const {
  // pJ per action x actions per ns (GHz) = mW. Every cell and converter of every array is
  // active: the arrays' cells present, not only the used ones (the paper's table).
  const double clock_ghz = clock_mhz * 1e-3;
  ComponentBreakdown p = leakage_mw(v);
  p.crossbar += v.cells_present * lib.cell.read_pj * clock_ghz;
  p.adc += v.adcs * lib.adc.conversion_pj_at(adc_bits_priced()) * lib.adc_sample_rate_gsps;
  p.dac += v.dacs * dac_conversion_pj() * clock_ghz;
  p.accumulator += v.accumulators * lib.accumulator.accumulate_pj * clock_ghz;
  return p;
}

ComponentBreakdown CostModel::dynamic_energy_pj(const ActionCounts& a) const {
  ComponentBreakdown e;
  e.crossbar = a.cell_reads * lib.cell.read_pj;
  e.adc = a.adc_conversions * lib.adc.conversion_pj_at(adc_bits_priced());
  e.dac = a.dac_conversions * dac_conversion_pj();
  e.accumulator = a.accumulates * lib.accumulator.accumulate_pj;
  e.shift_register = a.shifts * lib.shift_register.shift_pj;
  e.buffer = a.buffer_read_bytes * lib.buffer.read_pj_per_byte + a.buffer_write_bytes * lib.buffer.write_pj_per_byte;
  e.interconnect = a.bus_bytes * lib.interconnect.transfer_pj_per_byte;
  e.digital = a.digital_ops * lib.digital.op_pj;
  e.memory = a.memory_bytes * lib.memory.transfer_pj_per_byte;
  return e;
}

ComponentBreakdown CostModel::platform_area_mm2(int digital_units) const {
  ComponentBreakdown a;
  a.interconnect = lib.interconnect.area_mm2;
  a.digital = digital_units * lib.digital.area_mm2;
  return a;
}

ComponentBreakdown CostModel::platform_leakage_mw(int digital_units) const {
  ComponentBreakdown p;
  p.interconnect = lib.interconnect.leakage_mw;
  p.digital = digital_units * lib.digital.leakage_mw;
  return p;
}

ActionCounts layer_actions_per_image(const LayerInventory& v, long long shifted_entries) {
  const double n = static_cast<double>(v.iterations);
  ActionCounts a;
  a.dac_conversions = n * v.dacs;
  a.cell_reads = n * v.cells_used;
  a.adc_conversions = n * v.row_blocks * v.physical_cols;
  a.accumulates = n * v.row_blocks * v.cols;
  a.shifts = static_cast<double>(shifted_entries);
  // Inputs come from the layer's buffer (into the shift register, or straight to the DACs
  // of a sparse layer); outputs are written to the next layer's buffer.
  a.buffer_read_bytes =
      v.scheme == MappingScheme::Dense ? static_cast<double>(shifted_entries) : static_cast<double>(v.rows);
  a.buffer_write_bytes = n * v.cols;
  return a;
}

}  // namespace xbarsim
