#pragma once
/// One run of the SystemC/TLM-2.0 accelerator (platform/Pipeline.h) on a network, reported
/// as JSON: timing, stalls and throughput come from the simulation, counts from the shared
/// inventory, energy from the actions the processes counted. Used by simulate and explore.
#include <nlohmann/json.hpp>
#include <functional>
#include <optional>
#include <string>

#include "sw/common/config.h"
#include "sw/common/failure.h"
#include "sw/nn/dataset.h"
#include "sw/nn/model.h"

namespace xbarsim {

class CrossbarBackend;

/// The images of a simulation: the dataset's (labelled, so accuracy is reported) or seeded
/// random ones.
struct SimulationData {
  Dataset test, calib;
  bool labelled = false;
};
/// `images` test images of `dataset` (eval's split and calibration images), or random images
/// from data.synthetic_seed when `dataset` is empty.
SimulationData simulation_data(const std::string& dataset, const ConfigTree& cfg, const Model& model, int images);

/// What a simulation reports: the figures commands render, typed, and the whole report as
/// JSON (per layer, per digital stage, the machine, the mesh) for --json, --report and explore.
struct SimulationReport {
  std::string model, timing, schedule, mode, architecture;
  int images = 0;
  long long iterations_total = 0;
  double latency_us = 0, makespan_us = 0, throughput_images_per_s = 0;
  double energy_uj_per_image = 0, avg_power_mw = 0, peak_power_mw = 0, area_mm2 = 0;
  double achieved_tops_per_w = 0;
  std::string bottleneck;  ///< the stage (or the interconnect) busy longest per image
  double bottleneck_busy_us = 0;
  std::string bottleneck_unit;  ///< the unit that bounds it (a tile's, or the digital operation)
  double wall_time_s = 0, images_per_wall_s = 0;
  std::optional<double> accuracy;  ///< labelled images with values computed
  std::optional<double> software_accuracy;  ///< the software network's on the same images
  nlohmann::json json;             ///< the whole report
  /// The typed figures of a whole report (a child process's, sweeps and explore).
  static SimulationReport from_json(const nlohmann::json& j);
};

/// Programs `model` for `cfg` and simulates the accelerator on data.test (SystemC
/// elaborates once per process: call it once, or in run_in_child). `vcd`: trace file or "".
/// `print`: the per-layer table on stdout. `programmed`: the crossbars already programmed for
/// `cfg` on data.calib with eval.calibration_samples (explore's evaluation shares them), or
/// null to program them here.
SimulationReport simulate_model(const ConfigTree& cfg, const Model& model, const SimulationData& data,
                                const std::string& vcd, bool print, const CrossbarBackend* programmed = nullptr);

/// Runs `run` in a forked child process (a fresh SystemC kernel) and returns its JSON; the
/// child's failure is rethrown here with its kind and message (Failure::rethrow).
nlohmann::json run_in_child(const std::function<nlohmann::json()>& run);

}  // namespace xbarsim
