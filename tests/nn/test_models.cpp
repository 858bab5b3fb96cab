// The four shared ONNX models against PyTorch logits and recorded accuracies.
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>
#include <thread>

#include "sw/nn/dataset.h"
#include "sw/nn/network.h"
#include "tests/nn/nn_test_util.h"

using namespace xbarsim;

namespace {

struct RefRow {
  int index, label;
  std::vector<float> logits;
};

std::vector<RefRow> read_ref(const std::string& path) {
  std::ifstream in(path);
  std::vector<RefRow> rows;
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || !std::isdigit(static_cast<unsigned char>(line[0]))) continue;  // header
    std::stringstream ss(line);
    std::string cell;
    RefRow r;
    std::getline(ss, cell, ',');
    r.index = std::stoi(cell);
    std::getline(ss, cell, ',');
    r.label = std::stoi(cell);
    while (std::getline(ss, cell, ',')) r.logits.push_back(std::stof(cell));
    rows.push_back(r);
  }
  return rows;
}

const char* kModels[] = {"lenet_mnist", "resnet20_cifar10", "resnet32_cifar10", "resnet56_cifar10"};

}  // namespace

class SharedModel : public ::testing::TestWithParam<const char*> {};

TEST_P(SharedModel, LogitsMatchPyTorch) {
  REQUIRE_SHARED_DATA(dir);
  const std::string name = GetParam();
  const Model m = load_onnx_model(dir + "/../models/" + name + ".onnx");
  const auto ref = read_ref(dir + "/../models/" + name + ".ref.csv");
  ASSERT_EQ(ref.size(), 200u);
  const Dataset d = load_dataset(m.dataset, dir, "test", 0, 200);
  SoftwareBackend sw(m);
  std::vector<float> x(m.input.size());
  double worst = 0;
  for (const auto& r : ref) {
    ASSERT_EQ(d.labels[r.index], r.label);
    d.preprocess(r.index, m.pre, x.data());
    const Eigen::VectorXf logits = run_image(m, x.data(), sw);
    ASSERT_EQ(logits.size(), 10);
    for (int c = 0; c < 10; ++c) worst = std::max(worst, static_cast<double>(std::abs(logits(c) - r.logits[c])));
  }
  std::cout << "[ models ] " << name << ": max |logit - PyTorch| over 200 images = " << worst << "\n";
  EXPECT_LE(worst, 1e-4);
}

TEST_P(SharedModel, FullTestSetAccuracyMatchesMetadata) {
  REQUIRE_SHARED_DATA(dir);
  const std::string name = GetParam();
  const Model m = load_onnx_model(dir + "/../models/" + name + ".onnx");
  ASSERT_GT(m.reference_accuracy, 0);
  const Dataset d = load_dataset(m.dataset, dir, "test", 0, -1);
  ASSERT_EQ(d.count(), 10000);
  SoftwareBackend sw(m);
  std::vector<int> correct(2, 0);
  std::vector<std::thread> pool;
  for (int t = 0; t < 2; ++t)
    pool.emplace_back([&, t] {
      std::vector<float> x(m.input.size());
      for (int k = t; k < d.count(); k += 2) {
        d.preprocess(k, m.pre, x.data());
        Eigen::Index arg;
        run_image(m, x.data(), sw).maxCoeff(&arg);
        correct[t] += arg == d.labels[k];
      }
    });
  for (auto& th : pool) th.join();
  const double acc = (correct[0] + correct[1]) / 10000.0;
  std::cout << "[ models ] " << name << ": software accuracy " << acc << " (metadata " << m.reference_accuracy << ")\n";
  EXPECT_NEAR(acc, m.reference_accuracy, 0.0005);
}

INSTANTIATE_TEST_SUITE_P(Shared, SharedModel, ::testing::ValuesIn(kModels));
