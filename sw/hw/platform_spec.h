#pragma once
/// Settings of the accelerator's timing (configuration section `platform.`), SystemC-free so
/// that every command prices time the same way; the ADC rate and sharing come from the
/// component library and converters.adc_columns_per_adc (one rule, sw/hw/inventory.h).
#include <string>
#include <vector>

#include "sw/common/config.h"

namespace xbarsim {

struct PlatformConfig {
  double clock_mhz = 100;
  bool detailed = true;                    ///< platform.timing
  bool pipelined = false;                  ///< platform.schedule
  bool timing_only = false;                ///< platform.timing_only: no values computed
  double quantum_ns = 100;                 ///< platform.quantum_ns: temporal decoupling's quantum (> 0)
  int replication = 1;                     ///< every layer (platform.replication), unless per_layer/auto
  std::vector<int> replication_per_layer;  ///< platform.replication_per_layer (empty = replication)
  bool auto_replication = false;           ///< platform.replication = auto: balance under crossbar_budget
  long long crossbar_budget = 0;           ///< crossbars the auto replication may use (0 = 2x the unreplicated)
  int adc_columns_per_unit = 128;          ///< converters.adc_columns_per_adc resolved with the library
  /// Crossbars whose columns one ADC converts in turn (a machine's IMA shares its ADCs among
  /// more columns than one crossbar has): an ADC's conversions per read are this many
  /// crossbars' columns.
  int crossbars_per_adc = 1;
  double adc_rate_gsps = 1.28;  ///< the library's adc.sample_rate_gsps
  double dac_latency_ns = 1, crossbar_settle_ns = 5, accumulator_latency_ns = 2;
  int shift_entries_per_cycle = 64;
  /// Neuron cores with converters.image_bits: the datapath cycles (reads at the activations'
  /// precision) one read of a layer that reads the image takes, its steps' time rounded up.
  int image_read_cycles = 1;
  /// Datapath cycles one read of a layer takes (`reads_image`: it reads the network's input).
  int read_cycles(bool reads_image) const { return reads_image ? image_read_cycles : 1; }
  int link_bytes_per_cycle = 32;    ///< interconnect link width
  int hop_cycles = 1;               ///< interconnect latency per transfer
  int bus_lanes = 1;                ///< parallel links of the interconnect
  long long buffer_bytes = 0;       ///< every stage input buffer; 0 = sized automatically
  int memory_bytes_per_cycle = 16;  ///< off-chip input/output bandwidth
  double memory_latency_ns = 100;   ///< off-chip access latency per image transfer
  int digital_ops_per_cycle = 64;   ///< ReLU/Add/pooling unit throughput
  int activation_bytes = 1;         ///< bytes per activation value on the interconnect and in buffers
  int images = 1;
  int grain_rows = 1;  ///< output rows per transaction of a stage
  int fifo_depth = 2;  ///< platform.fifo_depth: row groups a tile unit's input FIFO holds
  int vcd_images = 1;  ///< images traced into the VCD
  bool check_protocol = false;  ///< platform.check_protocol: a base-protocol checker before every target
  /// Worker threads computing the values beside the simulation (solver.threads, resolved):
  /// the wall time only, never the figures.
  int threads = 1;
  double clock_ns() const { return 1e3 / clock_mhz; }
};

struct LayerInventory;
struct Architecture;

/// The timing a machine's tiles run with (architecture.machine): the datapath clocked once per
/// ima.read_ns, a read occupying the crossbars for that cycle, and the IMA's ADC sharing
/// (Architecture::columns_per_adc): fewer columns per ADC than a crossbar has give each
/// crossbar its own ADCs (adc_columns_per_unit), more make an ADC convert the columns of
/// crossbars_per_adc crossbars per read. The simulation runs with it and the mapper plans with
/// it (one rule).
PlatformConfig machine_platform(PlatformConfig pc, const Architecture& arch);

/// Time (ns) of the conversions of one read of a crossbar of `columns` physical columns: an ADC
/// per `columns_per_adc` columns converts ceil(columns / ADCs) of them, or, with ADCs shared by
/// `crossbars_per_adc` > 1 crossbars, columns x crossbars_per_adc, at `rate_gsps` each.
double adc_read_ns(long long columns, int columns_per_adc, int crossbars_per_adc, double rate_gsps);

/// The single iteration of a sparse (Toeplitz) layer at each of its tile's units (ns, before
/// the units round them to whole cycles): the shift register loads a crossbar's rows
/// (shift_entries_per_cycle per cycle); every read (input slices x read cycles) passes the
/// DACs, the settling crossbars and the most loaded ADC; the accumulator adds once. Ideal
/// timing: a cycle per read at the crossbars, nothing elsewhere (as a dense tile's).
struct SparseIterationNs {
  double shift = 0, dac = 0, crossbar = 0, adc = 0, accumulate = 0;
};
SparseIterationNs sparse_iteration_ns(const LayerInventory& v, const PlatformConfig& cfg);
/// The estimate of a sparse layer's busy time per image: its busiest unit's part in whole
/// cycles (the units pipeline successive images, as a dense tile's iterations).
double sparse_estimated_ns(const SparseIterationNs& t, const PlatformConfig& cfg);

/// Reads and validates `platform.`; ADC sharing and rate come from the resolved converter
/// spec and the component library.
PlatformConfig parse_platform_config(const ConfigTree& cfg, int adc_columns_per_unit, double adc_rate_gsps);

}  // namespace xbarsim
