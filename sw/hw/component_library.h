#pragma once
/// Power/area component library (YAML, configs/components/) and the scaling rules that
/// derive other resolutions. Energy = power x active time.
#include <string>

#include "sw/common/config.h"

namespace xbarsim {

/// How a converter figure changes with resolution (YAML `power_scaling` / `area_scaling`).
enum class Scaling {
  Exponential,  ///< value * 2^(bits - reference_bits) (the paper: 1-bit DAC to 8 bits = x256)
  Linear,       ///< value * bits / reference_bits
  Constant      ///< value
};

/// One converter type (YAML sections `adc`, `dac`): figures at `reference_bits`, scaled to `bits`.
struct ConverterSpec {
  double power_mw = 0;  ///< power of one unit at reference_bits, mW
  double area_mm2 = 0;  ///< area of one unit at reference_bits, mm^2
  int reference_bits = 8;
  Scaling power_scaling = Scaling::Exponential, area_scaling = Scaling::Exponential;
  double power_at(int bits) const;  ///< mW of one unit at `bits`
  double area_at(int bits) const;   ///< mm^2 of one unit at `bits`
};

/// Per-unit power/area figures (one YAML file, parsed once and validated).
struct ComponentLibrary {
  std::string source;  ///< file it was read from
  ConverterSpec adc, dac;
  int adc_columns_per_unit = 128;      ///< crossbar columns sharing one ADC (YAML adc.columns_per_unit)
  double adc_sample_rate_gsps = 1.28;  ///< as recorded with the source (timing: platform.adc_rate_gsps)
  double cell_power_mw = 0;            ///< one crossbar cell, mW (crossbar power = cells present x this)
  double cell_area_mm2 = 0;            ///< one crossbar cell, mm^2
  double accumulator_power_mw = 0;     ///< digital shift-and-add per crossbar, mW
  double accumulator_area_mm2 = 0;     ///< digital shift-and-add per crossbar, mm^2
};

/// Scales `value` from `ref` to `bits` by the rule.
double scale_by_bits(double value, int ref, int bits, Scaling rule);

/// Parses a component library from YAML text; errors name `origin`, the key and the bad
/// value (unknown sections or keys, missing figures, non-positive numbers, fractional bits).
ComponentLibrary parse_component_library(const std::string& yaml_text, const std::string& origin);

/// The library named by `components.library` ("" = built-in configs/components/isaac_paper.yaml),
/// with `components.adc_columns_per_adc` (> 0) overriding `adc.columns_per_unit`. Every
/// command that reports power/area (overhead, simulate) loads it here, so they agree.
ComponentLibrary load_component_library(const ConfigTree& cfg);

/// Energy in microjoules of `power_mw` active for `time_us` (mW x us = nJ = 1e-3 uJ). The
/// active time comes from the timing model (xbarsim simulate: per-layer latency).
inline double energy_uj(double power_mw, double time_us) { return power_mw * time_us * 1e-3; }

}  // namespace xbarsim
