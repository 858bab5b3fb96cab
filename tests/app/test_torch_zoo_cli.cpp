// torchvision topologies through every command (issue 26): at 32 x 32, `overhead` and
// `simulate --timing-only` on ISAAC-CE cost every layer (grouped ones included) and every
// Mul of two tensors (MobileNetV3's HardSwish and squeeze-excitation, issue 39), and `eval`
// runs SqueezeNet 1.1, ShuffleNetV2 and MobileNetV3-small through crossbars on images the
// test writes.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "sw/nn/model.h"
#include "tests/app/cli_test_util.h"
#include "tests/app/tiny_network.h"
#include "tests/nn/torch_zoo.h"

namespace {

nlohmann::json read_json(const std::string& p) {
  std::ifstream in(p);
  return nlohmann::json::parse(in);
}

}  // namespace

TEST(TorchZooCli, EveryCommandCostsEveryLayerOfTheZoo) {
  const std::string py = xbarsim_test::torch_python();
  if (py.empty()) GTEST_SKIP() << "python3-torch / python3-torchvision not installed; test skipped";
  const std::string dir = ::testing::TempDir() + "xbarsim_zoo_cli";
  const std::vector<std::string> names = {"resnet18",    "mobilenet_v2",       "squeezenet1_1",
                                          "densenet121", "shufflenet_v2_x0_5", "mobilenet_v3_small"};
  std::string list;
  for (const std::string& n : names) list += (list.empty() ? "" : " ") + n;
  ASSERT_TRUE(xbarsim_test::export_zoo(py, dir, 32, list)) << "see " << dir << "/export.log";
  xbarsim_test::write_tiny_cifar(dir + "/data", 4);
  const std::string isaac = std::string(XBARSIM_SOURCE_DIR) + "/configs/isaac.yaml";
  for (const std::string& name : names) {
    SCOPED_TRACE(name);
    const std::string model = dir + "/" + name + ".onnx";
    const xbarsim::Model m = xbarsim::load_onnx_model(model);
    int grouped = 0;
    for (const auto& L : m.linear) grouped += L.group > 1;
    EXPECT_EQ(grouped > 0, name == "mobilenet_v2" || name == "shufflenet_v2_x0_5" || name == "mobilenet_v3_small");

    auto r = xbarsim_test::run_xbarsim("overhead --model " + model + " --json " + dir + "/o.json");
    ASSERT_EQ(r.code, 0) << r.out;
    const auto o = read_json(dir + "/o.json");
    ASSERT_EQ(o["layers"].size(), m.linear.size());
    for (size_t l = 0; l < m.linear.size(); ++l) {
      const auto& d = o["layers"][l]["dense"];
      EXPECT_EQ(o["layers"][l]["name"], m.linear[l].name);
      EXPECT_GT(d["crossbars"].get<double>(), 0);
      // A grouped layer uses 1/group of its block-diagonal matrix's cells.
      const double used = d["cells_used"].get<double>(), rows = d["rows"].get<double>();
      if (m.linear[l].group > 1) {
        EXPECT_LE(used, rows * m.linear[l].c_out / m.linear[l].group) << l;
      }
    }

    r = xbarsim_test::run_xbarsim("simulate --model " + model + " --config " + isaac + " --timing-only --json " + dir +
                                  "/s.json");
    ASSERT_EQ(r.code, 0) << r.out;
    const auto s = read_json(dir + "/s.json");
    ASSERT_EQ(s["layers"].size(), m.linear.size());
    for (const auto& layer : s["layers"]) {
      EXPECT_GT(layer["crossbars"].get<double>(), 0) << layer["name"];
      EXPECT_GT(layer["busy_us"].get<double>(), 0) << layer["name"];
      EXPECT_GT(layer["energy_uj"].get<double>(), 0) << layer["name"];
    }
    EXPECT_GT(s["throughput_images_per_s"].get<double>(), 0);
    // A Mul of two tensors: one operation per output element on ISAAC-CE's two sigmoid units
    // at 1.2 operations per ns each.
    std::map<std::string, long long> mul_elements;
    for (const xbarsim::Op& op : m.ops)
      if (op.kind == xbarsim::OpKind::Mul) mul_elements[op.name] = m.values[static_cast<size_t>(op.out)].size();
    EXPECT_EQ(mul_elements.empty(), name != "mobilenet_v3_small");
    int muls = 0;
    for (const auto& d : s["digital_stages"]) {
      if (d["operation"] != "mul") continue;
      ++muls;
      const double ops = static_cast<double>(mul_elements.at(d["name"].get<std::string>()));
      EXPECT_EQ(d["operations"].get<double>(), ops) << d["name"];
      EXPECT_NEAR(d["busy_us"].get<double>(), ops / 2.4 * 1e-3, 1e-6 * ops) << d["name"];
    }
    EXPECT_EQ(muls, static_cast<int>(mul_elements.size()));

    // The others take minutes.
    if (name != "squeezenet1_1" && name != "shufflenet_v2_x0_5" && name != "mobilenet_v3_small") continue;
    r = xbarsim_test::run_xbarsim("eval --model " + model + " --dataset cifar10 --images 2 --set data.dir=" + dir +
                                  "/data --set eval.calibration_images=4 --json " + dir + "/e.json");
    ASSERT_EQ(r.code, 0) << r.out;
    const auto e = read_json(dir + "/e.json");
    ASSERT_EQ(e["layers"].size(), m.linear.size());
    for (const auto& layer : e["layers"]) EXPECT_TRUE(std::isfinite(layer["mean_relative_error"].get<double>()));
  }
}
