// Every command takes the bit-serial / bit-sliced keys (issue 24), on the tiny network the
// tests write (tests/app/tiny_network.h), and explore sweeps them: its points differ in what
// the keys change (reads, cells, conversions) and agree on what they do not.
#include <gtest/gtest.h>

#include <cstdlib>
#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "tests/app/cli_test_util.h"
#include "tests/app/tiny_network.h"

namespace {

class BitSerialCli : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ =
        ::testing::TempDir() + "xbarsim_bitserial_" + ::testing::UnitTest::GetInstance()->current_test_info()->name();
    std::system(("rm -rf '" + dir_ + "' && mkdir -p '" + dir_ + "/models'").c_str());
    xbarsim_test::write_tiny_cifar(dir_ + "/data", 8);
    xbarsim_test::write_tiny_model(dir_ + "/models/tiny.onnx");
    std::ofstream(cfg()) << "data:\n  dir: " << dir_ << "/data\n  models_dir: " << dir_
                         << "/models\neval:\n  calibration_images: 4\n  calibration_samples: 64\ncalibration:\n  samples: 10\n"
                            "crossbar:\n  cell_bits: 2\nmapping:\n  weight_bits: 8\n  max_rows: 64\n"
                            "converters:\n  input_bits: 8\n  dac_bits: 1\n";
  }
  void TearDown() override {
    if (!HasFailure()) std::system(("rm -rf '" + dir_ + "'").c_str());
  }
  std::string cfg() const { return dir_ + "/cfg.yaml"; }
  std::string path(const std::string& n) const { return dir_ + "/" + n; }
  xbarsim_test::Result run(const std::string& command, const std::string& args) const {
    return xbarsim_test::run_xbarsim(command + " --config " + cfg() + " " + args);
  }
  static nlohmann::json json(const std::string& p) {
    std::ifstream in(p);
    return nlohmann::json::parse(in);
  }
  std::string dir_;
};

}  // namespace

TEST_F(BitSerialCli, AnalysisCommandsAcceptTheKeys) {
  const std::pair<const char*, std::string> commands[] = {
      {"eval", "--model tiny --images 2"},
      {"xbar-study", "--set study.rows=40 --set study.cols=4 --set study.vectors=20"},
      {"overhead", "--model tiny"},
  };
  for (const auto& [command, args] : commands) {
    const auto r = run(command, args + " --json " + path(std::string(command) + ".json"));
    EXPECT_EQ(r.code, 0) << command << "\n" << r.out;
  }
  const auto ev = json(path("eval.json"));
  EXPECT_EQ(ev["input_bits"], 8);
  EXPECT_EQ(ev["cell_bits"], 2);
  EXPECT_GT(ev["energy_breakdown_uj"]["shift_add"].get<double>(), 0);
}

// SystemC runs (scripts/sanitize.sh leaves them out, as every simulating test).
TEST_F(BitSerialCli, SimulateAcceptsTheKeys) {
  const auto r = run("simulate", "--model tiny --dataset cifar10 --images 2 --json " + path("simulate.json"));
  ASSERT_EQ(r.code, 0) << r.out;
  // Sampled, shifted and added conversions are priced.
  const auto sim = json(path("simulate.json"));
  EXPECT_GT(sim["energy_breakdown_uj"]["sample_hold"].get<double>(), 0);
  EXPECT_GT(sim["energy_breakdown_uj"]["shift_add"].get<double>(), 0);
}

TEST_F(BitSerialCli, ExploreSweepsDacBitsAndCellBits) {
  const auto r = run("explore",
                     "--model tiny --images 2 --set 'converters.dac_bits=[1,8]' --set "
                     "'crossbar.cell_bits=[2,4]' --out " +
                         path("x.jsonl") + " --json " + path("x.json"));
  ASSERT_EQ(r.code, 0) << r.out;
  const auto j = json(path("x.json"));
  ASSERT_EQ(j["points"].size(), 4u) << j.dump(1).substr(0, 2000);
  auto point = [&](const std::string& label) {
    for (const auto& p : j["points"])
      if (p["label"] == label) return p;
    ADD_FAILURE() << "no point " << label;
    return nlohmann::json();
  };
  const auto c2d1 = point("cell_bits=2 dac_bits=1"), c2d8 = point("cell_bits=2 dac_bits=8"),
             c4d1 = point("cell_bits=4 dac_bits=1");
  auto energy = [](const nlohmann::json& p) { return p["energy_uj_per_image"].get<double>(); };
  auto adc_energy = [](const nlohmann::json& p) { return p["energy_breakdown_uj"]["adc"].get<double>(); };
  // Eight 1-bit reads convert eight times what one 8-bit read does; 2-bit cells twice the
  // columns of 4-bit cells (4 cells per 8-bit weight, not 2).
  EXPECT_NEAR(adc_energy(c2d1), 8 * adc_energy(c2d8), 1e-9 * adc_energy(c2d1));
  EXPECT_NEAR(adc_energy(c2d1), 2 * adc_energy(c4d1), 1e-9 * adc_energy(c2d1));
  EXPECT_GT(energy(c2d1), energy(c4d1));
  // An 8-bit DAC is larger than a 1-bit one.
  EXPECT_GT(c2d8["area_breakdown_mm2"]["dac"].get<double>(), c2d1["area_breakdown_mm2"]["dac"].get<double>());
}

// A machine (issue 25): overhead, eval and simulate price the same chip (area and peak power
// from counts x components), simulate places the network on it and crosses its mesh, and a
// mapping that contradicts the machine's crossbars is refused naming the key.
TEST_F(BitSerialCli, SimulateOnIsaacCeGivesOverheadsChip) {
  const std::string machine =
      " --set architecture.machine=isaac-ce --set mapping.max_rows=128 --set mapping.max_cols=128"
      " --set components.library=isaac";
  const auto o = run("overhead", "--model tiny" + machine + " --json " + path("o.json"));
  ASSERT_EQ(o.code, 0) << o.out;
  const auto s = run("simulate", "--model tiny --dataset cifar10 --images 2 --set platform.schedule=pipelined" +
                                     machine + " --json " + path("s.json"));
  ASSERT_EQ(s.code, 0) << s.out;
  const auto e = run("eval", "--model tiny --images 2" + machine + " --json " + path("e.json"));
  ASSERT_EQ(e.code, 0) << e.out;
  const auto oj = json(path("o.json")), sj = json(path("s.json")), ej = json(path("e.json"));
  EXPECT_NEAR(ej["area_mm2"].get<double>(), oj["machine"]["area_mm2"].get<double>(), 1e-9);
  EXPECT_NEAR(ej["peak_power_mw"].get<double>(), oj["machine"]["peak_power_mw"].get<double>(), 1e-6);
  EXPECT_EQ(sj["architecture"], "isaac-ce");
  EXPECT_NEAR(sj["area_mm2"].get<double>(), oj["machine"]["area_mm2"].get<double>(), 1e-9);
  EXPECT_NEAR(sj["peak_power_mw"].get<double>(), oj["machine"]["peak_power_mw"].get<double>(), 1e-6);
  EXPECT_NEAR(sj["area_mm2"].get<double>(), 85.4, 0.01 * 85.4);  // ISAAC's chip
  EXPECT_TRUE(sj["placement"]["fits"].get<bool>());
  EXPECT_EQ(sj["placement"]["imas_used"], oj["machine"]["mapping"]["imas_used"]);
  EXPECT_GT(sj["achieved_tops_per_w"].get<double>(), 0);
  EXPECT_TRUE(sj.contains("noc"));
  // eval counts in closed form what simulate counts on the mesh: the same actions' energy,
  // part by part (the leakage follows each command's time per image).
  const double e_sim = sj["dynamic_energy_uj_per_image"].get<double>();
  EXPECT_GT(sj["dynamic_energy_breakdown_uj"]["interconnect"].get<double>(), 0);
  EXPECT_GT(sj["dynamic_energy_breakdown_uj"]["digital"].get<double>(), 0);
  EXPECT_NEAR(ej["dynamic_energy_uj_per_image"].get<double>(), e_sim, 1e-9 * e_sim);
  for (const auto& [part, v] : sj["dynamic_energy_breakdown_uj"].items())
    EXPECT_NEAR(ej["dynamic_energy_breakdown_uj"][part].get<double>(), v.get<double>(), 1e-9 * e_sim) << part;
  const auto bad = run("overhead", "--model tiny --set architecture.machine=isaac-ce --set components.library=isaac");
  EXPECT_EQ(bad.code, 2) << bad.out;
  EXPECT_NE(bad.out.find("mapping.max_rows"), std::string::npos) << bad.out;
}

// Timing and action counts do not depend on the values: a timing-only run (no programming, no
// reads) reports what the run that computes the logits reports, on a machine (auto replication)
// and on layer-sized tiles, bit-serial and not. It refuses a dataset it would not read.
TEST_F(BitSerialCli, SimulateTimingOnlyReportsWhatTheFullRunReports) {
  const std::string machine =
      " --set architecture.machine=isaac-ce --set mapping.max_rows=128 --set mapping.max_cols=128"
      " --set components.library=isaac --set platform.replication=auto";
  for (const std::string& design : {machine, std::string(" --set converters.input_bits=none")}) {
    const std::string common = " --model tiny --images 3 --set platform.schedule=pipelined" + design;
    const auto full = run("simulate", common + " --json " + path("full.json"));
    ASSERT_EQ(full.code, 0) << full.out;
    const auto fast = run("simulate", common + " --timing-only --json " + path("fast.json"));
    ASSERT_EQ(fast.code, 0) << fast.out;
    auto a = json(path("full.json")), b = json(path("fast.json"));
    EXPECT_EQ(a["mode"], "timing-and-values");
    EXPECT_EQ(b["mode"], "timing-only");
    for (auto* j : {&a, &b})
      for (const char* k : {"mode", "simulation_wall_time_s", "simulated_images_per_wall_s"}) j->erase(k);
    EXPECT_GT(a["latency_us"].get<double>(), 0);
    EXPECT_EQ(a.dump(), b.dump()) << design;
  }
  const auto bad = run("simulate", "--model tiny --dataset cifar10 --images 2 --timing-only");
  EXPECT_EQ(bad.code, 2) << bad.out;
  EXPECT_NE(bad.out.find("--images"), std::string::npos) << bad.out;
}

// Temporal decoupling (platform.quantum_ns): a stage publishes rows up to one quantum before its
// own time, so along an image's path of `stages` operations plus the input and output
// transfers its latency, and the run's makespan, move by at most (stages + 2) x quantum; a
// quantum at or below the clock period (10 ns) waits every delay, and 0 is refused.
TEST_F(BitSerialCli, SimulateQuantumSweepMovesTimingWithinTheBound) {
  const auto r = run("simulate",
                     "--model tiny --images 4 --timing-only --set platform.schedule=pipelined"
                     " --set 'platform.quantum_ns=[1,10,1000,100000]' --json " +
                         path("q.json"));
  ASSERT_EQ(r.code, 0) << r.out;
  const auto j = json(path("q.json"));
  ASSERT_EQ(j.size(), 4u);
  const double lat0 = j[0]["latency_us"].get<double>(), span0 = j[0]["makespan_us"].get<double>();
  EXPECT_EQ(j[1]["latency_us"].get<double>(), lat0);
  EXPECT_EQ(j[1]["makespan_us"].get<double>(), span0);
  for (size_t k = 1; k < j.size(); ++k) {
    const double bound_us = (j[k]["stages"].get<int>() + 2) * j[k]["quantum_ns"].get<double>() * 1e-3;
    EXPECT_LE(std::abs(j[k]["latency_us"].get<double>() - lat0), bound_us) << j[k]["quantum_ns"];
    EXPECT_LE(std::abs(j[k]["makespan_us"].get<double>() - span0), bound_us) << j[k]["quantum_ns"];
    EXPECT_EQ(j[k]["energy_uj_per_image"], j[0]["energy_uj_per_image"]);  // the same actions
  }
  EXPECT_NE(j[3]["latency_us"].get<double>(), lat0);  // a quantum beyond an image's time does move it
  const auto zero = run("simulate", "--model tiny --images 1 --timing-only --set platform.quantum_ns=0");
  EXPECT_EQ(zero.code, 2) << zero.out;
  EXPECT_NE(zero.out.find("platform.quantum_ns"), std::string::npos) << zero.out;
}

// A sparse (Toeplitz) layer's iteration goes through its tile's units (issue 52): its busy
// time is its busiest unit's part (the estimate, in closed form), the report names the unit,
// and pipelined images overlap from unit to unit.
TEST_F(BitSerialCli, SimulateSparseLayersAreTimedByTheirTilesUnits) {
  const auto r = run("simulate",
                     "--model tiny --images 4 --timing-only --set mapping.scheme=sparse --set platform.schedule=pipelined"
                     " --json " + path("sparse.json"));
  ASSERT_EQ(r.code, 0) << r.out;
  const auto j = json(path("sparse.json"));
  ASSERT_FALSE(j["layers"].empty());
  for (const auto& L : j["layers"]) {
    EXPECT_EQ(L["iterations"], 1) << L["name"];
    EXPECT_GT(L["busy_us"].get<double>(), 0) << L["name"];
    EXPECT_NEAR(L["busy_us"].get<double>(), L["estimated_busy_us"].get<double>(), 1e-9) << L["name"];
    EXPECT_FALSE(L["bound_by"].get<std::string>().empty()) << L["name"];
  }
}

// Issue 38 item 5: a network that does not fit the machine is refused by every command with
// simulate's message (eval used to exit 0, pricing a 1-IMA chip that runs a 2-IMA network;
// overhead printed the status after the bill). The tiny network's two layers take a 128 x 128
// crossbar each: two IMAs of one crossbar; the machine has one.
TEST_F(BitSerialCli, ANetworkTooLargeForTheMachineIsRefusedByEveryCommand) {
  std::ofstream(path("small.yaml"))
      << "name: small\ncrossbar: {rows: 128, cols: 128, cell_bits: 2}\n"
         "ima: {crossbars: 1, adcs: 1, read_ns: 100, input_register_bytes: 128, output_register_bytes: 32}\n"
         "tile:\n  imas: 1\n  edram: {kib: 64, bytes_per_ns: 38.4}\n  bus: {unit: tile_bus, bytes_per_ns: 38.4}\n"
         "  units:\n    sigmoid: {count: 2, actions_per_ns: 1.2, ops: [relu, affine, activation, softmax]}\n"
         "    maxpool: {count: 1, actions_per_ns: 1.2, ops: [maxpool, avgpool, globalavgpool]}\n"
         "chip:\n  tiles: 1\n  tiles_per_router: 1\n  mesh: {rows: 1, cols: 1}\n"
         "  router: {unit: router, bytes_per_ns: 38.4, hop_ns: 1}\n"
         "  offchip: {unit: hypertransport, count: 1, bytes_per_ns: 6.4}\n";
  const std::string machine = " --set architecture.machine=" + path("small.yaml") +
                              " --set mapping.max_rows=128 --set mapping.max_cols=128 --set components.library=isaac";
  const std::string message =
      "the network does not fit architecture.machine small: the network needs 2 IMAs (2 crossbars in whole IMAs of "
      "1), small has 1 (1 tiles x 1)";
  for (const auto& [command, args] :
       {std::pair<std::string, std::string>{"simulate", "--model tiny --images 2 --timing-only"},
        {"eval", "--model tiny --images 2"},
        {"overhead", "--model tiny"}}) {
    const auto r = run(command, args + machine);
    EXPECT_EQ(r.code, 2) << command << "\n" << r.out;
    EXPECT_NE(r.out.find("error: " + message + "\n"), std::string::npos) << command << "\n" << r.out;
  }
  // explore: the point fails with the same reason.
  const auto x = run("explore", "--model tiny --images 2" + machine + " --out " + path("x.jsonl") + " --json " +
                                    path("x.json"));
  ASSERT_EQ(x.code, 0) << x.out;
  const auto j = json(path("x.json"));
  ASSERT_EQ(j["points"].size(), 1u);
  EXPECT_EQ(j["points"][0]["status"], "failed");
  EXPECT_EQ(j["points"][0]["reason"], message);
}
