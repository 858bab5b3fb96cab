#include "sw/hw/platform_spec.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "sw/common/parse.h"
#include "sw/hw/architecture.h"
#include "sw/hw/inventory.h"

namespace xbarsim {

PlatformConfig parse_platform_config(const ConfigTree& cfg, int adc_columns_per_unit, double adc_rate_gsps) {
  PlatformConfig c;
  c.clock_mhz = cfg.get_double("platform.clock_mhz");
  c.detailed = require_one_of(cfg, "platform.timing", {"ideal", "detailed"}) == "detailed";
  c.pipelined = require_one_of(cfg, "platform.schedule", {"sequential", "pipelined"}) == "pipelined";
  c.timing_only = cfg.get_bool("platform.timing_only");
  c.quantum_ns = cfg.get_double("platform.quantum_ns");
  if (!(c.quantum_ns > 0) || c.quantum_ns > 1e9)
    throw InputError("platform.quantum_ns = " + cfg.get_string("platform.quantum_ns") +
                     ": must be in (0, 1e9] ns (a quantum at or below the clock period waits every delay)");
  if (cfg.get_string("platform.replication") == "auto")
    c.auto_replication = true;
  else
    c.replication = cfg.get_int32("platform.replication");
  const std::string per_layer = cfg.get_string("platform.replication_per_layer");
  if (!per_layer.empty()) {
    std::stringstream ss(per_layer);
    std::string item;
    while (std::getline(ss, item, ',')) {
      long long r = 0;
      if (!parse_int64(item, r) || r < 1 || r > 4096)
        throw InputError("configuration key 'platform.replication_per_layer': '" + item +
                         "' is not a replication in [1, 4096]");
      c.replication_per_layer.push_back(static_cast<int>(r));
    }
  }
  c.crossbar_budget = cfg.get_int("platform.crossbar_budget");
  c.adc_columns_per_unit = adc_columns_per_unit;
  c.adc_rate_gsps = adc_rate_gsps;
  c.dac_latency_ns = cfg.get_double("platform.dac_latency_ns");
  c.crossbar_settle_ns = cfg.get_double("platform.crossbar_settle_ns");
  c.accumulator_latency_ns = cfg.get_double("platform.accumulator_latency_ns");
  c.shift_entries_per_cycle = cfg.get_int32("platform.shift_entries_per_cycle");
  c.link_bytes_per_cycle = cfg.get_int32("platform.link_bytes_per_cycle");
  c.hop_cycles = cfg.get_int32("platform.hop_cycles");
  c.bus_lanes = cfg.get_int32("platform.bus_lanes");
  c.buffer_bytes = cfg.get_string("platform.buffer_bytes") == "auto" ? 0 : cfg.get_int("platform.buffer_bytes");
  c.memory_bytes_per_cycle = cfg.get_int32("platform.memory_bytes_per_cycle");
  c.memory_latency_ns = cfg.get_double("platform.memory_latency_ns");
  c.digital_ops_per_cycle = cfg.get_int32("platform.digital_ops_per_cycle");
  c.activation_bytes = cfg.get_int32("platform.activation_bytes");
  c.images = cfg.get_int32("platform.images");
  c.vcd_images = cfg.get_int32("platform.vcd_images");
  c.check_protocol = cfg.get_bool("platform.check_protocol");
  c.grain_rows = cfg.get_int32("platform.grain_rows");
  c.fifo_depth = cfg.get_int32("platform.fifo_depth");
  return c;
}

}  // namespace xbarsim

namespace xbarsim {

SparseIterationNs sparse_iteration_ns(const LayerInventory& v, const PlatformConfig& cfg) {
  const double clk = cfg.clock_ns();
  const int cycles = v.input_slices * cfg.read_cycles(v.reads_image);
  SparseIterationNs t;
  if (!cfg.detailed) {  // a read per cycle
    t.crossbar = clk * cycles;
    return t;
  }
  const long long rows = std::min(v.rows, v.array_rows);
  const long long cols = std::min(v.physical_cols, v.array_cols);
  const long long adcs = adcs_for_columns(cols, cfg.adc_columns_per_unit);
  t.shift = std::ceil(static_cast<double>(rows) / cfg.shift_entries_per_cycle) * clk;
  t.dac = cfg.dac_latency_ns * cycles;
  t.crossbar = cfg.crossbar_settle_ns * cycles;
  t.adc = std::ceil(static_cast<double>(cols) / std::max<long long>(adcs, 1)) / cfg.adc_rate_gsps * cycles;
  t.accumulate = cfg.accumulator_latency_ns;
  return t;
}

double sparse_estimated_ns(const SparseIterationNs& t, const PlatformConfig& cfg) {
  const double clk = cfg.clock_ns();
  double busiest = 0;
  for (double ns : {t.shift, t.dac, t.crossbar, t.adc, t.accumulate})
    busiest = std::max(busiest, std::ceil(ns / clk - 1e-9) * clk);
  return busiest;
}

PlatformConfig machine_platform(PlatformConfig pc, const Architecture& arch) {
  if (!arch.machine) return pc;
  pc.clock_mhz = 1e3 / arch.ima.read_ns;     // the tiles' datapath clock: one read per cycle
  pc.crossbar_settle_ns = arch.ima.read_ns;  // a read occupies the crossbars for a cycle
  const int per_adc = arch.columns_per_adc(), cols = std::max(1, arch.crossbar.cols);
  pc.adc_columns_per_unit = std::max(1, std::min(per_adc, cols));
  pc.crossbars_per_adc = std::max(1, per_adc / cols);
  return pc;
}

double adc_read_ns(long long columns, int columns_per_adc, int crossbars_per_adc, double rate_gsps) {
  if (columns <= 0) return 0;
  if (crossbars_per_adc > 1) return static_cast<double>(columns) * crossbars_per_adc / rate_gsps;
  const long long adcs = std::max<long long>(1, adcs_for_columns(columns, columns_per_adc));
  return std::ceil(static_cast<double>(columns) / adcs) / rate_gsps;
}

}  // namespace xbarsim
