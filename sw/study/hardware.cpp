#include "sw/study/hardware.h"

#include <algorithm>
#include <cmath>

#include "sw/analog/input_slicing.h"
#include "sw/nn/network.h"

namespace xbarsim {

nlohmann::json CostReport::to_json() const {
  return {{"crossbars", crossbars},
          {"adcs", adcs},
          {"dacs", dacs},
          {"area_mm2", area_mm2.total()},
          {"area_breakdown_mm2", area_mm2.to_json()},
          {"peak_power_mw", peak_power_mw.total()},
          {"peak_power_breakdown_mw", peak_power_mw.to_json()},
          {"energy_uj_per_image", energy_uj().total()},
          {"energy_breakdown_uj", energy_uj().to_json()},
          // The actions' energy alone, without the leakage over the command's time per image
          // (eval's sequential estimate, simulate's simulated schedule).
          {"dynamic_energy_uj_per_image", dynamic_energy_uj.total()},
          {"dynamic_energy_breakdown_uj", dynamic_energy_uj.to_json()},
          {"leakage_mw", leakage_mw.total()},
          {"leakage_breakdown_mw", leakage_mw.to_json()},
          {"avg_power_mw", avg_power_mw()},
          {"time_ns_per_image", time_ns}};
}

CostReport CostReport::from_json(const nlohmann::json& j) {
  CostReport r;
  r.crossbars = j.at("crossbars").get<long long>();
  r.adcs = j.at("adcs").get<long long>();
  r.dacs = j.at("dacs").get<long long>();
  r.area_mm2 = ComponentBreakdown::from_json(j.at("area_breakdown_mm2"));
  r.peak_power_mw = ComponentBreakdown::from_json(j.at("peak_power_breakdown_mw"));
  r.dynamic_energy_uj = ComponentBreakdown::from_json(j.at("dynamic_energy_breakdown_uj"));
  r.leakage_mw = ComponentBreakdown::from_json(j.at("leakage_breakdown_mw"));
  r.time_ns = j.at("time_ns_per_image").get<double>();
  return r;
}

void add_layer_cost(CostReport& r, const HardwareContext& hw, const LayerInventory& v, const ActionCounts& a) {
  const CoreKind& core = hw.arch.core();
  r.area_mm2 += core.layer_area_mm2(hw, v);
  r.peak_power_mw += core.layer_peak_power_mw(hw, v);
  r.leakage_mw += core.layer_leakage_mw(hw, v);
  r.dynamic_energy_uj += core.layer_energy_pj(hw, v, a) * 1e-6;
  r.crossbars += v.crossbars;
  r.adcs += v.adcs;
  r.dacs += v.dacs;
}

void price_whole_machine(CostReport& r, const HardwareContext& hw) {
  if (!hw.arch.machine) return;
  const MachineBill bill = hw.arch.core().machine_bill(hw);
  r.area_mm2 = bill.chip_area_mm2;
  r.peak_power_mw = bill.chip_peak_mw;
  r.leakage_mw = bill.chip_leakage_mw;
}

void add_platform_cost(CostReport& r, const HardwareContext& hw, const PlatformActions& p) {
  if (hw.arch.machine) return;
  r.dynamic_energy_uj += hw.cost.dynamic_energy_pj(p.actions) * 1e-6;
  r.area_mm2 += hw.cost.platform_area_mm2(p.digital_units);
  r.leakage_mw += hw.cost.platform_leakage_mw(p.digital_units);
}

MachineActions machine_actions(const Model& m, const HardwareContext& hw, const Mapping& mp, double edram_read_bytes) {
  MachineActions a;
  a.edram_read_bytes = edram_read_bytes;
  const Architecture& arch = hw.arch;
  const MeshGeometry mesh{arch.chip.mesh_rows, arch.chip.mesh_cols, arch.chip.tiles_per_router};
  if (mp.fits)  // (a network that does not fit has no placement to route between)
    a.router_bytes = machine_traffic(m, place_operations(m, mp), mesh, hw.platform.activation_bytes).router_bytes;
  const PlatformActions p = platform_actions(m, hw.platform.activation_bytes);
  a.memory_bytes = p.actions.memory_bytes;
  for (const Op& op : m.ops) {
    const long long ops = digital_row_ops(op, m.values[op.out], m.values[op.in[0]]) * m.values[op.out].h;
    if (ops > 0) a.digital_ops.push_back({digital_op_name(op.kind), static_cast<double>(ops)});
  }
  return a;
}

void add_machine_cost(CostReport& r, const HardwareContext& hw, const MachineActions& a) {
  if (!hw.arch.machine) return;
  price_whole_machine(r, hw);
  const Architecture& arch = hw.arch;
  // Each unit by name, its actions priced by price(); a machine without one (cores without a
  // mesh, bus or buffer) moves those bytes nowhere on chip.
  std::vector<Instance> units;
  Ledger actions;
  auto act = [&](const std::string& role, const std::string& unit, const char* part, double n) {
    if (unit.empty()) return;
    units.push_back({role, unit, part, 0, {}});
    actions.add(role, "action", n);
  };
  act("tile_bus", arch.tile.bus.unit, "interconnect", a.edram_read_bytes);
  act("router", arch.chip.router.unit, "interconnect", a.router_bytes);
  act("offchip", arch.chip.offchip.unit, "memory", a.memory_bytes);
  for (const UnitUse& u : arch.tile.units) units.push_back({"unit " + u.unit, u.unit, "digital", 0, {}});
  for (const auto& [op, ops] : a.digital_ops)  // by the first unit that performs it (none: nothing)
    for (const UnitUse& u : arch.tile.units)
      if (std::find(u.ops.begin(), u.ops.end(), op) != u.ops.end()) {
        actions.add("unit " + u.unit, "action", ops);
        break;
      }
  const Bill b = price(hw.lib.named, units, actions, 0.0);
  ComponentBreakdown e;
  for (auto [part, field] : {std::pair{"interconnect", &ComponentBreakdown::interconnect},
                             {"memory", &ComponentBreakdown::memory}, {"digital", &ComponentBreakdown::digital}}) {
    const auto it = b.energy_pj.find(part);
    if (it != b.energy_pj.end()) e.*field = it->second;
  }
  r.dynamic_energy_uj += e * 1e-6;
}

MachineReport machine_report(const Model& m, const HardwareContext& hw, const std::vector<bool>& signed_inputs) {
  const std::vector<bool> reads_image = linear_reads_image(m);
  const Architecture& a = hw.arch;
  MachineReport r;
  r.name = a.name;
  r.tiles = a.chip.tiles;
  r.imas_per_tile = a.tile.imas;
  r.crossbars_per_ima = a.ima.crossbars;
  r.bill = a.core().machine_bill(hw);
  std::vector<LayerInventory> layers;
  for (size_t l = 0; l < m.linear.size(); ++l)
    layers.push_back(hw.inventory(m.linear[l], MappingScheme::Dense, signed_inputs.at(l), reads_image.at(l)));
  r.mapping = map_network(layers, a, hw.platform, &m, &hw.mapping);
  const int slices = make_input_slicing(hw.converters.activation_bits(), hw.converters.dac_bits, false, 1.0).slices;
  const double weights = static_cast<double>(a.crossbar.rows) * (a.crossbar.cols / hw.mapping.columns_per_weight());
  r.peak_gops = 2.0 * weights / (slices * a.ima.read_ns) * static_cast<double>(a.crossbars());
  return r;
}

void require_fit(const Mapping& mapping, const Architecture& arch) {
  if (!mapping.fits)
    throw InputError("the network does not fit architecture.machine " + arch.name + ": " + mapping.reason);
}

void require_fit(const Model& m, const HardwareContext& hw) {
  if (hw.arch.machine) require_fit(machine_report(m, hw, linear_inputs_signed(m)).mapping, hw.arch);
}

nlohmann::json MachineReport::to_json() const {
  auto lines = [](const std::vector<BillLine>& v) {
    nlohmann::json j = nlohmann::json::array();
    for (const BillLine& l : v)
      j.push_back({{"unit", l.unit}, {"count", l.count}, {"area_mm2", l.area_mm2}, {"peak_power_mw", l.peak_mw}});
    return j;
  };
  const double area = area_mm2(), power = peak_power_mw();
  return {{"name", name},
          {"tiles", tiles},
          {"imas_per_tile", imas_per_tile},
          {"crossbars_per_ima", crossbars_per_ima},
          {"area_mm2", area},
          {"peak_power_mw", power},
          {"ima",
           {{"area_mm2", MachineBill::area(bill.ima)},
            {"peak_power_mw", MachineBill::peak_mw(bill.ima)},
            {"units", lines(bill.ima)}}},
          {"tile",
           {{"area_mm2", MachineBill::area(bill.tile)},
            {"peak_power_mw", MachineBill::peak_mw(bill.tile)},
            {"units", lines(bill.tile)}}},
          {"chip", {{"units", lines(bill.chip)}}},
          {"peak_gops", peak_gops},
          {"peak_gops_per_mm2", area > 0 ? peak_gops / area : 0.0},
          {"peak_gops_per_w", power > 0 ? peak_gops / (power * 1e-3) : 0.0},
          {"mapping", mapping.to_json()}};
}

}  // namespace xbarsim
