#pragma once
/// The hardware a configuration describes, parsed once and shared by every command: the
/// component library, the machine (or layer-sized), the platform, the mapping and converters
/// it is priced for, and (neuron cores) its reads at the configured precision.
#include "sw/analog/analog_layer.h"
#include "sw/hw/architecture.h"
#include "sw/hw/core_kind.h"
#include "sw/hw/cost.h"
#include "sw/hw/inventory.h"
#include "sw/hw/platform_spec.h"

namespace xbarsim {

struct HardwareContext {
  MappingSpec mapping;
  ConvertersSpec converters;
  ComponentLibrary lib;
  PlatformConfig platform;
  Architecture arch;          ///< architecture.machine (layer-sized: arch.machine is false)
  int columns_per_adc = 128;  ///< converters.adc_columns_per_adc resolved with the library or the machine
  bool column_scales = false;  ///< ranging.weight_scale: column (a digital multiply per crossbar output)
  CostModel cost;
  /// Neuron cores (their CoreKind::configure): the steps of one read at the configured precision and
  /// the solved energy (pJ) of one magnitude bit's input pulses on a whole core.
  ReadSteps read_steps;
  /// Neuron cores: the steps of one read of a layer that reads the image (converters.image_bits;
  /// read_steps without it).
  ReadSteps image_read_steps;
  double core_pulse_pj_per_bit = 0;
  /// The inventory of layer L under `scheme`, its inputs streamed as the converters say
  /// (`signed_inputs`: linear_inputs_signed, or the programmed layer's; `reads_image`:
  /// linear_reads_image, the layer's converters ConvertersSpec::for_layer).
  LayerInventory inventory(const LinearLayer& L, MappingScheme scheme, bool signed_inputs, bool reads_image) const;
  /// The steps of one neuron read of a layer (neuron cores).
  const ReadSteps& steps_of(const LayerInventory& v) const { return v.reads_image ? image_read_steps : read_steps; }
};

/// Reads components.library, architecture.machine and platform.*; mapping and converters
/// come from `ac` (and must fit the machine: check_crossbar_geometry, the ADC sharing).
HardwareContext make_hardware_context(const ConfigTree& cfg, const AnalogConfig& ac);

}  // namespace xbarsim
