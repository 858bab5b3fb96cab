#include "sw/hw/cost.h"

#include <algorithm>
#include <iterator>

#include "sw/nn/ops.h"

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
constexpr const char* kPartNames[] = {"crossbar",    "adc",         "dac",          "accumulator",
                                      "shift_register", "buffer",    "sample_hold",  "shift_add",
                                      "output_register", "interconnect", "digital",  "memory"};
static_assert(std::size(kPartNames) == std::size(kParts), "a name for every part");

/// The field of the part named `name`, or null when it is not a field (a named component's part).
double ComponentBreakdown::*field_named(const std::string& name) {
  const auto* it = std::find(std::begin(kPartNames), std::end(kPartNames), name);
  return it == std::end(kPartNames) ? nullptr : kParts[it - std::begin(kPartNames)];
}

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
  nlohmann::json j = {{"total", total()}};
  for (size_t k = 0; k < std::size(kParts); ++k) j[kPartNames[k]] = this->*kParts[k];
  for (const auto& [name, v] : parts) j[name] = v;
  return j;
}

ComponentBreakdown ComponentBreakdown::from_json(const nlohmann::json& j) {
  ComponentBreakdown b;
  for (const auto& [key, value] : j.items()) {
    if (key == "total") continue;
    if (const auto field = field_named(key))
      b.*field = value.get<double>();
    else
      b.parts[key] = value.get<double>();
  }
  return b;
}

namespace {
/// Every count of a layer's actions, for the element-wise operations.
constexpr double ActionCounts::*kActions[] = {
    &ActionCounts::dac_conversions,    &ActionCounts::adc_conversions, &ActionCounts::cell_reads,
    &ActionCounts::accumulates,        &ActionCounts::shifts,          &ActionCounts::samples,
    &ActionCounts::shift_adds,         &ActionCounts::buffer_read_bytes, &ActionCounts::buffer_write_bytes,
    &ActionCounts::bus_bytes,          &ActionCounts::digital_ops,     &ActionCounts::memory_bytes,
    &ActionCounts::scale_multiplies};
}  // namespace

ActionCounts& ActionCounts::operator+=(const ActionCounts& o) {
  for (auto f : kActions) this->*f += o.*f;
  return *this;
}

ActionCounts& ActionCounts::operator/=(double n) {
  for (auto f : kActions) this->*f /= n;
  return *this;
}
namespace {

/// A breakdown from price()'s figures by part, each part a ComponentBreakdown field by name.
ComponentBreakdown by_part(const std::map<std::string, double>& parts) {
  ComponentBreakdown b;
  for (const auto& [name, v] : parts) {
    const auto field = field_named(name);
    if (!field) throw std::logic_error("by_part: no part '" + name + "'");
    b.*field = v;
  }
  return b;
}

}  // namespace

std::vector<Instance> CostModel::instances(const LayerInventory* v) const {
  std::vector<Instance> units;
  auto unit = [&](const char* name, const char* component, const char* part, double count, Params p = {}) {
    lib.named.at(component);  // a library without the part: named in the error
    units.push_back({name, component, part, v ? count : 0.0, p});
  };
  const LayerInventory none;
  const LayerInventory& n = v ? *v : none;
  const Params adc{{"bits", static_cast<double>(adc_bits_priced())}}, dac{{"bits", static_cast<double>(dac_bits_priced())}};
  unit("crossbar", "cell", "crossbar", static_cast<double>(n.cells_present));
  unit("adc", "adc", "adc", static_cast<double>(n.adcs), adc);
  unit("dac", "dac", "dac", static_cast<double>(n.dacs), dac);
  if (dac_lut) unit("dac_lut", "dac_lut", "dac", static_cast<double>(n.dacs));
  unit("accumulator", "accumulator", "accumulator", static_cast<double>(n.accumulators));
  unit("shift_register", "shift_register", "shift_register", static_cast<double>(n.shift_register_entries * n.input_bytes));
  unit("buffer", "buffer", "buffer", static_cast<double>(n.buffer_bytes) / kKiB);  // per KiB
  unit("sample_hold", "sample_hold", "sample_hold", static_cast<double>(n.sample_holds));
  unit("shift_add", "shift_add", "shift_add", static_cast<double>(shift_add_units(n)));
  unit("output_register", "output_register", "output_register", static_cast<double>(n.output_register_bytes));
  unit("interconnect", "interconnect", "interconnect", 0);
  unit("digital", "digital", "digital", 0);
  unit("memory", "memory", "memory", 0);
  return units;
}

ComponentBreakdown CostModel::area_mm2(const LayerInventory& v) const {
  return by_part(price(lib.named, instances(&v), Ledger{}, 0.0).area_mm2);
}

ComponentBreakdown CostModel::leakage_mw(const LayerInventory& v) const {
  return by_part(price(lib.named, instances(&v), Ledger{}, 0.0).leakage_mw);
}

ComponentBreakdown CostModel::peak_power_mw(const LayerInventory& v) const {
  return peak_power_mw(v, v.adcs * lib.adc_sample_rate_gsps());
}

ComponentBreakdown CostModel::peak_power_mw(const LayerInventory& v, double conversions_per_ns) const {
  // Actions per ns (GHz) x pJ per action = mW. Every cell and converter of every array is
  // active: the arrays' cells present, not only the used ones (the paper's table). One read
  // per cycle: every DAC reads its input register entry, every column is sampled; every
  // conversion is shifted, added and written to the output register (sliced reads).
  const double clock_ghz = clock_mhz * 1e-3;
  Ledger per_cycle, per_ns;
  per_cycle.add("crossbar", "read", static_cast<double>(v.cells_present));
  per_ns.add("adc", "convert", conversions_per_ns);
  per_cycle.add("dac", "convert", static_cast<double>(v.dacs));
  if (dac_lut) per_cycle.add("dac_lut", "read", static_cast<double>(v.dacs));
  per_cycle.add("accumulator", "accumulate", static_cast<double>(v.accumulators));
  per_cycle.add("shift_register", "read", static_cast<double>(v.dacs));
  per_cycle.add("sample_hold", "sample", static_cast<double>(v.sample_holds));
  if (v.sliced()) {
    per_ns.add("shift_add", "add", conversions_per_ns);
    per_ns.add("output_register", "write", conversions_per_ns);
  }
  const std::vector<Instance> units = instances(&v);
  return by_part(price(lib.named, units, Ledger{}, 0.0).leakage_mw) +
         by_part(price(lib.named, units, per_cycle, 0.0).energy_pj) * clock_ghz +
         by_part(price(lib.named, units, per_ns, 0.0).energy_pj);
}

ComponentBreakdown CostModel::dynamic_energy_pj(const ActionCounts& a) const {
  Ledger l;
  l.add("crossbar", "read", a.cell_reads);
  l.add("adc", "convert", a.adc_conversions);
  l.add("dac", "convert", a.dac_conversions);
  if (dac_lut) l.add("dac_lut", "read", a.dac_conversions);  // every conversion looks its table up
  l.add("accumulator", "accumulate", a.accumulates);
  l.add("shift_register", "shift", a.shifts);
  l.add("shift_register", "read", a.dac_conversions);  // every DAC conversion reads its entry
  l.add("sample_hold", "sample", a.samples);
  l.add("shift_add", "add", a.shift_adds);
  l.add("output_register", "write", a.shift_adds);  // each shift-and-add result is written
  l.add("buffer", "read", a.buffer_read_bytes);
  l.add("buffer", "write", a.buffer_write_bytes);
  l.add("interconnect", "transfer", a.bus_bytes);
  l.add("digital", "op", a.digital_ops + a.scale_multiplies);
  l.add("memory", "transfer", a.memory_bytes);
  return by_part(price(lib.named, instances(nullptr), l, 0.0).energy_pj);  // (the actions' performers)
}

Bill CostModel::platform_bill(int digital_units) const {
  return price(lib.named,
               {{"interconnect", "interconnect", "interconnect", 1, {}},
                {"digital", "digital", "digital", static_cast<double>(digital_units), {}}},
               Ledger{}, 0.0);
}

ComponentBreakdown CostModel::platform_area_mm2(int digital_units) const {
  return by_part(platform_bill(digital_units).area_mm2);
}

ComponentBreakdown CostModel::platform_leakage_mw(int digital_units) const {
  return by_part(platform_bill(digital_units).leakage_mw);
}

long long CostModel::shift_add_units(const LayerInventory& v) const {
  if (!v.sliced()) return 0;
  const long long per = lib.shift_add_adcs_per_unit();
  return (v.adcs + per - 1) / per;
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
  a.scale_multiplies = v.column_scales ? a.accumulates : 0.0;  // each crossbar output by its column's gain
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
  return op_info(op.kind).row_ops(op, out, in0);
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
