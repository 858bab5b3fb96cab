#pragma once
/// Component library (YAML, configs/components/), in the style of Accelergy: every
/// component by name with its area, leakage power and energy per action, each figure possibly
/// scaled by the instance's parameters (a converter's bits). One form for every library
/// (sw/hw/components.h), ISAAC's and NeuRRAM's alike; everything is priced by price().
#include <string>

#include "sw/common/config.h"
#include "sw/hw/components.h"

namespace xbarsim {

struct ComponentLibrary {
  std::string source;  ///< file it was read from
  NamedLibrary named;  ///< every component by name
  /// A parameter default of a component, or `fallback` when the library has no such
  /// component (a neuron core's library has no crossbar-core ADC).
  double param(const std::string& component, const std::string& key, double fallback) const;
  /// The ADC's sharing (crossbar columns per ADC, the default of converters.adc_columns_per_adc)
  /// and its conversions per ns (timing and peak power): adc.params.
  int adc_columns_per_unit() const { return static_cast<int>(param("adc", "columns_per_unit", 128)); }
  double adc_sample_rate_gsps() const { return param("adc", "sample_rate_gsps", 1.28); }
  /// The resolution a converter's figures are given at (its params' bits): what an ideal
  /// converter (bits 0) is priced at.
  int reference_bits(const std::string& converter) const { return static_cast<int>(param(converter, "bits", 8)); }
  /// ADCs whose results one shift-and-add unit combines (shift_add.params.adcs_per_unit).
  int shift_add_adcs_per_unit() const { return static_cast<int>(param("shift_add", "adcs_per_unit", 1)); }
};

/// The parts a machine of crossbar cores prices by these names (the inventory's units and the
/// platform's): a library for such a machine must have each (and dac_lut when the DACs have
/// pre-distortion tables).
extern const char* const kCrossbarCoreComponents[12];

/// Parses a component library from YAML text; errors name `origin`, the component, the key and
/// the bad value (unknown keys, missing figures, negative numbers, duplicate keys, a library in
/// the fixed form of earlier versions).
ComponentLibrary parse_component_library(const std::string& yaml_text, const std::string& origin);

/// The library named by `components.library`: a YAML file, or a built-in by name (isaac_paper,
/// the default, isaac or neurram: configs/components/<name>.yaml compiled in).
ComponentLibrary load_component_library(const ConfigTree& cfg);

}  // namespace xbarsim
