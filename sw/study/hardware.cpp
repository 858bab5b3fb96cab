#include "sw/study/hardware.h"

#include "sw/analog/input_slicing.h"
#include "sw/nn/network.h"

namespace xbarsim {

HardwareContext make_hardware_context(const ConfigTree& cfg, const AnalogConfig& ac) {
  HardwareContext hw;
  hw.mapping = ac.mapping;
  hw.converters = ac.converters;
  hw.lib = load_component_library(cfg);
  hw.arch = load_architecture(cfg);
  check_crossbar_geometry(hw.arch, ac.mapping);
  hw.columns_per_adc = resolve_columns_per_adc(ac.converters.adc_columns_per_adc, hw.lib.adc_columns_per_unit);
  if (hw.arch.machine) {
    const int shared = hw.arch.columns_per_adc();
    if (ac.converters.adc_columns_per_adc != 0 && ac.converters.adc_columns_per_adc != shared)
      throw InputError("converters.adc_columns_per_adc = " + std::to_string(ac.converters.adc_columns_per_adc) +
                       ", but architecture.machine " + hw.arch.name + " shares each ADC among " +
                       std::to_string(shared) + " columns (its IMA's); set 0 or " + std::to_string(shared));
    hw.columns_per_adc = shared;
  }
  if (hw.arch.neuron_cores()) {  // one read's time follows from the precision
    const int in = ac.converters.activation_bits(), out = ac.converters.adc_bits;
    if (in < 1 || out < 1)
      throw InputError("architecture.machine " + hw.arch.name +
                       " reads with neurons whose steps follow the precision: set converters.input_bits (or "
                       "dac_bits) and converters.adc_bits (the output bits), not none");
    hw.arch.ima.read_ns = hw.arch.read_steps(in, out).time_ns;
  }
  hw.platform = parse_platform_config(cfg, hw.columns_per_adc, hw.lib.adc_sample_rate_gsps);
  hw.cost.lib = hw.lib;
  hw.cost.dac_bits = ac.converters.dac_bits;
  hw.cost.dac_lut = ac.dac_predistorts();
  hw.cost.adc_bits = ac.converters.adc_bits;
  hw.cost.clock_mhz = hw.platform.clock_mhz;
  return hw;
}

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
          {"avg_power_mw", avg_power_mw()},
          {"time_ns_per_image", time_ns}};
}

void add_layer_cost(CostReport& r, const HardwareContext& hw, const LayerInventory& v, const ActionCounts& a) {
  r.area_mm2 += hw.cost.area_mm2(v);
  r.peak_power_mw += hw.cost.peak_power_mw(v);
  r.leakage_mw += hw.cost.leakage_mw(v);
  r.dynamic_energy_uj += hw.cost.dynamic_energy_pj(a) * 1e-6;
  r.crossbars += v.crossbars;
  r.adcs += v.adcs;
  r.dacs += v.dacs;
}

void price_whole_machine(CostReport& r, const HardwareContext& hw) {
  if (!hw.arch.machine) return;
  const MachineBill bill = price_machine(hw.arch, hw.cost, hw.converters, hw.mapping);
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
  ComponentBreakdown pj;
  pj.interconnect = a.edram_read_bytes * hw.lib.unit(arch.tile.bus.unit).action_pj +
                    a.router_bytes * hw.lib.unit(arch.chip.router.unit).action_pj;
  pj.memory = a.memory_bytes * hw.lib.unit(arch.chip.offchip.unit).action_pj;
  for (const auto& [name, ops] : a.digital_ops) pj.digital += ops * digital_op_pj(arch, hw.lib, name);
  r.dynamic_energy_uj += pj * 1e-6;
}

MachineReport machine_report(const Model& m, const HardwareContext& hw, const std::vector<bool>& signed_inputs) {
  const Architecture& a = hw.arch;
  if (a.neuron_cores())
    throw InputError("architecture.machine " + a.name +
                     ": networks are not placed on neuron cores yet; its peak figures: xbarsim simulate without "
                     "--model; a network's accuracy at its precisions: --set architecture.machine=layer-sized");
  MachineReport r;
  r.name = a.name;
  r.tiles = a.chip.tiles;
  r.imas_per_tile = a.tile.imas;
  r.crossbars_per_ima = a.ima.crossbars;
  r.bill = price_machine(a, hw.cost, hw.converters, hw.mapping);
  std::vector<LayerInventory> layers;
  for (size_t l = 0; l < m.linear.size(); ++l)
    layers.push_back(hw.inventory(m.linear[l], MappingScheme::Dense, signed_inputs.at(l)));
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
