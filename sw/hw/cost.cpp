#include "sw/hw/cost.h"

namespace xbarsim {

namespace {
constexpr double kKiB = 1024.0;
}

namespace {
/// Every figure of a breakdown, for the element-wise operations.
constexpr double ComponentBreakdown::*kParts[] = {&ComponentBreakdown::crossbar,
                                                  &ComponentBreakdown::adc,
                                                  &ComponentBreakdown::dac,
                                                  &ComponentBreakdown::accumulator,
                                                  &ComponentBreakdown::shift_register,
                                                  &ComponentBreakdown::buffer,
                                                  &ComponentBreakdown::sample_hold,
                                                  &ComponentBreakdown::shift_add,
                                                  &ComponentBreakdown::output_register,
                                                  &ComponentBreakdown::interconnect,
                                                  &ComponentBreakdown::digital,
                                                  &ComponentBreakdown::memory};
}  // namespace

ComponentBreakdown& ComponentBreakdown::operator+=(const ComponentBreakdown& o) {
  for (auto f : kParts) this->*f += o.*f;
  for (const auto& [name, v] : o.parts) parts[name] += v;
  return *this;
}

ComponentBreakdown ComponentBreakdown::operator*(double k) const {
  ComponentBreakdown r = *this;
  for (auto f : kParts) r.*f *= k;
  for (auto& [name, v] : r.parts) v *= k;
  return r;
}

nlohmann::json ComponentBreakdown::to_json() const {
  nlohmann::json j = {{"crossbar", crossbar},
          {"adc", adc},
          {"dac", dac},
          {"accumulator", accumulator},
          {"shift_register", shift_register},
          {"buffer", buffer},
          {"sample_hold", sample_hold},
          {"shift_add", shift_add},
          {"output_register", output_register},
          {"interconnect", interconnect},
          {"digital", digital},
          {"memory", memory},
          {"total", total()}};
  for (const auto& [name, v] : parts) j[name] = v;
  return j;
}

ActionCounts& ActionCounts::operator+=(const ActionCounts& o) {
  dac_conversions += o.dac_conversions;
  adc_conversions += o.adc_conversions;
  cell_reads += o.cell_reads;
  accumulates += o.accumulates;
  shifts += o.shifts;
  samples += o.samples;
  shift_adds += o.shift_adds;
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
  a.shift_register = v.shift_register_entries * v.input_bytes * lib.shift_register.area_mm2_per_entry;
  a.buffer = v.buffer_bytes / kKiB * lib.buffer.area_mm2_per_kib;
  a.sample_hold = v.sample_holds * lib.sample_hold.area_mm2;
  a.shift_add = shift_add_units(v) * lib.shift_add.area_mm2;
  a.output_register = v.output_register_bytes * lib.output_register.area_mm2_per_byte;
  return a;
}

ComponentBreakdown CostModel::leakage_mw(const LayerInventory& v) const {
  ComponentBreakdown p;
  p.crossbar = v.cells_present * lib.cell.leakage_mw;
  p.adc = v.adcs * lib.adc.leakage_mw;
  p.dac = v.dacs * (lib.dac.leakage_mw + (dac_lut ? lib.dac_lut.leakage_mw : 0.0));
  p.accumulator = v.accumulators * lib.accumulator.leakage_mw;
  p.shift_register = v.shift_register_entries * v.input_bytes * lib.shift_register.leakage_mw_per_entry;
  p.buffer = v.buffer_bytes / kKiB * lib.buffer.leakage_mw_per_kib;
  p.sample_hold = v.sample_holds * lib.sample_hold.leakage_mw;
  p.shift_add = shift_add_units(v) * lib.shift_add.leakage_mw;
  p.output_register = v.output_register_bytes * lib.output_register.leakage_mw_per_byte;
  return p;
}

ComponentBreakdown CostModel::peak_power_mw(const LayerInventory& v) const {
  return peak_power_mw(v, v.adcs * lib.adc_sample_rate_gsps);
}

ComponentBreakdown CostModel::peak_power_mw(const LayerInventory& v, double conversions_per_ns) const {
  // pJ per action x actions per ns (GHz) = mW. Every cell and converter of every array is
  // active: the arrays' cells present, not only the used ones (the paper's table).
  const double clock_ghz = clock_mhz * 1e-3;
  ComponentBreakdown p = leakage_mw(v);
  p.crossbar += v.cells_present * lib.cell.read_pj * clock_ghz;
  p.adc += conversions_per_ns * lib.adc.conversion_pj_at(adc_bits_priced());
  p.dac += v.dacs * dac_conversion_pj() * clock_ghz;
  p.accumulator += v.accumulators * lib.accumulator.accumulate_pj * clock_ghz;
  // One read per cycle: every DAC reads its input register entry, every column is sampled;
  // every conversion is shifted, added and written to the output register (sliced reads).
  p.shift_register += v.dacs * lib.shift_register.read_pj * clock_ghz;
  p.sample_hold += v.sample_holds * lib.sample_hold.sample_pj * clock_ghz;
  if (v.sliced()) {
    p.shift_add += conversions_per_ns * lib.shift_add.op_pj;
    p.output_register += conversions_per_ns * lib.output_register.write_pj;
  }
  return p;
}

ComponentBreakdown CostModel::dynamic_energy_pj(const ActionCounts& a) const {
  ComponentBreakdown e;
  e.crossbar = a.cell_reads * lib.cell.read_pj;
  e.adc = a.adc_conversions * lib.adc.conversion_pj_at(adc_bits_priced());
  e.dac = a.dac_conversions * dac_conversion_pj();
  e.accumulator = a.accumulates * lib.accumulator.accumulate_pj;
  e.shift_register = a.shifts * lib.shift_register.shift_pj + a.dac_conversions * lib.shift_register.read_pj;
  e.sample_hold = a.samples * lib.sample_hold.sample_pj;
  e.shift_add = a.shift_adds * lib.shift_add.op_pj;
  e.output_register = a.shift_adds * lib.output_register.write_pj;
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

long long CostModel::shift_add_units(const LayerInventory& v) const {
  return v.sliced() ? (v.adcs + lib.shift_add.adcs_per_unit - 1) / lib.shift_add.adcs_per_unit : 0;
}

ActionCounts layer_actions_per_image(const LayerInventory& v, long long shifted_entries) {
  const double n = static_cast<double>(v.iterations), reads = static_cast<double>(v.reads());
  ActionCounts a;
  a.dac_conversions = reads * v.dacs;
  a.cell_reads = reads * v.cells_used;
  a.adc_conversions = reads * v.row_blocks * v.physical_cols;
  a.samples = a.adc_conversions;
  a.shift_adds = v.sliced() ? a.adc_conversions : 0.0;
  a.accumulates = n * v.row_blocks * v.cols;
  a.shifts = static_cast<double>(shifted_entries);
  // Inputs come from the layer's buffer (into the shift register, or straight to the DACs
  // of a sparse layer); outputs are written to the next layer's buffer.
  a.buffer_read_bytes =
      v.scheme == MappingScheme::Dense ? static_cast<double>(shifted_entries) : static_cast<double>(v.rows);
  a.buffer_write_bytes = n * v.cols;
  return a;
}

long long activation_row_bytes(const Shape& s, int activation_bytes) {
  return static_cast<long long>(s.c) * s.w * activation_bytes;
}

long long digital_row_ops(const Op& op, const Shape& out, const Shape& in0) {
  switch (op.kind) {
    case OpKind::Relu:
    case OpKind::Affine:
    case OpKind::Add:
    case OpKind::Sub:
    case OpKind::Mul:
    case OpKind::Div:
    case OpKind::Activation:
      return static_cast<long long>(out.c) * out.w;
    case OpKind::Softmax:  // per value: an exponential, its share of the sum, a division
      return 3LL * out.c * out.w;
    case OpKind::MaxPool:
    case OpKind::AvgPool:
      return static_cast<long long>(out.c) * out.w * op.k_h * op.k_w;
    case OpKind::GlobalAvgPool:
      return static_cast<long long>(in0.size());
    case OpKind::Pad:
    case OpKind::Slice:
    case OpKind::Flatten:
    case OpKind::Concat:
    case OpKind::Shuffle:
    case OpKind::Linear:  // (a tile's work is its crossbars')
      return 0;
  }
  return 0;
}

PlatformActions platform_actions(const Model& m, int activation_bytes) {
  PlatformActions p;
  std::vector<int> consumers(m.values.size(), 0);
  for (const Op& op : m.ops)
    for (int v : op.in) ++consumers[v];
  ++consumers[m.output];  // the logits go to memory
  for (size_t v = 0; v < m.values.size(); ++v)
    p.actions.bus_bytes +=
        static_cast<double>(consumers[v]) * activation_row_bytes(m.values[v], activation_bytes) * m.values[v].h;
  const Shape& out = m.values[m.output];
  p.actions.memory_bytes = static_cast<double>(activation_row_bytes(m.input, activation_bytes)) * m.input.h +
                           static_cast<double>(activation_row_bytes(out, activation_bytes)) * out.h;
  for (const Op& op : m.ops) {
    const long long ops = digital_row_ops(op, m.values[op.out], m.values[op.in[0]]) * m.values[op.out].h;
    p.actions.digital_ops += static_cast<double>(ops);
    if (ops > 0) ++p.digital_units;
  }
  return p;
}

}  // namespace xbarsim
