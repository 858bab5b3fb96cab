// torchvision topologies exported by the tests themselves (tests/nn/torch_zoo.py, Debian's
// python3-torch and python3-torchvision; skipped with a message where absent): each imports,
// and xbarsim's software path reproduces torch's logits on a fixed input.
#include <gtest/gtest.h>

#include <cstdlib>
#include <string>

#include "sw/common/errors.h"
#include "sw/nn/network.h"
#include "sw/nn/npy.h"
#include "tests/nn/torch_zoo.h"

using namespace xbarsim;

namespace {

void expect_torch_logits(const std::string& dir, const std::string& name) {
  SCOPED_TRACE(name);
  const Model m = load_onnx_model(dir + "/" + name + ".onnx");
  const NpyArray x = read_npy(dir + "/" + name + ".input.npy"), want = read_npy(dir + "/" + name + ".logits.npy");
  ASSERT_EQ(x.elements(), m.input.size());
  std::vector<float> in(static_cast<size_t>(x.elements()));
  for (int64_t k = 0; k < x.elements(); ++k) in[static_cast<size_t>(k)] = static_cast<float>(x.at(k));
  SoftwareBackend sw(m);
  const Eigen::VectorXf y = run_image(m, in.data(), sw);
  ASSERT_EQ(y.size(), want.elements());
  double scale = 0;
  for (int64_t k = 0; k < want.elements(); ++k) scale = std::max(scale, std::abs(want.at(k)));
  for (int64_t k = 0; k < want.elements(); ++k)
    EXPECT_NEAR(y[k], want.at(k), 1e-4 * scale) << "logit " << k;
}

}  // namespace

// ResNet-18, MobileNetV2 (depthwise convolutions), SqueezeNet 1.1, DenseNet-121,
// ShuffleNetV2 (its channel shuffle: Shape, Gather, Reshape to 5-D, Transpose, Split),
// MobileNetV3-small (HardSwish as HardSigmoid then Mul, squeeze-excitation: a Mul of
// N x C x 1 x 1 by N x C x H x W) and torch_zoo.py's silu_se block (SiLU, squeeze-excitation,
// Sub and Div of two computed tensors) at 32 x 32.
TEST(TorchZoo, TorchvisionTopologiesAt32x32ImportAndGiveTorchsLogits) {
  const std::string py = xbarsim_test::torch_python();
  if (py.empty()) GTEST_SKIP() << "python3-torch / python3-torchvision not installed; test skipped";
  const std::string dir = ::testing::TempDir() + "xbarsim_zoo_32";
  const char* names[] = {"resnet18",           "mobilenet_v2",       "squeezenet1_1", "densenet121",
                         "shufflenet_v2_x0_5", "mobilenet_v3_small", "silu_se"};
  std::string list;
  for (const char* n : names) list += std::string(list.empty() ? "" : " ") + n;
  ASSERT_TRUE(xbarsim_test::export_zoo(py, dir, 32, list)) << "the export failed (see " << dir << "/export.log)";
  for (const char* n : names) expect_torch_logits(dir, n);
}

// One network at ImageNet size: SqueezeNet 1.1 at 224 x 224 (ceil-mode pooling, Concat).
TEST(TorchZoo, SqueezeNetAt224x224GivesTorchsLogits) {
  const std::string py = xbarsim_test::torch_python();
  if (py.empty()) GTEST_SKIP() << "python3-torch / python3-torchvision not installed; test skipped";
  const std::string dir = ::testing::TempDir() + "xbarsim_zoo_224";
  ASSERT_TRUE(xbarsim_test::export_zoo(py, dir, 224, "squeezenet1_1")) << "see " << dir << "/export.log";
  expect_torch_logits(dir, "squeezenet1_1");
}
