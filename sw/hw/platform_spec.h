#pragma once
/// Settings of the accelerator's timing (configuration section `platform.`), SystemC-free so
/// that every command prices time the same way; the ADC rate and sharing come from the
/// component library and converters.adc_columns_per_adc (one rule, sw/hw/inventory.h).
#include <string>

#include "sw/common/config.h"

namespace xbarsim {

struct PlatformConfig {
  double clock_mhz = 100;
  bool detailed = true;    ///< platform.timing
  bool pipelined = false;  ///< platform.schedule
  int replication = 1;
  int adc_columns_per_unit = 128;  ///< converters.adc_columns_per_adc resolved with the library
  double adc_rate_gsps = 1.28;     ///< the library's adc.sample_rate_gsps
  double dac_latency_ns = 1, crossbar_settle_ns = 5, accumulator_latency_ns = 2;
  int shift_entries_per_cycle = 64;
  int io_words_per_cycle = 16;
  double quantum_ns = 10000;
  int images = 1;
  double clock_ns() const { return 1e3 / clock_mhz; }
};

/// Reads and validates `platform.`; ADC sharing and rate come from the resolved converter
/// spec and the component library.
PlatformConfig parse_platform_config(const ConfigTree& cfg, int adc_columns_per_unit, double adc_rate_gsps);

}  // namespace xbarsim
