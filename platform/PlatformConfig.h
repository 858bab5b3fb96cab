#pragma once
/// Settings of the SystemC accelerator model (configuration section `platform.`).
#include <string>

#include "sw/common/config.h"

namespace xbarsim {

struct PlatformConfig {
  double clock_mhz = 100;
  bool detailed = true;          ///< platform.timing
  bool pipelined = false;        ///< platform.schedule
  int replication = 1;
  int adcs_per_crossbar = 0;     ///< 0 = library rule
  int adc_columns_per_unit = 128;
  double adc_rate_gsps = 1.28;
  double dac_latency_ns = 1, crossbar_settle_ns = 5, accumulator_latency_ns = 2;
  int shift_entries_per_cycle = 64;
  int io_words_per_cycle = 16;
  double quantum_ns = 10000;
  int images = 1;
  double clock_ns() const { return 1e3 / clock_mhz; }
};

/// Reads and validates `platform.`; `adc_columns_per_unit` comes from the component library.
PlatformConfig parse_platform_config(const ConfigTree& cfg, int adc_columns_per_unit);

}  // namespace xbarsim
