#pragma once
// A tiny CIFAR-shaped network and data set written by the tests themselves, so that the
// command-line tests of whole runs (eval, explore, simulate) need no shared data: a 3x32x32
// input, Conv 3x3/2 (4 channels) -> Relu -> MaxPool 3x3/3 -> Flatten -> Gemm (100 -> 10), with
// deterministic weights, and CIFAR-10 binary files of `images` records of deterministic pixels.
#include <sys/stat.h>

#include <cstdint>
#include <fstream>
#include <initializer_list>
#include <string>
#include <utility>
#include <vector>

#include "tests/onnx_builder.h"

namespace xbarsim_test {

namespace tiny_detail {

/// Weights in [-0.25, 0.25) from a linear congruential stream of seed `salt`.
inline void init(onnx::GraphProto* g, const std::string& name, std::initializer_list<int64_t> dims, unsigned salt) {
  uint32_t s = 12345u + salt;
  onnx_builder::float_init(g, name, dims, [&](size_t) {
    s = s * 1664525u + 1013904223u;
    return (static_cast<float>(s >> 8) / 16777216.0f - 0.5f) * 0.5f;
  });
}

}  // namespace tiny_detail

/// Writes the tiny network to `path` (metadata: dataset cifar10 and its preprocessing); another
/// `variant` gives other weights.
inline void write_tiny_model(const std::string& path, unsigned variant = 0) {
  using namespace onnx_builder;
  using tiny_detail::init;
  onnx::ModelProto m = model("tiny", "xbarsim tests");
  auto* g = m.mutable_graph();
  io(g->add_input(), "x", {1, 3, 32, 32});
  init(g, "w1", {4, 3, 3, 3}, 1 + 10 * variant);
  init(g, "b1", {4}, 2 + 10 * variant);
  init(g, "w2", {10, 100}, 3 + 10 * variant);
  init(g, "b2", {10}, 4 + 10 * variant);
  auto* c = node(g, "Conv", {"x", "w1", "b1"}, "c1");
  ints_attr(c, "kernel_shape", {3, 3});
  ints_attr(c, "strides", {2, 2});
  node(g, "Relu", {"c1"}, "r1");
  auto* p = node(g, "MaxPool", {"r1"}, "p1");
  ints_attr(p, "kernel_shape", {3, 3});
  ints_attr(p, "strides", {3, 3});
  node(g, "Flatten", {"p1"}, "f1");
  int_attr(node(g, "Gemm", {"f1", "w2", "b2"}, "y"), "transB", 1);
  io(g->add_output(), "y", {1, 10});
  for (const auto& kv : std::initializer_list<std::pair<const char*, const char*>>{
           {"dataset", "cifar10"}, {"input_scale", "1/255"}, {"input_mean", "0.5"}, {"input_std", "0.25"}})
    meta(m, kv.first, kv.second);
  std::ofstream f(path, std::ios::binary);
  m.SerializeToOstream(&f);
}

/// Writes `dir`/cifar10/test_batch.bin and calib_batch.bin, `images` records each.
inline void write_tiny_cifar(const std::string& dir, int images) {
  mkdir(dir.c_str(), 0755);
  mkdir((dir + "/cifar10").c_str(), 0755);
  for (const char* file : {"test_batch.bin", "calib_batch.bin"}) {
    std::ofstream f(dir + "/cifar10/" + file, std::ios::binary);
    uint32_t s = file[0] == 't' ? 7u : 11u;
    for (int k = 0; k < images; ++k) {
      f.put(static_cast<char>(k % 10));
      for (int i = 0; i < 3072; ++i) {
        s = s * 1103515245u + 12345u;
        f.put(static_cast<char>((s >> 16) & 0xff));
      }
    }
  }
}

}  // namespace xbarsim_test
