#include "sw/hw/platform_spec.h"

namespace xbarsim {

PlatformConfig parse_platform_config(const ConfigTree& cfg, int adc_columns_per_unit, double adc_rate_gsps) {
  PlatformConfig c;
  c.clock_mhz = require_positive(cfg, "platform.clock_mhz");
  c.detailed = require_one_of(cfg, "platform.timing", {"ideal", "detailed"}) == "detailed";
  c.pipelined = require_one_of(cfg, "platform.schedule", {"sequential", "pipelined"}) == "pipelined";
  c.replication = cfg.get_int32("platform.replication");
  c.adc_columns_per_unit = adc_columns_per_unit;
  c.adc_rate_gsps = adc_rate_gsps;
  c.dac_latency_ns = require_nonnegative(cfg, "platform.dac_latency_ns");
  c.crossbar_settle_ns = require_nonnegative(cfg, "platform.crossbar_settle_ns");
  c.accumulator_latency_ns = require_nonnegative(cfg, "platform.accumulator_latency_ns");
  c.shift_entries_per_cycle = cfg.get_int32("platform.shift_entries_per_cycle");
  c.io_words_per_cycle = cfg.get_int32("platform.io_words_per_cycle");
  c.quantum_ns = require_positive(cfg, "platform.quantum_ns");
  c.images = cfg.get_int32("platform.images");
  return c;
}

}  // namespace xbarsim
