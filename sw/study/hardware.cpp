#include "sw/study/hardware.h"

namespace xbarsim {

HardwareContext make_hardware_context(const ConfigTree& cfg, const AnalogConfig& ac) {
  HardwareContext hw;
  hw.mapping = ac.mapping;
  hw.converters = ac.converters;
  hw.lib = load_component_library(cfg);
  hw.columns_per_adc = resolve_columns_per_adc(ac.converters.adc_columns_per_adc, hw.lib.adc_columns_per_unit);
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

}  // namespace xbarsim
