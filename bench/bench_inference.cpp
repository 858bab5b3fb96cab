// Per-image inference cost of the shared models: total and the part spent in the
// linear-layer multiplies. Run: build/bench/bench_inference [model.onnx] [images]
#include <chrono>
#include <iostream>

#include "sw/common/config.h"
#include "sw/nn/dataset.h"
#include "sw/nn/network.h"

using namespace xbarsim;

namespace {
struct TimedBackend : LinearBackend {
  explicit TimedBackend(const Model& m) : model(m) {}
  void multiply(int l, const RowMatrixXf& c, Eigen::MatrixXf& o) const override {
    const auto a = std::chrono::steady_clock::now();
    o.noalias() = c * model.linear[l].weight;
    seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - a).count();
  }
  const Model& model;
  mutable double seconds = 0;
};
}  // namespace

int main(int argc, char** argv) {
  const ConfigTree cfg;
  const std::string dir = resolve_data_dir(cfg);
  const std::string path = argc > 1 ? argv[1] : resolve_models_dir(cfg) + "/resnet20_cifar10.onnx";
  const int n = argc > 2 ? std::atoi(argv[2]) : 200;
  const Model m = load_onnx_model(path);
  const Dataset d = load_dataset(m.dataset, dir, "test", 0, n);
  TimedBackend b(m);
  std::vector<float> x(m.input.size());
  const auto t0 = std::chrono::steady_clock::now();
  for (int k = 0; k < d.count(); ++k) {
    d.preprocess(k, m.pre, x.data());
    run_image(m, x.data(), b);
  }
  const double total = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::cout << path << ": " << 1e3 * total / d.count() << " ms/image on one core, of which linear-layer GEMM "
            << 1e3 * b.seconds / d.count() << " ms (" << 100 * b.seconds / total << " %)\n";
}
