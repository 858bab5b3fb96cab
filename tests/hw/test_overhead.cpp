// Overhead model against hand-computed counts, sums and scaling rules.
#include <gtest/gtest.h>

#include <array>
#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sys/wait.h>

#include "sw/hw/overhead.h"
#include "sw/nn/dataset.h"
#include "sw/nn/presets.h"

using namespace xbarsim;

namespace {
const double kCellP = 2.4 / 16384, kCellA = 0.0002 / 16384;  // ISAAC array / cells
ComponentLibrary lib() { return load_component_library(ConfigTree()); }
}  // namespace

TEST(Overhead, PaperDenseRowFollowsTheRules) {
  HardwareSettings hw;  // unbounded, 8-bit
  const MappingCost c = mapping_cost(27, 16, 27 * 16, 1024, hw, lib());
  EXPECT_EQ(c.crossbars, 1);
  EXPECT_EQ(c.adcs, 1);
  EXPECT_EQ(c.dacs, 27);
  EXPECT_NEAR(c.xbar_power_mw, 432 * kCellP, 1e-12);
  EXPECT_NEAR(c.xbar_area_mm2, 432 * kCellA, 1e-15);
  EXPECT_NEAR(c.total_power_mw, 432 * kCellP + 2.0 + 27 * 1.0, 1e-9);
  EXPECT_NEAR(c.total_area_mm2, 432 * kCellA + 0.0012 + 27 * 4.25e-5, 1e-12);
  EXPECT_DOUBLE_EQ(c.utilization(), 1.0);
}

TEST(Overhead, SparseToeplitzAdcsShareColumns) {
  HardwareSettings hw;
  const MappingCost c = mapping_cost(3072, 14400, 14400LL * 27, 1, hw, lib());
  EXPECT_EQ(c.adcs, 113);  // ceil(14400 / 128)
  EXPECT_EQ(c.dacs, 3072);
  EXPECT_NEAR(c.total_power_mw, 3072.0 * 14400 * kCellP + 113 * 2.0 + 3072 * 1.0, 1e-6);
  EXPECT_NEAR(c.utilization(), 27.0 / 3072, 1e-12);
}

TEST(Overhead, PartitioningCountsPhysicalArrays) {
  HardwareSettings hw;
  hw.max_rows = 64;
  hw.max_cols = 64;
  MappingCost c = mapping_cost(576, 64, 576 * 64, 64, hw, lib());
  EXPECT_EQ(c.crossbars, 9);
  EXPECT_EQ(c.adcs, 9);
  EXPECT_EQ(c.dacs, 576);
  EXPECT_EQ(c.cells_present, 9 * 64 * 64);
  c = mapping_cost(100, 200, 100 * 200, 1, hw, lib());
  EXPECT_EQ(c.crossbars, 2 * 4);
  EXPECT_EQ(c.adcs, 8);        // column blocks of 50: one ADC each, per row block
  EXPECT_EQ(c.dacs, 100 * 4);  // every column block drives its own rows
  EXPECT_EQ(c.cells_present, 8 * 4096);
  EXPECT_NEAR(c.utilization(), 20000.0 / 32768, 1e-12);
  hw.max_cols = 300;  // 300-column arrays: one crossbar per row block, 2 ADCs (ceil(200/128))
  c = mapping_cost(100, 200, 100 * 200, 1, hw, lib());
  EXPECT_EQ(c.adcs, 2 * 2);
}

TEST(Overhead, ScalingRulesAreData) {
  const ComponentLibrary l = parse_component_library(R"(
adc: {power_mw: 2, area_mm2: 0.0012, reference_bits: 8, columns_per_unit: 64, sample_rate_gsps: 1,
      power_scaling: linear, area_scaling: constant}
dac: {power_mw: 1, area_mm2: 4e-5, reference_bits: 8}
cell: {power_mw: 1e-4, area_mm2: 1e-8}
accumulator: {power_mw: 0.05, area_mm2: 6e-5}
)",
                                                     "test");
  EXPECT_NEAR(l.adc.power_at(6), 2.0 * 6 / 8, 1e-15);
  EXPECT_NEAR(l.adc.area_at(6), 0.0012, 1e-15);
  EXPECT_NEAR(l.dac.power_at(6), 0.25, 1e-15);  // exponential by default: 2^-2
  EXPECT_NEAR(l.dac.area_at(10), 16e-5, 1e-15);
  HardwareSettings hw;
  hw.adc_bits = 6;
  hw.dac_bits = 6;
  const MappingCost c = mapping_cost(10, 100, 1000, 1, hw, l);
  EXPECT_EQ(c.adcs, 2);  // 64 columns per ADC
  EXPECT_NEAR(c.total_power_mw, 1000 * 1e-4 + 2 * 1.5 + 10 * 0.25 + 0.05, 1e-12);
  EXPECT_THROW(parse_component_library("adc: {power_mw: -1}", "bad"), InputError);
  EXPECT_THROW(parse_component_library("gpu: {}", "bad"), InputError);
}

TEST(Overhead, Resnet20CliMatchesHandComputedPaperShapes) {
  const std::string out = "/tmp/xbarsim_overhead_test.json";
  const std::string cmd = std::string(XBARSIM_BINARY) +
                          " overhead --preset resnet20 --set mapping.max_rows=unbounded --set "
                          "mapping.max_cols=unbounded --json " + out + " > /dev/null 2>&1";
  ASSERT_EQ(std::system(cmd.c_str()), 0);
  std::ifstream in(out);
  const auto j = nlohmann::json::parse(in);
  struct Shape4 {
    int k, cin, cout, hw;
  } shapes[] = {{3, 3, 16, 32}, {3, 16, 16, 32}, {3, 32, 32, 16}, {3, 64, 64, 8}};
  for (const auto& s : shapes) {
    bool found = false;
    for (const auto& l : j["layers"]) {
      if (l["kernel"] != nlohmann::json({s.k, s.k, s.cin, s.cout}) || l["input"][0] != s.hw) continue;
      found = true;
      const long long rows = 9LL * s.cin, cols = s.cout;
      EXPECT_EQ(l["dense"]["rows"], rows);
      EXPECT_EQ(l["dense"]["cols"], cols);
      EXPECT_EQ(l["dense"]["adcs"], 1);
      EXPECT_EQ(l["dense"]["dacs"], rows);
      EXPECT_NEAR(l["dense"]["total_power_mw"].get<double>(), rows * cols * kCellP + 2 + rows, 1e-9);
      EXPECT_EQ(l["dense"]["iterations"], s.hw * s.hw);
      const long long srows = 1LL * s.hw * s.hw * s.cin, o = s.hw - 2, scols = o * o * s.cout;
      EXPECT_EQ(l["sparse"]["rows"], srows);
      EXPECT_EQ(l["sparse"]["cols"], scols);
      EXPECT_EQ(l["sparse"]["adcs"], (scols + 127) / 128);
      EXPECT_NEAR(l["sparse"]["total_area_mm2"].get<double>(),
                  srows * scols * kCellA + (scols + 127) / 128 * 0.0012 + srows * 4.25e-5, 1e-9);
      break;
    }
    EXPECT_TRUE(found) << s.cin << "x" << s.cout;
  }
  EXPECT_EQ(j["totals"]["dense"]["iterations"], 9089);  // the paper's ResNet-20 count
}

TEST(Presets, MatchTheSharedOnnxTopologies) {
  std::string dir;
  try {
    dir = resolve_models_dir(ConfigTree());
  } catch (const InputError&) {
    GTEST_SKIP() << "shared data directory not found; test skipped";
  }
  for (const char* name : {"lenet", "resnet20", "resnet32", "resnet56"}) {
    const std::string file = std::string(name) == "lenet" ? "lenet_mnist" : std::string(name) + "_cifar10";
    Model onnx;
    try {
      onnx = load_onnx_model(dir + "/" + file + ".onnx");
    } catch (const InputError&) {
      GTEST_SKIP() << "shared models not found; test skipped";
    }
    const Model p = make_preset(name);
    ASSERT_EQ(p.linear.size(), onnx.linear.size()) << name;
    // The same op sequence (ONNX slices H and W in two Slice nodes, the preset in one).
    auto kinds = [](const Model& m) {
      std::vector<OpKind> k;
      for (const auto& op : m.ops)
        if (op.kind != OpKind::Slice) k.push_back(op.kind);
      return k;
    };
    EXPECT_EQ(kinds(p), kinds(onnx)) << name;
    for (size_t k = 0; k < p.linear.size(); ++k) {
      const auto &a = p.linear[k], &b = onnx.linear[k];
      EXPECT_EQ(std::make_tuple(a.k_h, a.k_w, a.c_in, a.c_out, a.stride_h, a.pad_t, a.in.h, a.out.h),
                std::make_tuple(b.k_h, b.k_w, b.c_in, b.c_out, b.stride_h, b.pad_t, b.in.h, b.out.h))
          << name << " layer " << k;
    }
  }
}
