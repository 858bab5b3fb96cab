#include "sw/hw/hardware_context.h"

namespace xbarsim {

HardwareContext make_hardware_context(const ConfigTree& cfg, const AnalogConfig& ac) {
  HardwareContext hw;
  hw.mapping = ac.mapping;
  hw.converters = ac.converters;
  hw.column_scales = ac.ranging.weight_scale == WeightScale::Column;
  hw.lib = load_component_library(cfg);
  hw.arch = load_architecture(cfg);
  check_crossbar_geometry(hw.arch, ac.mapping);
  hw.columns_per_adc = resolve_columns_per_adc(ac.converters.adc_columns_per_adc, hw.lib.adc_columns_per_unit());
  if (hw.arch.machine) {
    const int shared = hw.arch.columns_per_adc();
    if (ac.converters.adc_columns_per_adc != 0 && ac.converters.adc_columns_per_adc != shared)
      throw InputError("converters.adc_columns_per_adc = " + std::to_string(ac.converters.adc_columns_per_adc) +
                       ", but architecture.machine " + hw.arch.name + " shares each ADC among " +
                       std::to_string(shared) + " columns (its IMA's); set 0 or " + std::to_string(shared));
    hw.columns_per_adc = shared;
  }
  hw.platform = parse_platform_config(cfg, hw.columns_per_adc, hw.lib.adc_sample_rate_gsps());
  hw.cost.lib = hw.lib;
  hw.cost.dac_bits = ac.converters.dac_bits;
  hw.cost.dac_lut = ac.dac_predistorts();
  hw.cost.adc_bits = ac.converters.adc_bits;
  hw.cost.clock_mhz = hw.platform.clock_mhz;
  hw.arch.core().configure(hw, ac);
  return hw;
}

LayerInventory HardwareContext::inventory(const LinearLayer& L, MappingScheme scheme, bool signed_inputs,
                                          bool reads_image) const {
  LayerInventory v = layer_inventory(L, scheme, mapping, columns_per_adc);
  v.column_scales = column_scales;
  stream_inputs(v, converters.for_layer(reads_image), signed_inputs);
  v.reads_image = reads_image && converters.image_bits != 0;
  return v;
}

}  // namespace xbarsim
