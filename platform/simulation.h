#pragma once
/// One run of the SystemC/TLM-2.0 accelerator (platform/Pipeline.h) on a network, as a
/// library call returning a typed report: timing, stalls and throughput come from the
/// simulation, counts from the shared inventory, energy from the actions the processes
/// counted. simulate and explore drive it; SimulationReport::to_json is its one serialization
/// (--json, --report, explore's rows and the child process's answer all go through it).
#include <nlohmann/json.hpp>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "sw/common/config.h"
#include "sw/common/failure.h"
#include "sw/nn/dataset.h"
#include "sw/nn/model.h"
#include "sw/study/hardware.h"

namespace xbarsim {

class CrossbarBackend;

/// The images of a simulation: the dataset's (labelled, so accuracy is reported) or seeded
/// random ones.
struct SimulationData {
  Dataset test, calib;
  bool labelled = false;
};

/// A linear layer's stage as simulated: its units, the time its tile was busy, stalled and
/// starved per image beside the mapper's estimate, and its cost.
struct SimulatedLayer : LayerShape {  ///< (the JSON holds its name and kernel)
  long long stage = 0;  ///< its place in the pipeline
  long long rows = 0, cols = 0, crossbars = 0, adcs = 0, dacs = 0, iterations = 0, cycles = 0;
  int replication = 1;
  double busy_us = 0, stall_us = 0, starved_us = 0;
  /// A tile's (dense stage): the mapper's estimate of its busy time, busy / estimate, the units
  /// that bound it and each unit's utilization; none for a sparse layer.
  std::optional<double> estimated_busy_us, busy_over_estimate;
  std::optional<std::string> bound_by;
  std::map<std::string, double> unit_utilization;
  long long buffer_bytes = 0, buffer_peak_bytes = 0;
  double energy_uj = 0;
  ComponentBreakdown area_mm2;
};

/// A digital stage (pooling, additions, activations, data movement) as simulated, per image.
struct SimulatedDigitalStage {
  std::string name, operation;
  long long stage = 0;
  int tile = -1;
  double operations = 0, busy_us = 0, stall_us = 0, starved_us = 0;
};

/// A stage of the pipeline in its order (a layer's, a digital one's, the shared interconnect).
struct PipelineStage {
  std::string name, kind;  ///< kind: "linear", "digital" or "interconnect"
  double busy_us = 0, stall_us = 0;
};

/// What a simulation reports, typed; to_json() is the whole report (per layer, per digital
/// stage, the machine, the mesh) and from_json() reads it back exactly (a child process's).
struct SimulationReport {
  std::string model, timing, schedule, mapping, mode, architecture, component_library;
  double clock_mhz = 0, quantum_ns = 0;
  int images = 0, stages = 0, tiles = 0;
  Preprocessing preprocessing;
  std::vector<std::string> warnings;
  long long iterations_total = 0, cycles_total = 0;
  double latency_us = 0, makespan_us = 0, throughput_images_per_s = 0;
  std::string throughput_from;  ///< "simulated outputs", or the bottleneck stage's rate (one image)
  double estimated_period_us = 0, period_over_estimate = 0;
  CostReport cost;  ///< per image, priced from the simulation's counted actions
  double macs_per_image = 0, achieved_gops = 0, achieved_tops_per_w = 0, achieved_gops_per_mm2 = 0;
  /// The stage (or the interconnect) busy longest per image, and the unit that bounds it.
  struct Bottleneck {
    std::string stage;
    double busy_us_per_image = 0;
    std::optional<std::string> unit;
    nlohmann::json to_json() const;
  };
  std::optional<Bottleneck> bottleneck;
  std::map<std::string, double> unit_utilization;  ///< each kind of tile unit over the run, every copy
  /// Layer-sized: the shared bus (platform.bus_lanes).
  struct Bus {
    double bytes_per_image = 0, utilization = 0, interconnect_busy_us_per_image = 0;
  };
  std::optional<Bus> bus;
  /// On a machine: its peak, the mapper's placement and the mesh's traffic per image.
  struct Machine {
    double peak_gops = 0;
    nlohmann::json placement;  ///< Mapping::to_json of the placement the simulation ran
    double noc_bytes_per_image = 0, router_bytes_per_image = 0, local_bytes_per_image = 0;
    double contention_us_per_image = 0, link_utilization = 0;
  };
  std::optional<Machine> machine;
  /// platform.check_protocol: the transactions checked and the first violations.
  struct ProtocolCheck {
    long long transactions = 0, violations = 0;
    std::vector<std::string> first_violations;
  };
  std::optional<ProtocolCheck> protocol_check;
  std::vector<SimulatedLayer> layers;
  std::vector<SimulatedDigitalStage> digital_stages;
  double wall_time_s = 0, images_per_wall_s = 0;  ///< how this run went (not a result)
  std::optional<double> accuracy;           ///< labelled images with values computed
  std::optional<double> software_accuracy;  ///< the software network's on the same images

  double energy_uj_per_image() const { return cost.energy_uj().total(); }
  double avg_power_mw() const { return cost.avg_power_mw(); }
  double peak_power_mw() const { return cost.peak_power_mw.total(); }
  double area_mm2() const { return cost.area_mm2.total(); }
  /// The pipeline's stages in order, the shared interconnect last when it is one.
  std::vector<PipelineStage> pipeline_stages() const;
  nlohmann::json to_json() const;
  static SimulationReport from_json(const nlohmann::json& j);
};

/// What a run tells while it goes: programming (layers done, of), simulating (images done,
/// of), and notes for the user (what a slow configuration costs); any may be empty.
struct SimulationProgress {
  std::function<void(int, int)> programming, simulating;
  std::function<void(const std::string&)> note;
};

/// Programs `model` for `cfg` and simulates the accelerator on data.test (SystemC
/// elaborates once per process: call it once, or in run_in_child). `vcd`: trace file or "".
/// `programmed`: the crossbars already programmed for `cfg` on data.calib with
/// eval.calibration_samples (explore's evaluation shares them), or null to program them here.
SimulationReport simulate_model(const ConfigTree& cfg, const Model& model, const SimulationData& data,
                                const std::string& vcd, const SimulationProgress& progress = {},
                                const CrossbarBackend* programmed = nullptr);

/// Runs `run` in a forked child process (a fresh SystemC kernel) and returns its report; the
/// child's failure is rethrown here with its kind and message (Failure::rethrow).
SimulationReport run_in_child(const std::function<SimulationReport()>& run);

}  // namespace xbarsim
