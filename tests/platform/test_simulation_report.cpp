// The typed report of one simulation (platform/simulation.h): its JSON reads back to the same
// report (a child process's answer, explore's rows), and its figures hold the closed forms the
// JSON promises.
#include <gtest/gtest.h>

#include "platform/simulation.h"
#include "sw/nn/presets.h"

#include "tests/platform/one_simulation.h"

using namespace xbarsim;

namespace {

SimulationReport timing_only(const std::string& config, const std::string& preset) {
  const ConfigTree cfg = ConfigTree::load(config, {"platform.timing_only=true", "platform.images=2"});
  return simulate_model(cfg, make_preset(preset, 3), SimulationData{}, "");
}

/// Checks that hold for any report, against its JSON.
void expect_report_reads_back(const SimulationReport& r, size_t linear_layers) {
  const nlohmann::json j = r.to_json();
  EXPECT_EQ(SimulationReport::from_json(j).to_json(), j);  // nothing dropped or altered
  ASSERT_EQ(r.layers.size(), linear_layers);
  // Energy = the actions' + every part's leakage over the simulated time per image, part by
  // part (the leakage breakdown is in the JSON so that a reader can check it).
  const double t_ms = j["time_ns_per_image"].get<double>() * 1e-6;
  EXPECT_GT(t_ms, 0);
  for (const auto& [part, e] : j["energy_breakdown_uj"].items())
    EXPECT_DOUBLE_EQ(e.get<double>(), j["dynamic_energy_breakdown_uj"][part].get<double>() +
                                          j["leakage_breakdown_mw"][part].get<double>() * t_ms)
        << part;
  double layers_uj = 0;
  for (const SimulatedLayer& l : r.layers) layers_uj += l.energy_uj;
  EXPECT_LE(layers_uj, r.cost.dynamic_energy_uj.total() * (1 + 1e-12));  // the platform's on top
  // The stages in pipeline order: every layer's and digital stage's once.
  const std::vector<PipelineStage> stages = r.pipeline_stages();
  EXPECT_EQ(stages.size(), r.layers.size() + r.digital_stages.size() + (r.bus ? 1 : 0));
  EXPECT_EQ(static_cast<int>(r.layers.size() + r.digital_stages.size()), r.stages);
}

}  // namespace

TEST(SimulationReport, LayerSizedReadsBackFromItsJson) {
  ONE_SIMULATION_PER_PROCESS();
  const SimulationReport r = timing_only("", "lenet");
  expect_report_reads_back(r, make_preset("lenet", 3).linear.size());
  ASSERT_TRUE(r.bus.has_value());
  EXPECT_FALSE(r.machine.has_value());
  EXPECT_EQ(r.pipeline_stages().back().kind, "interconnect");
  EXPECT_EQ(r.architecture, "layer-sized");
  EXPECT_EQ(r.images, 2);
}

TEST(SimulationReport, MachineReadsBackFromItsJson) {
  ONE_SIMULATION_PER_PROCESS();
  const SimulationReport r = timing_only(std::string(XBARSIM_SOURCE_DIR) + "/configs/isaac.yaml", "resnet20");
  expect_report_reads_back(r, make_preset("resnet20", 3).linear.size());
  ASSERT_TRUE(r.machine.has_value());
  EXPECT_FALSE(r.bus.has_value());
  EXPECT_TRUE(r.machine->placement.contains("layers"));
  EXPECT_GT(r.machine->noc_bytes_per_image, 0);
}
