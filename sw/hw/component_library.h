#pragma once
/// Power/area component library (YAML, configs/components/) and the scaling rules that
/// derive other resolutions. Energy = power x active time.
#include <string>

#include "sw/common/config.h"

namespace xbarsim {

enum class Scaling { Exponential, Linear, Constant };

/// One converter type: figures at `reference_bits`, scaled to `bits`.
struct ConverterSpec {
  double power_mw = 0, area_mm2 = 0;
  int reference_bits = 8;
  Scaling power_scaling = Scaling::Exponential, area_scaling = Scaling::Exponential;
  double power_at(int bits) const;
  double area_at(int bits) const;
};

struct ComponentLibrary {
  std::string source;  ///< file it was read from
  ConverterSpec adc, dac;
  int adc_columns_per_unit = 128;
  double adc_sample_rate_gsps = 1.28;
  double cell_power_mw = 0, cell_area_mm2 = 0;
  double accumulator_power_mw = 0, accumulator_area_mm2 = 0;
};

/// Scales `value` from `ref` to `bits` by the rule.
double scale_by_bits(double value, int ref, int bits, Scaling rule);

/// Parses a component library from YAML text; errors name `origin` and the key.
ComponentLibrary parse_component_library(const std::string& yaml_text, const std::string& origin);

/// The library named by `components.library` ("" = built-in configs/components/isaac_paper.yaml).
ComponentLibrary load_component_library(const ConfigTree& cfg);

/// Energy in microjoules of `power_mw` active for `time_us`.
inline double energy_uj(double power_mw, double time_us) { return power_mw * time_us * 1e-3; }

}  // namespace xbarsim
