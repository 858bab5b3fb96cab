// One inventory and one cost model for every command: the same configuration gives the same
// crossbars, ADCs, DACs and area in overhead, eval, xbar-study and simulate; every knob moves
// cost in the documented direction; a small layer's energy equals a hand computation.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <fstream>
#include <random>

#include "sw/nn/presets.h"
#include "sw/study/eval_study.h"
#include "sw/study/overhead_study.h"
#include "sw/study/xbar_study.h"

using namespace xbarsim;

namespace {

nlohmann::json run_json(const std::string& args, const std::string& name) {
  const std::string path = "/tmp/xbarsim_consistency_" + name + ".json";
  const std::string cmd = std::string(XBARSIM_BINARY) + " " + args + " --json " + path + " > /dev/null 2>&1";
  const int st = std::system(cmd.c_str());
  EXPECT_TRUE(WIFEXITED(st) && WEXITSTATUS(st) == 0) << cmd;
  std::ifstream in(path);
  return nlohmann::json::parse(in);
}

const char* kSets = "--set mapping.max_rows=64 --set mapping.max_cols=48 --set converters.adc_columns_per_adc=32";

}  // namespace

TEST(Consistency, AllCommandsCountAndPriceTheSameDesign) {
  const ConfigTree cfg =
      ConfigTree::load("", {"mapping.max_rows=64", "mapping.max_cols=48", "converters.adc_columns_per_adc=32"});
  const EvalPoint point = parse_eval_point(cfg);
  const Model model = make_preset("lenet", 3);
  // overhead
  const OverheadReport over = overhead_study(model, point.hw);
  // eval (the crossbars it really programs, on random images)
  const EvalResult ev = run_eval(model, point, EvalSpec{2, 0, 4, 64}, random_dataset(model.input, 2, 1),
                                 random_dataset(model.input, 4, 2));
  // simulate (the executable: the SystemC platform)
  const nlohmann::json sim = run_json(std::string("simulate --preset lenet ") + kSets, "simulate");
  ASSERT_EQ(over.layers.size(), ev.layers.size());
  ASSERT_EQ(sim["layers"].size(), ev.layers.size());
  double area = 0;
  for (size_t l = 0; l < ev.layers.size(); ++l) {
    const LayerInventory& o = over.layers[l].dense.inv;
    SCOPED_TRACE(o.name);
    EXPECT_EQ(ev.layers[l].inventory.crossbars, o.crossbars);
    EXPECT_EQ(sim["layers"][l]["crossbars"], o.crossbars);
    EXPECT_EQ(sim["layers"][l]["adcs"], o.adcs);
    EXPECT_EQ(sim["layers"][l]["dacs"], o.dacs);
    EXPECT_EQ(ev.layers[l].inventory.adcs, o.adcs);
    EXPECT_EQ(ev.layers[l].inventory.dacs, o.dacs);
    area += over.layers[l].dense.area_mm2.total();
  }
  double sim_layers = 0;
  for (const auto& l : sim["layers"]) sim_layers += l["area_mm2"].get<double>();
  EXPECT_NEAR(sim_layers, area, 1e-12 * area);
  // The platform adds the interconnect and its digital units to the layers' area.
  const auto& ab = sim["area_breakdown_mm2"];
  EXPECT_NEAR(sim["area_mm2"].get<double>(), area + ab["interconnect"].get<double>() + ab["digital"].get<double>(),
              1e-12 * area);
  // eval prices the same platform in closed form: the same area and energy per image.
  EXPECT_NEAR(ev.cost.area_mm2.total(), sim["area_mm2"].get<double>(), 1e-12 * area);
  const double e_sim = sim["energy_uj_per_image"].get<double>();
  EXPECT_NEAR(ev.cost.energy_uj().total(), e_sim, 1e-9 * e_sim);
  for (const char* part : {"interconnect", "memory", "digital"}) {
    EXPECT_GT(sim["energy_breakdown_uj"][part].get<double>(), 0) << part;
    EXPECT_NEAR(ev.cost.energy_uj().to_json()[part].get<double>(), sim["energy_breakdown_uj"][part].get<double>(),
                1e-9 * e_sim)
        << part;
  }
  // xbar-study of one 150 x 100 matrix: the same rule.
  const nlohmann::json xs = run_json(std::string("xbar-study --set study.rows=150 --set study.cols=100 "
                                                 "--set study.vectors=4 ") +
                                         kSets,
                                     "xbar");
  const LayerInventory m = matrix_inventory(150, 100, 4, point.ac.mapping, 32);
  EXPECT_EQ(xs["crossbar_count"], m.crossbars);
  EXPECT_EQ(xs["crossbars"].size(), static_cast<size_t>(m.crossbars));  // really programmed
  EXPECT_EQ(xs["adc_count"], m.adcs);
  EXPECT_EQ(xs["dac_count"], m.dacs);
  EXPECT_EQ(m.crossbars, 3 * 3);           // ceil(150/64) x ceil(100/48)
  EXPECT_EQ(m.adcs, 3 * (2 * 2 + 1 * 2));  // column blocks 34, 33, 33 -> 2 ADCs each at 32 per ADC
}

TEST(Consistency, KnobsMoveCostInTheDocumentedDirection) {
  auto cost_of = [](std::vector<std::string> sets, const char* net = "resnet20") {
    const ConfigTree cfg = ConfigTree::load("", sets);
    const EvalPoint p = parse_eval_point(cfg);
    return overhead_study(make_preset(net, 1), p.hw).dense_total;
  };
  const MappingOverhead base = cost_of({});
  // Lower ADC resolution: cheaper ADCs, same count.
  const MappingOverhead adc4 = cost_of({"converters.adc_bits=4"});
  EXPECT_EQ(adc4.inv.adcs, base.inv.adcs);
  EXPECT_LT(adc4.area_mm2.adc, base.area_mm2.adc / 15);
  EXPECT_LT(adc4.peak_power_mw.adc, base.peak_power_mw.adc / 15);
  // Sharing an ADC over fewer columns (more ADCs per crossbar): more ADCs, area and power.
  const MappingOverhead share32 = cost_of({"converters.adc_columns_per_adc=32"});
  EXPECT_GT(share32.inv.adcs, base.inv.adcs);
  EXPECT_GT(share32.area_mm2.total(), base.area_mm2.total());
  EXPECT_GT(share32.peak_power_mw.adc, base.peak_power_mw.adc);
  // Differential pairs: twice the physical columns and cells read; where a layer's columns
  // no longer fit one array (LeNet's 500-column layers), more crossbars and area.
  const MappingOverhead diff = cost_of({"mapping.negative=differential"});
  EXPECT_EQ(diff.inv.physical_cols, 2 * base.inv.physical_cols);
  EXPECT_EQ(diff.inv.cells_used, 2 * base.inv.cells_used);
  const MappingOverhead lenet = cost_of({}, "lenet"), lenet_diff = cost_of({"mapping.negative=differential"}, "lenet");
  EXPECT_GT(lenet_diff.inv.crossbars, lenet.inv.crossbars);
  EXPECT_GT(lenet_diff.area_mm2.total(), lenet.area_mm2.total());
  const nlohmann::json e1 = run_json("simulate --preset resnet20 --timing ideal", "energy_base");
  const nlohmann::json e2 =
      run_json("simulate --preset resnet20 --timing ideal --set mapping.negative=differential", "energy_diff");
  EXPECT_GT(e2["energy_breakdown_uj"]["adc"].get<double>(), 1.9 * e1["energy_breakdown_uj"]["adc"].get<double>());
  EXPECT_GT(e2["energy_breakdown_uj"]["crossbar"].get<double>(),
            1.9 * e1["energy_breakdown_uj"]["crossbar"].get<double>());
  // The simulated timing follows the ADC count: more ADCs per crossbar, shorter latency.
  const nlohmann::json t1 = run_json("simulate --preset resnet20", "lat_base");
  const nlohmann::json t2 = run_json("simulate --preset resnet20 --set converters.adc_columns_per_adc=16", "lat_16");
  EXPECT_LT(t2["latency_us"].get<double>(), t1["latency_us"].get<double>());
  EXPECT_GT(t2["adcs"].get<long long>(), t1["adcs"].get<long long>());
  EXPECT_GT(t2["area_mm2"].get<double>(), t1["area_mm2"].get<double>());
}

TEST(Consistency, SmallLayerEnergyByHand) {
  // 3x3 conv, 2 -> 4 channels, 5x5 input, pad 1: 25 iterations on one 18 x 4 crossbar with
  // 18 DACs and 1 ADC (defaults: 144 x 128 arrays, 128 columns per ADC, 8-bit converters).
  Model m = make_preset("lenet", 1);
  LinearLayer L = m.linear[0];
  L.c_in = 2, L.c_out = 4, L.k_h = L.k_w = 3, L.stride_h = L.stride_w = 1;
  L.pad_t = L.pad_l = L.pad_b = L.pad_r = 1;
  L.in = {2, 5, 5};
  L.out = {4, 5, 5};
  const EvalPoint p = parse_eval_point(ConfigTree());
  const LayerInventory v = layer_inventory(L, MappingScheme::Dense, p.ac.mapping, p.hw.columns_per_adc);
  EXPECT_EQ(v.crossbars, 1);
  EXPECT_EQ(v.dacs, 18);
  EXPECT_EQ(v.adcs, 1);
  const ActionCounts a = layer_actions_per_image(v, dense_shifted_entries(L));
  EXPECT_EQ(a.dac_conversions, 25 * 18);
  EXPECT_EQ(a.cell_reads, 25 * 18 * 4);
  EXPECT_EQ(a.adc_conversions, 25 * 4);
  EXPECT_EQ(a.shifts, 5 * (18 + 4 * 6));  // a full window per output row, then 3 x 2 entries per step
  EXPECT_EQ(a.samples, 25 * 4);
  EXPECT_EQ(a.shift_adds, 0);  // one read of one cell per weight: nothing to shift and add
  // Library figures (configs/components/isaac_paper.yaml) in pJ per action.
  const double hand = 450 * 10.0 + 1800 * 1.46484375e-3 + 100 * 1.5625 + 100 * 0.0 + 210 * 0.0323 + 210 * 0.539 +
                      100 * 0.539 + 100 * 9.765625e-4;
  const ComponentBreakdown e = p.hw.cost.dynamic_energy_pj(a);
  EXPECT_NEAR(e.total(), hand, 1e-9 * hand);
  EXPECT_NEAR(e.dac, 4500.0, 1e-9);
  EXPECT_NEAR(e.adc, 156.25, 1e-9);
  // Leakage is zero in this library: energy over any time equals the dynamic energy.
  EXPECT_NEAR(p.hw.cost.energy_pj(a, v, 1e6).total(), hand, 1e-9 * hand);
}

TEST(Consistency, DenseAndSparseSimulationsAgreeWithOverhead) {
  // The whole-network dense vs sparse comparison comes out of the timing simulation with the
  // counts of `overhead` (the paper's study: one crossbar per layer).
  const ConfigTree cfg = ConfigTree::load("", {"mapping.max_rows=unbounded", "mapping.max_cols=unbounded"});
  const OverheadReport over = overhead_study(make_preset("resnet20", 3), parse_eval_point(cfg).hw);
  for (const char* scheme : {"dense", "sparse"}) {
    SCOPED_TRACE(scheme);
    const nlohmann::json j = run_json(std::string("simulate --preset resnet20 --set mapping.max_rows=unbounded "
                                                  "--set mapping.max_cols=unbounded --set mapping.scheme=") +
                                          scheme,
                                      std::string("scheme_") + scheme);
    const MappingOverhead& t = std::string(scheme) == "dense" ? over.dense_total : over.sparse_total;
    long long adcs = 0, dacs = 0;
    double area = 0;
    for (const auto& l : j["layers"]) {
      adcs += l["adcs"].get<long long>();
      dacs += l["dacs"].get<long long>();
      area += l["area_mm2"].get<double>();
    }
    EXPECT_EQ(j["iterations_total"].get<long long>(), t.inv.iterations);
    EXPECT_EQ(adcs, t.inv.adcs);
    EXPECT_EQ(dacs, t.inv.dacs);
    EXPECT_NEAR(area, t.area_mm2.total(), 1e-9 * area);
  }
}

TEST(Consistency, ReplicationMultipliesCrossbarsAndArea) {
  const nlohmann::json one = run_json("simulate --preset lenet --set platform.schedule=pipelined --images 2", "rep1");
  const nlohmann::json two = run_json(
      "simulate --preset lenet --set platform.schedule=pipelined --images 2 --set "
      "platform.replication_per_layer=3,1,1,1",
      "rep3");
  EXPECT_EQ(two["layers"][0]["replication"], 3);
  EXPECT_EQ(two["layers"][0]["crossbars"].get<long long>(), 3 * one["layers"][0]["crossbars"].get<long long>());
  // Arrays, converters, accumulators and shift registers are copied; the layer's input buffer is not.
  const auto &a1 = one["layers"][0]["area_breakdown_mm2"], &a3 = two["layers"][0]["area_breakdown_mm2"];
  for (const char* c : {"crossbar", "adc", "dac", "accumulator", "shift_register"})
    EXPECT_NEAR(a3[c].get<double>(), 3 * a1[c].get<double>(), 1e-15) << c;
  EXPECT_EQ(a3["buffer"], a1["buffer"]);
  EXPECT_EQ(two["tiles"], one["tiles"].get<int>() + 2);
}

TEST(Consistency, AutoReplicationRaisesPipelinedThroughput) {
  // Under twice the unreplicated crossbars, with an interconnect that is not the bottleneck
  // (32 lanes of 64 bytes per cycle), copying the first layers raises the simulated throughput.
  const std::string base =
      "simulate --preset resnet20 --images 16 --set platform.schedule=pipelined "
      "--set platform.link_bytes_per_cycle=64 --set platform.bus_lanes=32 ";
  const nlohmann::json one = run_json(base + "--set platform.replication=1", "auto_off");
  const nlohmann::json two = run_json(base + "--set platform.replication=auto", "auto_on");
  long long x1 = 0, x2 = 0;
  for (const auto& l : one["layers"]) x1 += l["crossbars"].get<long long>();
  for (const auto& l : two["layers"]) x2 += l["crossbars"].get<long long>();
  EXPECT_LE(x2, 2 * x1);
  EXPECT_GT(two["throughput_images_per_s"].get<double>(), 2.0 * one["throughput_images_per_s"].get<double>());
}
