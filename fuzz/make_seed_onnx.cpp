// Writes the tiny ONNX seed models of corpus/fuzz_onnx (weights are small deterministic
// numbers; nothing is taken from trained models). Usage: make_seed_onnx <output-dir>
#include <onnx/onnx_pb.h>

#include "tests/onnx_builder.h"

#include <cstdio>
#include <fstream>
#include <initializer_list>
#include <string>
#include <vector>

namespace {

using namespace onnx_builder;

/// Small deterministic weights: (i mod 7 - 3) / 4.
void add_float_init(onnx::GraphProto* g, const std::string& name, std::initializer_list<int64_t> dims) {
  float_init(g, name, dims, [](size_t i) { return static_cast<float>(static_cast<int>(i % 7) - 3) * 0.25f; });
}

onnx::ModelProto base(const char* name) { return model(name, "xbarsim make_seed_onnx"); }

// 1x1x4x4 -> Conv 3x3 (2 ch, pad 1) -> Relu -> MaxPool 2x2/2 -> Flatten -> Gemm (8 -> 3).
onnx::ModelProto small_cnn() {
  auto m = base("small_cnn");
  auto* g = m.mutable_graph();
  io(g->add_input(), "x", {1, 1, 4, 4});
  add_float_init(g, "w1", {2, 1, 3, 3});
  add_float_init(g, "b1", {2});
  add_float_init(g, "w2", {3, 8});
  add_float_init(g, "b2", {3});
  auto* c = node(g, "Conv", {"x", "w1", "b1"}, "c1");
  ints_attr(c, "kernel_shape", {3, 3});
  ints_attr(c, "pads", {1, 1, 1, 1});
  ints_attr(c, "strides", {1, 1});
  node(g, "Relu", {"c1"}, "r1");
  auto* p = node(g, "MaxPool", {"r1"}, "p1");
  ints_attr(p, "kernel_shape", {2, 2});
  ints_attr(p, "strides", {2, 2});
  node(g, "Flatten", {"p1"}, "f1");
  auto* gm = node(g, "Gemm", {"f1", "w2", "b2"}, "y");
  int_attr(gm, "transB", 1);
  // Gemm with transB: weight is N x K = 3 x 8.
  io(g->add_output(), "y", {1, 3});
  meta(m, "input_scale", "1/255");
  meta(m, "input_mean", "0.5");
  meta(m, "input_std", "0.25");
  meta(m, "dataset", "mnist");
  return m;
}

// 1x2x4x4 -> Pad -> BatchNorm -> Slice (H 1..5) -> Add(self) -> AveragePool 2x2 -> Reshape -> MatMul,
// plus a Constant-produced Reshape shape and a GlobalAveragePool side branch merged by Add.
onnx::ModelProto ops_mix() {
  auto m = base("ops_mix");
  auto* g = m.mutable_graph();
  io(g->add_input(), "x", {1, 2, 4, 4});
  int_init(g, "pads", {0, 0, 1, 1, 0, 0, 1, 1});
  add_float_init(g, "bn_s", {2});
  add_float_init(g, "bn_b", {2});
  add_float_init(g, "bn_m", {2});
  auto* var = g->add_initializer();
  var->set_name("bn_v");
  var->set_data_type(onnx::TensorProto::FLOAT);
  var->add_dims(2);
  var->add_float_data(1.0f);
  var->add_float_data(2.0f);
  int_init(g, "st", {1});
  int_init(g, "en", {5});
  int_init(g, "ax", {2});
  add_float_init(g, "wm", {8, 2});
  node(g, "Pad", {"x", "pads"}, "pd");
  node(g, "BatchNormalization", {"pd", "bn_s", "bn_b", "bn_m", "bn_v"}, "bn");
  node(g, "Slice", {"bn", "st", "en", "ax"}, "sl");
  node(g, "Add", {"sl", "sl"}, "ad");
  auto* ap = node(g, "AveragePool", {"ad"}, "ap");
  ints_attr(ap, "kernel_shape", {2, 3});
  ints_attr(ap, "strides", {2, 3});
  auto* cst = node(g, "Constant", {}, "shape");
  auto* a = cst->add_attribute();
  a->set_name("value");
  a->set_type(onnx::AttributeProto::TENSOR);
  a->mutable_t()->set_data_type(onnx::TensorProto::INT64);
  a->mutable_t()->add_dims(2);
  a->mutable_t()->add_int64_data(1);
  a->mutable_t()->add_int64_data(-1);
  node(g, "Reshape", {"ap", "shape"}, "rs");
  node(g, "MatMul", {"rs", "wm"}, "y");
  node(g, "GlobalAveragePool", {"x"}, "gap");
  io(g->add_output(), "y", {1, 2});
  meta(m, "software_accuracy_test_batch", "0.5");
  return m;
}

// 1x2x4x4 -> Conv 1x1 -> SiLU (Sigmoid, Mul) -> a squeeze-excitation (GlobalAveragePool,
// HardSigmoid, Mul of 1x2x1x1 by 1x2x4x4) -> Sub of the pooled value -> Div by a Sigmoid of one
// row (1x2x1x4) -> Flatten -> Gemm: the arithmetic of two computed values, broadcast.
onnx::ModelProto squeeze_excite() {
  auto m = base("squeeze_excite");
  auto* g = m.mutable_graph();
  io(g->add_input(), "x", {1, 2, 4, 4});
  add_float_init(g, "w1", {2, 2, 1, 1});
  add_float_init(g, "w2", {3, 32});
  int_init(g, "st", {0});
  int_init(g, "en", {1});
  int_init(g, "ax", {2});
  node(g, "Conv", {"x", "w1"}, "c");
  node(g, "Sigmoid", {"c"}, "sg");
  node(g, "Mul", {"c", "sg"}, "silu");
  node(g, "GlobalAveragePool", {"silu"}, "gap");
  node(g, "HardSigmoid", {"gap"}, "hs");
  node(g, "Mul", {"hs", "silu"}, "se");
  node(g, "Sub", {"se", "gap"}, "sb");
  node(g, "Slice", {"c", "st", "en", "ax"}, "row");
  node(g, "Sigmoid", {"row"}, "sr");
  node(g, "Div", {"sb", "sr"}, "dv");
  node(g, "Flatten", {"dv"}, "f");
  int_attr(node(g, "Gemm", {"f", "w2"}, "y"), "transB", 1);
  io(g->add_output(), "y", {1, 3});
  return m;
}

bool write(const onnx::ModelProto& m, const std::string& path) {
  std::ofstream out(path, std::ios::binary);
  return m.SerializeToOstream(&out);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: %s <output-dir>\n", argv[0]);
    return 2;
  }
  const std::string dir = argv[1];
  if (!write(small_cnn(), dir + "/small_cnn.onnx") || !write(ops_mix(), dir + "/ops_mix.onnx") ||
      !write(squeeze_excite(), dir + "/squeeze_excite.onnx")) {
    std::fprintf(stderr, "cannot write into %s\n", dir.c_str());
    return 1;
  }
  return 0;
}
