#pragma once
// Building small ONNX models in code, for the tests (tests/app/tiny_network.h) and the fuzzer's
// seed generator (fuzz/make_seed_onnx.cpp): initializers, nodes, attributes, graph inputs and
// outputs, metadata. Opset 13, IR version 8.
#include <onnx/onnx_pb.h>

#include <cstdint>
#include <functional>
#include <initializer_list>
#include <string>
#include <vector>

namespace onnx_builder {

/// A model with an empty graph named `name`.
inline onnx::ModelProto model(const std::string& name, const std::string& producer) {
  onnx::ModelProto m;
  m.set_ir_version(8);
  m.set_producer_name(producer);
  auto* op = m.add_opset_import();
  op->set_domain("");
  op->set_version(13);
  m.mutable_graph()->set_name(name);
  return m;
}

/// A float initializer of shape `dims`, element i = value(i), stored as raw data.
inline void float_init(onnx::GraphProto* g, const std::string& name, std::initializer_list<int64_t> dims,
                       const std::function<float(size_t)>& value) {
  auto* t = g->add_initializer();
  t->set_name(name);
  t->set_data_type(onnx::TensorProto::FLOAT);
  size_t n = 1;
  for (auto d : dims) {
    t->add_dims(d);
    n *= static_cast<size_t>(d);
  }
  std::vector<float> v(n);
  for (size_t i = 0; i < n; ++i) v[i] = value(i);
  t->set_raw_data(std::string(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(float)));
}

/// A 1-D int64 initializer.
inline void int_init(onnx::GraphProto* g, const std::string& name, std::initializer_list<int64_t> vals) {
  auto* t = g->add_initializer();
  t->set_name(name);
  t->set_data_type(onnx::TensorProto::INT64);
  t->add_dims(static_cast<int64_t>(vals.size()));
  for (auto v : vals) t->add_int64_data(v);
}

/// A node `op` named op_out with inputs `in` and the one output `out`.
inline onnx::NodeProto* node(onnx::GraphProto* g, const std::string& op, std::initializer_list<const char*> in,
                             const std::string& out) {
  auto* n = g->add_node();
  n->set_op_type(op);
  n->set_name(op + "_" + out);
  for (const char* i : in) n->add_input(i);
  n->add_output(out);
  return n;
}

inline void ints_attr(onnx::NodeProto* n, const char* name, std::initializer_list<int64_t> v) {
  auto* a = n->add_attribute();
  a->set_name(name);
  a->set_type(onnx::AttributeProto::INTS);
  for (auto x : v) a->add_ints(x);
}

inline void int_attr(onnx::NodeProto* n, const char* name, int64_t v) {
  auto* a = n->add_attribute();
  a->set_name(name);
  a->set_type(onnx::AttributeProto::INT);
  a->set_i(v);
}

/// A float tensor of shape `dims` as a graph input or output.
inline void io(onnx::ValueInfoProto* v, const std::string& name, std::initializer_list<int64_t> dims) {
  v->set_name(name);
  auto* tt = v->mutable_type()->mutable_tensor_type();
  tt->set_elem_type(onnx::TensorProto::FLOAT);
  for (auto d : dims) tt->mutable_shape()->add_dim()->set_dim_value(d);
}

inline void meta(onnx::ModelProto& m, const char* key, const char* value) {
  auto* p = m.add_metadata_props();
  p->set_key(key);
  p->set_value(value);
}

}  // namespace onnx_builder
