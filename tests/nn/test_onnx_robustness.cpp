// Malformed ONNX models and dataset files, built by the test with the protobuf API: each
// must be an InputError naming the problem, never a crash, an out-of-bounds read or a
// silently wrong network.
#include <gtest/gtest.h>
#include <onnx/onnx_pb.h>

#include <cmath>
#include <fstream>
#include <functional>

#include "sw/common/errors.h"
#include "sw/nn/dataset.h"
#include "sw/nn/model.h"

using namespace xbarsim;

namespace {

void add_float(onnx::GraphProto& g, const std::string& name, std::vector<int64_t> dims, std::vector<float> v) {
  auto* t = g.add_initializer();
  t->set_name(name);
  t->set_data_type(onnx::TensorProto::FLOAT);
  for (auto d : dims) t->add_dims(d);
  for (float x : v) t->add_float_data(x);
}

void add_ints(onnx::GraphProto& g, const std::string& name, std::vector<int64_t> v) {
  auto* t = g.add_initializer();
  t->set_name(name);
  t->set_data_type(onnx::TensorProto::INT64);
  t->add_dims(static_cast<int64_t>(v.size()));
  for (auto x : v) t->add_int64_data(x);
}

void set_ints(onnx::NodeProto* n, const std::string& name, std::vector<int64_t> v) {
  auto* a = n->add_attribute();
  a->set_name(name);
  a->set_type(onnx::AttributeProto::INTS);
  for (auto x : v) a->add_ints(x);
}

onnx::NodeProto* add_node(onnx::GraphProto& g, const std::string& op, std::vector<std::string> in, std::string out) {
  auto* n = g.add_node();
  n->set_op_type(op);
  n->set_name(op + "_" + out);
  for (auto& s : in) n->add_input(s);
  n->add_output(out);
  return n;
}

/// x (1x1x4x4) -> Conv 2x1x3x3 pad 1 -> BatchNorm -> Relu -> MaxPool 2 -> Flatten -> Gemm 8->3.
onnx::ModelProto tiny_model() {
  onnx::ModelProto m;
  m.set_ir_version(7);
  m.add_opset_import()->set_version(13);
  onnx::GraphProto& g = *m.mutable_graph();
  auto* in = g.add_input();
  in->set_name("x");
  auto* shape = in->mutable_type()->mutable_tensor_type()->mutable_shape();
  in->mutable_type()->mutable_tensor_type()->set_elem_type(onnx::TensorProto::FLOAT);
  for (int d : {1, 1, 4, 4}) shape->add_dim()->set_dim_value(d);
  add_float(g, "w", {2, 1, 3, 3}, std::vector<float>(18, 0.1f));
  add_float(g, "b", {2}, {0.0f, 0.5f});
  for (const char* p : {"bn_s", "bn_b", "bn_m", "bn_v"}) add_float(g, p, {2}, {1.0f, 1.0f});
  add_float(g, "fc", {3, 8}, std::vector<float>(24, 0.2f));
  auto* conv = add_node(g, "Conv", {"x", "w", "b"}, "c");
  set_ints(conv, "pads", {1, 1, 1, 1});
  set_ints(conv, "strides", {1, 1});
  add_node(g, "BatchNormalization", {"c", "bn_s", "bn_b", "bn_m", "bn_v"}, "n");
  add_node(g, "Relu", {"n"}, "r");
  auto* pool = add_node(g, "MaxPool", {"r"}, "p");
  set_ints(pool, "kernel_shape", {2, 2});
  set_ints(pool, "strides", {2, 2});
  add_node(g, "Flatten", {"p"}, "f");
  auto* fc = add_node(g, "Gemm", {"f", "fc"}, "y");
  auto* tb = fc->add_attribute();
  tb->set_name("transB");
  tb->set_type(onnx::AttributeProto::INT);
  tb->set_i(1);
  g.add_output()->set_name("y");
  return m;
}

Model load(const onnx::ModelProto& m) { return load_onnx_model_from_bytes(m.SerializeAsString(), "crafted.onnx"); }

onnx::TensorProto* initializer(onnx::ModelProto& m, const std::string& name) {
  for (auto& t : *m.mutable_graph()->mutable_initializer())
    if (t.name() == name) return &t;
  return nullptr;
}
onnx::NodeProto* node(onnx::ModelProto& m, const std::string& op) {
  for (auto& n : *m.mutable_graph()->mutable_node())
    if (n.op_type() == op) return &n;
  return nullptr;
}
void set_attr(onnx::NodeProto* n, const std::string& name, std::vector<int64_t> v) {
  for (auto& a : *n->mutable_attribute())
    if (a.name() == name) {
      a.clear_ints();
      for (auto x : v) a.add_ints(x);
      return;
    }
  set_ints(n, name, v);
}

void expect_rejected(const std::function<void(onnx::ModelProto&)>& mutate, const std::string& part) {
  onnx::ModelProto m = tiny_model();
  mutate(m);
  try {
    load(m);
    ADD_FAILURE() << "expected InputError containing '" << part << "'";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(part), std::string::npos) << e.what();
  }
}

}  // namespace

TEST(OnnxRobustness, TheTinyModelLoads) {
  const Model m = load(tiny_model());
  ASSERT_EQ(m.linear.size(), 2u);
  EXPECT_EQ(m.linear[0].rows(), 9);
  EXPECT_EQ(m.linear[0].out.h, 4);
  EXPECT_EQ(m.linear[1].c_in, 8);
  EXPECT_EQ(m.linear[1].c_out, 3);
}

TEST(OnnxRobustness, ZeroOrNegativeStridesKernelsAndPads) {
  expect_rejected([](auto& m) { set_attr(node(m, "Conv"), "strides", {0, 1}); }, "strides");
  expect_rejected([](auto& m) { set_attr(node(m, "MaxPool"), "strides", {1, 0}); }, "strides");
  expect_rejected([](auto& m) { set_attr(node(m, "MaxPool"), "kernel_shape", {0, 2}); }, "kernel_shape");
  expect_rejected([](auto& m) { set_attr(node(m, "MaxPool"), "kernel_shape", {99999999999, 2}); }, "kernel_shape");
  expect_rejected([](auto& m) { set_attr(node(m, "Conv"), "pads", {-1, 1, 1, 1}); }, "pads");
  expect_rejected([](auto& m) { set_attr(node(m, "Conv"), "dilations", {0, 1}); }, "dilations");
}

TEST(OnnxRobustness, ShortWrongTypeAndNonFiniteInitializers) {
  expect_rejected([](auto& m) { initializer(m, "w")->mutable_float_data()->RemoveLast(); }, "holds 17 values");
  expect_rejected(
      [](auto& m) {
        auto* t = initializer(m, "w");
        t->clear_float_data();
        t->set_raw_data(std::string(17 * 4, '\0'));
      },
      "bytes of raw data");
  expect_rejected(
      [](auto& m) {
        auto* t = initializer(m, "w");
        t->clear_float_data();
        t->set_data_type(onnx::TensorProto::INT32);
        for (int k = 0; k < 18; ++k) t->add_int32_data(1);
      },
      "must hold float32");
  expect_rejected([](auto& m) { initializer(m, "fc")->mutable_float_data()->RemoveLast(); }, "'fc'");
  expect_rejected([](auto& m) { initializer(m, "bn_v")->mutable_float_data()->RemoveLast(); }, "'bn_v'");
  expect_rejected([](auto& m) { initializer(m, "w")->set_float_data(3, std::nanf("")); }, "non-finite");
  expect_rejected([](auto& m) { initializer(m, "b")->set_float_data(0, INFINITY); }, "non-finite");
  expect_rejected([](auto& m) { initializer(m, "w")->set_data_type(onnx::TensorProto::DOUBLE); }, "data type");
  expect_rejected([](auto& m) { initializer(m, "w")->set_dims(0, -2); }, "dims");
}

TEST(OnnxRobustness, NodesWithMissingInputsOrOutputs) {
  expect_rejected(
      [](auto& m) { node(m, "Conv")->mutable_input()->RemoveLast(), node(m, "Conv")->mutable_input()->RemoveLast(); },
      "needs 2 input");
  expect_rejected([](auto& m) { node(m, "BatchNormalization")->mutable_input()->RemoveLast(); }, "needs 5 input");
  expect_rejected([](auto& m) { node(m, "Relu")->clear_output(); }, "has no output");
  expect_rejected([](auto& m) { node(m, "Gemm")->mutable_input()->RemoveLast(); }, "needs 2 input");
}

TEST(OnnxRobustness, SliceAndReshapeArguments) {
  auto slice = [](onnx::ModelProto& m, std::vector<int64_t> starts, std::vector<int64_t> ends) {
    auto& g = *m.mutable_graph();
    add_ints(g, "st", starts);
    add_ints(g, "en", ends);
    node(m, "BatchNormalization")->set_input(0, "s");
    auto* sl = g.add_node();
    sl->set_op_type("Slice");
    sl->set_name("slice");
    sl->add_input("c");
    sl->add_input("st");
    sl->add_input("en");
    sl->add_output("s");
    // Keep topological order: move the Slice right after the Conv.
    for (int k = g.node_size() - 1; k > 1; --k) g.mutable_node()->SwapElements(k, k - 1);
  };
  expect_rejected([&](auto& m) { slice(m, {0, 0}, {1}); }, "different lengths");
  expect_rejected(
      [&](auto& m) {
        slice(m, {0}, {1});
        initializer(m, "st")->clear_int64_data();
      },
      "holds 0 values");
  auto reshape = [](onnx::ModelProto& m, std::vector<int64_t> shape) {
    auto& g = *m.mutable_graph();
    add_ints(g, "shape", shape);
    auto* f = node(m, "Flatten");
    f->set_op_type("Reshape");
    f->add_input("shape");
  };
  expect_rejected([&](auto& m) { reshape(m, {1, -2, 4, 1}); }, "target shape");
  expect_rejected([&](auto& m) { reshape(m, {1, 2, 2, 2, 1, 1, 1, 1, 1}); }, "target rank 9");
  expect_rejected([&](auto& m) { reshape(m, {1, -1, -1}); }, "target shape");
  expect_rejected([&](auto& m) { reshape(m, {1, 3}); }, "reshape to 3 elements of a value of 8");
}

TEST(OnnxRobustness, MetadataIsParsedWithCheckedConversions) {
  auto meta = [](onnx::ModelProto& m, const std::string& k, const std::string& v) {
    auto* p = m.add_metadata_props();
    p->set_key(k);
    p->set_value(v);
  };
  expect_rejected([&](auto& m) { meta(m, "input_scale", "1/0"); }, "input_scale");
  expect_rejected([&](auto& m) { meta(m, "input_std", "0"); }, "input_std");
  expect_rejected([&](auto& m) { meta(m, "input_mean", "nan"); }, "input_mean");
  expect_rejected([&](auto& m) { meta(m, "software_accuracy_test_batch", "abc"); }, "software_accuracy_test_batch");
  onnx::ModelProto ok = tiny_model();
  meta(ok, "input_scale", "1/255");
  EXPECT_DOUBLE_EQ(load(ok).pre.scale, 1.0 / 255);
}

TEST(DatasetRobustness, TruncatedAndImplausibleFilesAreInputErrors) {
  const std::string cifar = "/tmp/xbarsim_bad_cifar.bin";
  std::ofstream(cifar, std::ios::binary) << std::string(3073 + 100, '\0');
  EXPECT_THROW(load_cifar10(cifar), InputError);
  std::ofstream(cifar, std::ios::binary) << std::string(3073, '\x0b');  // label 11
  EXPECT_THROW(load_cifar10(cifar), InputError);
  auto be = [](uint32_t v) { return std::string{char(v >> 24), char(v >> 16), char(v >> 8), char(v)}; };
  const std::string im = "/tmp/xbarsim_bad_im.idx", lb = "/tmp/xbarsim_bad_lb.idx";
  std::ofstream(lb, std::ios::binary) << be(2049) + be(2) + std::string(2, '\0');
  std::ofstream(im, std::ios::binary) << be(2050) + be(2) + be(28) + be(28);  // wrong magic
  EXPECT_THROW(load_mnist(im, lb), InputError);
  std::ofstream(im, std::ios::binary) << be(2051) + be(2) + be(0xFFFFFFFF) + be(28);  // huge rows
  EXPECT_THROW(load_mnist(im, lb), InputError);
  std::ofstream(im, std::ios::binary) << be(2051) + be(2) + be(28) + be(28) + std::string(100, '\0');  // short
  EXPECT_THROW(load_mnist(im, lb), InputError);
  std::ofstream(im, std::ios::binary) << be(2051) + be(2) + be(2) + be(2) + std::string(8, '\0');
  std::ofstream(lb, std::ios::binary) << be(2049) + be(2) + std::string(1, '\0') + std::string(1, '\x0c');  // label 12
  EXPECT_THROW(load_mnist(im, lb), InputError);
}
