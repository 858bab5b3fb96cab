#include <onnx/onnx_pb.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <sstream>

#include "sw/common/errors.h"
#include "sw/nn/model.h"

namespace xbarsim {

namespace {

struct Init {
  std::vector<int64_t> dims;
  std::vector<float> f;
  std::vector<int64_t> i;
};

Init read_tensor(const onnx::TensorProto& t, const std::string& where) {
  Init out;
  for (auto d : t.dims()) out.dims.push_back(d);
  size_t count = 1;
  for (auto d : out.dims) count *= static_cast<size_t>(d);
  const std::string& raw = t.raw_data();
  switch (t.data_type()) {
    case onnx::TensorProto::FLOAT:
      if (!raw.empty()) {
        if (raw.size() != count * 4) throw InputError(where + ": tensor '" + t.name() + "' has a bad size");
        out.f.resize(count);
        std::memcpy(out.f.data(), raw.data(), raw.size());
      } else {
        out.f.assign(t.float_data().begin(), t.float_data().end());
      }
      break;
    case onnx::TensorProto::INT64:
      if (!raw.empty()) {
        if (raw.size() != count * 8) throw InputError(where + ": tensor '" + t.name() + "' has a bad size");
        out.i.resize(count);
        std::memcpy(out.i.data(), raw.data(), raw.size());
      } else {
        out.i.assign(t.int64_data().begin(), t.int64_data().end());
      }
      break;
    case onnx::TensorProto::INT32:
      for (auto v : t.int32_data()) out.i.push_back(v);
      if (!raw.empty()) {
        std::vector<int32_t> tmp(raw.size() / 4);
        std::memcpy(tmp.data(), raw.data(), raw.size());
        out.i.assign(tmp.begin(), tmp.end());
      }
      break;
    default:
      throw InputError(where + ": tensor '" + t.name() + "' has unsupported data type " +
                       std::to_string(t.data_type()));
  }
  return out;
}

Op make_op(OpKind kind, const std::string& name, std::vector<int> in) {
  Op op;
  op.kind = kind;
  op.name = name;
  op.in = std::move(in);
  return op;
}

class Loader {
 public:
  Loader(const onnx::ModelProto& m, const std::string& path, Model& model) : m_(m), path_(path), model_(model) {}

  void run(Shape input_override) {
    const auto& g = m_.graph();
    for (const auto& t : g.initializer()) inits_[t.name()] = read_tensor(t, path_);
    // Graph input: the first input that is not an initializer.
    std::string input_name;
    for (const auto& in : g.input())
      if (!inits_.count(in.name())) {
        input_name = in.name();
        Shape s;
        const auto& dims = in.type().tensor_type().shape().dim();
        if (dims.size() == 4) {
          s.c = static_cast<int>(dims[1].dim_value());
          s.h = static_cast<int>(dims[2].dim_value());
          s.w = static_cast<int>(dims[3].dim_value());
        }
        if (input_override.c > 0) s = input_override;
        if (s.c <= 0 || s.h <= 0 || s.w <= 0)
          throw InputError(path_ + ": input '" + in.name() + "' must be N x C x H x W with known C, H, W");
        model_.input = s;
        break;
      }
    if (input_name.empty()) throw InputError(path_ + ": the graph has no input");
    define(input_name, model_.input);
    for (const auto& node : g.node()) add_node(node);
    if (g.output_size() != 1) throw InputError(path_ + ": expected exactly one graph output");
    model_.output = value(g.output(0).name(), "graph output");
  }

 private:
  std::string where(const onnx::NodeProto& n) const {
    return path_ + ": node '" + n.name() + "' (" + n.op_type() + ")";
  }
  int define(const std::string& name, Shape s) {
    ids_[name] = static_cast<int>(model_.values.size());
    model_.values.push_back(s);
    return ids_[name];
  }
  int value(const std::string& name, const std::string& ctx) const {
    auto it = ids_.find(name);
    if (it == ids_.end()) throw InputError(ctx + ": input '" + name + "' is not computed by an earlier node");
    return it->second;
  }
  const Init& init(const std::string& name, const std::string& ctx) const {
    auto it = inits_.find(name);
    if (it == inits_.end()) throw InputError(ctx + ": '" + name + "' must be a constant initializer");
    return it->second;
  }
  static const onnx::AttributeProto* attr(const onnx::NodeProto& n, const char* name) {
    for (const auto& a : n.attribute())
      if (a.name() == name) return &a;
    return nullptr;
  }
  static std::vector<int64_t> ints(const onnx::NodeProto& n, const char* name, std::vector<int64_t> dflt) {
    const auto* a = attr(n, name);
    if (!a) return dflt;
    return std::vector<int64_t>(a->ints().begin(), a->ints().end());
  }
  static int64_t int_attr(const onnx::NodeProto& n, const char* name, int64_t dflt) {
    const auto* a = attr(n, name);
    return a ? a->i() : dflt;
  }
  static float float_attr(const onnx::NodeProto& n, const char* name, float dflt) {
    const auto* a = attr(n, name);
    return a ? a->f() : dflt;
  }
  void reject(const onnx::NodeProto& n, const std::string& what) const {
    throw InputError(where(n) + ": unsupported " + what);
  }
  void check_known_attrs(const onnx::NodeProto& n, std::initializer_list<const char*> known) const {
    for (const auto& a : n.attribute()) {
      bool ok = false;
      for (const char* k : known) ok = ok || a.name() == k;
      if (!ok) reject(n, "attribute '" + a.name() + "'");
    }
  }

  void add_linear(const onnx::NodeProto& n, LinearLayer L, int in_id, const std::vector<float>& w_oihw,
                  const std::vector<float>* bias) {
    L.name = n.name();
    L.in = model_.values[in_id];
    const int K = L.rows();
    L.weight.resize(K, L.c_out);
    for (int o = 0; o < L.c_out; ++o)
      for (int c = 0; c < L.c_in; ++c)
        for (int ky = 0; ky < L.k_h; ++ky)
          for (int kx = 0; kx < L.k_w; ++kx)
            L.weight((kx * L.k_h + ky) * L.c_in + c, o) =
                w_oihw[((static_cast<size_t>(o) * L.c_in + c) * L.k_h + ky) * L.k_w + kx];
    L.bias = Eigen::VectorXf::Zero(L.c_out);
    if (bias) {
      if (static_cast<int>(bias->size()) != L.c_out) reject(n, "bias length");
      for (int o = 0; o < L.c_out; ++o) L.bias(o) = (*bias)[o];
    }
    Op op = make_op(OpKind::Linear, n.name(), {in_id});
    op.linear = static_cast<int>(model_.linear.size());
    op.out = define(n.output(0), L.out);
    model_.linear.push_back(std::move(L));
    model_.ops.push_back(op);
  }

  void add_node(const onnx::NodeProto& n) {
    const std::string& t = n.op_type();
    const std::string ctx = where(n);
    if (t == "Constant") {
      const auto* a = attr(n, "value");
      if (!a) reject(n, "Constant without a tensor 'value'");
      inits_[n.output(0)] = read_tensor(a->t(), ctx);
      return;
    }
    if (n.input_size() < 1) reject(n, "node without inputs");
    if (t == "Conv") {
      check_known_attrs(n, {"dilations", "group", "kernel_shape", "pads", "strides", "auto_pad"});
      const auto* ap = attr(n, "auto_pad");
      if (ap && ap->s() != "NOTSET") reject(n, "auto_pad '" + ap->s() + "'");
      if (int_attr(n, "group", 1) != 1) reject(n, "group != 1");
      for (auto d : ints(n, "dilations", {1, 1}))
        if (d != 1) reject(n, "dilation != 1");
      const int in_id = value(n.input(0), ctx);
      const Init& w = init(n.input(1), ctx);
      if (w.dims.size() != 4) reject(n, "weight rank");
      LinearLayer L;
      L.c_out = static_cast<int>(w.dims[0]);
      L.c_in = static_cast<int>(w.dims[1]);
      L.k_h = static_cast<int>(w.dims[2]);
      L.k_w = static_cast<int>(w.dims[3]);
      const Shape in = model_.values[in_id];
      if (in.c != L.c_in) reject(n, "input channels (" + std::to_string(in.c) + ") != weight channels");
      const auto s = ints(n, "strides", {1, 1});
      const auto p = ints(n, "pads", {0, 0, 0, 0});
      if (s.size() != 2 || p.size() != 4) reject(n, "strides/pads rank");
      L.stride_h = static_cast<int>(s[0]);
      L.stride_w = static_cast<int>(s[1]);
      L.pad_t = static_cast<int>(p[0]);
      L.pad_l = static_cast<int>(p[1]);
      L.pad_b = static_cast<int>(p[2]);
      L.pad_r = static_cast<int>(p[3]);
      L.out = {L.c_out, (in.h + L.pad_t + L.pad_b - L.k_h) / L.stride_h + 1,
               (in.w + L.pad_l + L.pad_r - L.k_w) / L.stride_w + 1};
      if (L.out.h < 1 || L.out.w < 1) reject(n, "kernel larger than the padded input");
      const std::vector<float>* b = n.input_size() > 2 && !n.input(2).empty() ? &init(n.input(2), ctx).f : nullptr;
      add_linear(n, std::move(L), in_id, w.f, b);
    } else if (t == "Gemm" || t == "MatMul") {
      if (t == "Gemm") {
        check_known_attrs(n, {"alpha", "beta", "transA", "transB"});
        if (int_attr(n, "transA", 0) != 0) reject(n, "transA = 1");
      } else {
        check_known_attrs(n, {});
      }
      const int in_id = value(n.input(0), ctx);
      const Shape in = model_.values[in_id];
      if (in.h != 1 || in.w != 1) reject(n, "input that is not a flat vector (insert Flatten)");
      const Init& w = init(n.input(1), ctx);
      if (w.dims.size() != 2) reject(n, "weight rank");
      const bool trans_b = t == "Gemm" && int_attr(n, "transB", 0) != 0;
      const int K = static_cast<int>(trans_b ? w.dims[1] : w.dims[0]);
      const int N = static_cast<int>(trans_b ? w.dims[0] : w.dims[1]);
      if (K != in.c) reject(n, "inner dimension " + std::to_string(K) + " vs input " + std::to_string(in.c));
      const float alpha = t == "Gemm" ? float_attr(n, "alpha", 1.0f) : 1.0f;
      const float beta = t == "Gemm" ? float_attr(n, "beta", 1.0f) : 1.0f;
      std::vector<float> w_oi(static_cast<size_t>(N) * K);  // as OIHW with H = W = 1
      for (int o = 0; o < N; ++o)
        for (int k = 0; k < K; ++k)
          w_oi[static_cast<size_t>(o) * K + k] =
              alpha * (trans_b ? w.f[static_cast<size_t>(o) * K + k] : w.f[static_cast<size_t>(k) * N + o]);
      std::vector<float> bias;
      if (n.input_size() > 2 && !n.input(2).empty()) {
        const Init& c = init(n.input(2), ctx);
        if (c.f.size() != static_cast<size_t>(N)) reject(n, "bias that is not a vector of length N");
        for (float v : c.f) bias.push_back(beta * v);
      }
      LinearLayer L;
      L.is_conv = false;
      L.c_in = K;
      L.c_out = N;
      L.out = {N, 1, 1};
      add_linear(n, std::move(L), in_id, w_oi, bias.empty() ? nullptr : &bias);
    } else if (t == "Relu") {
      check_known_attrs(n, {});
      const int in_id = value(n.input(0), ctx);
      Op op = make_op(OpKind::Relu, n.name(), {in_id});
      op.out = define(n.output(0), model_.values[in_id]);
      model_.ops.push_back(op);
    } else if (t == "Add") {
      check_known_attrs(n, {});
      const int a = value(n.input(0), ctx), b = value(n.input(1), ctx);
      if (!(model_.values[a] == model_.values[b])) reject(n, "broadcasting (inputs of different shapes)");
      Op op = make_op(OpKind::Add, n.name(), {a, b});
      op.out = define(n.output(0), model_.values[a]);
      model_.ops.push_back(op);
    } else if (t == "MaxPool" || t == "AveragePool") {
      check_known_attrs(n, {"kernel_shape", "strides", "pads", "ceil_mode", "dilations", "storage_order",
                            "count_include_pad", "auto_pad"});
      const auto* ap = attr(n, "auto_pad");
      if (ap && ap->s() != "NOTSET") reject(n, "auto_pad '" + ap->s() + "'");
      if (int_attr(n, "ceil_mode", 0) != 0) reject(n, "ceil_mode = 1");
      if (int_attr(n, "count_include_pad", 0) != 0) reject(n, "count_include_pad = 1");
      for (auto d : ints(n, "dilations", {1, 1}))
        if (d != 1) reject(n, "dilation != 1");
      const int in_id = value(n.input(0), ctx);
      const Shape in = model_.values[in_id];
      const auto k = ints(n, "kernel_shape", {});
      const auto s = ints(n, "strides", {1, 1});
      const auto p = ints(n, "pads", {0, 0, 0, 0});
      if (k.size() != 2 || s.size() != 2 || p.size() != 4) reject(n, "kernel/strides/pads rank");
      Op op = make_op(t == "MaxPool" ? OpKind::MaxPool : OpKind::AvgPool, n.name(), {in_id});
      op.k_h = static_cast<int>(k[0]);
      op.k_w = static_cast<int>(k[1]);
      op.s_h = static_cast<int>(s[0]);
      op.s_w = static_cast<int>(s[1]);
      op.p_t = static_cast<int>(p[0]);
      op.p_l = static_cast<int>(p[1]);
      op.p_b = static_cast<int>(p[2]);
      op.p_r = static_cast<int>(p[3]);
      const Shape out{in.c, (in.h + op.p_t + op.p_b - op.k_h) / op.s_h + 1, (in.w + op.p_l + op.p_r - op.k_w) / op.s_w + 1};
      if (out.h < 1 || out.w < 1) reject(n, "pooling window larger than the input");
      op.out = define(n.output(0), out);
      model_.ops.push_back(op);
    } else if (t == "GlobalAveragePool") {
      check_known_attrs(n, {});
      const int in_id = value(n.input(0), ctx);
      Op op = make_op(OpKind::GlobalAvgPool, n.name(), {in_id});
      op.out = define(n.output(0), Shape{model_.values[in_id].c, 1, 1});
      model_.ops.push_back(op);
    } else if (t == "Flatten" || t == "Reshape") {
      const int in_id = value(n.input(0), ctx);
      const Shape in = model_.values[in_id];
      Shape out{in.size(), 1, 1};
      if (t == "Flatten") {
        check_known_attrs(n, {"axis"});
        if (int_attr(n, "axis", 1) != 1) reject(n, "axis != 1");
      } else {
        check_known_attrs(n, {"allowzero"});
        const Init& sh = init(n.input(1), ctx);
        std::vector<int64_t> d = sh.i;
        if (d.size() == 2 || d.size() == 4) {
          int64_t known = 1, infer = -1;
          for (size_t q = 1; q < d.size(); ++q) {
            if (d[q] == 0) d[q] = q == 1 ? in.c : q == 2 ? in.h : in.w;
            if (d[q] == -1)
              infer = static_cast<int64_t>(q);
            else
              known *= d[q];
          }
          if (infer > 0) d[infer] = in.size() / known;
          out = d.size() == 2 ? Shape{static_cast<int>(d[1]), 1, 1}
                              : Shape{static_cast<int>(d[1]), static_cast<int>(d[2]), static_cast<int>(d[3])};
        } else {
          reject(n, "target rank (only N x K or N x C x H x W)");
        }
        if (out.size() != in.size()) reject(n, "reshape that changes the element count");
      }
      // Data stay in C, H, W order: a pure relabelling of the shape.
      Op op = make_op(OpKind::Flatten, n.name(), {in_id});
      op.out = define(n.output(0), out);
      model_.ops.push_back(op);
    } else if (t == "Slice") {
      check_known_attrs(n, {});
      const int in_id = value(n.input(0), ctx);
      const Shape in = model_.values[in_id];
      const Init& st = init(n.input(1), ctx);
      const Init& en = init(n.input(2), ctx);
      std::vector<int64_t> axes;
      if (n.input_size() > 3 && !n.input(3).empty()) axes = init(n.input(3), ctx).i;
      for (size_t q = axes.size(); q < st.i.size(); ++q) axes.push_back(static_cast<int64_t>(q));
      std::vector<int64_t> steps(st.i.size(), 1);
      if (n.input_size() > 4 && !n.input(4).empty()) steps = init(n.input(4), ctx).i;
      Op op = make_op(OpKind::Slice, n.name(), {in_id});
      const int dims[3] = {in.c, in.h, in.w};
      int out_dims[3] = {in.c, in.h, in.w};
      for (size_t q = 0; q < st.i.size(); ++q) {
        int64_t ax = axes[q] < 0 ? axes[q] + 4 : axes[q];
        if (ax == 0) {
          if (st.i[q] != 0 || steps[q] != 1) reject(n, "slicing of the batch axis");
          continue;
        }
        if (ax < 1 || ax > 3) reject(n, "axis " + std::to_string(axes[q]));
        if (steps[q] < 1) reject(n, "step < 1");
        const int d = dims[ax - 1];
        auto clampi = [&](int64_t v) { return std::max<int64_t>(0, std::min<int64_t>(d, v < 0 ? v + d : v)); };
        const int64_t b = clampi(st.i[q]), e = clampi(en.i[q]);
        op.start[ax - 1] = static_cast<int>(b);
        op.step[ax - 1] = static_cast<int>(steps[q]);
        out_dims[ax - 1] = e > b ? static_cast<int>((e - b + steps[q] - 1) / steps[q]) : 0;
      }
      if (out_dims[0] < 1 || out_dims[1] < 1 || out_dims[2] < 1) reject(n, "empty slice");
      op.out = define(n.output(0), Shape{out_dims[0], out_dims[1], out_dims[2]});
      model_.ops.push_back(op);
    } else if (t == "Pad") {
      check_known_attrs(n, {"mode"});
      const auto* mode = attr(n, "mode");
      if (mode && mode->s() != "constant") reject(n, "mode '" + mode->s() + "'");
      const int in_id = value(n.input(0), ctx);
      const Shape in = model_.values[in_id];
      if (n.input_size() < 2) reject(n, "Pad without a pads input");
      const Init& p = init(n.input(1), ctx);
      if (p.i.size() != 8) reject(n, "pads that are not 4-D");
      if (p.i[0] != 0 || p.i[4] != 0) reject(n, "padding of the batch axis");
      Op op = make_op(OpKind::Pad, n.name(), {in_id});
      for (int q = 0; q < 3; ++q) {
        op.pad_lo[q] = static_cast<int>(p.i[1 + q]);
        op.pad_hi[q] = static_cast<int>(p.i[5 + q]);
        if (op.pad_lo[q] < 0 || op.pad_hi[q] < 0) reject(n, "negative pads");
      }
      if (n.input_size() > 2 && !n.input(2).empty()) {
        const Init& v = init(n.input(2), ctx);
        op.pad_value = v.f.empty() ? 0.0f : v.f[0];
      }
      op.out = define(n.output(0), Shape{in.c + op.pad_lo[0] + op.pad_hi[0], in.h + op.pad_lo[1] + op.pad_hi[1],
                                         in.w + op.pad_lo[2] + op.pad_hi[2]});
      model_.ops.push_back(op);
    } else if (t == "BatchNormalization") {
      check_known_attrs(n, {"epsilon", "momentum", "training_mode"});
      if (int_attr(n, "training_mode", 0) != 0) reject(n, "training_mode = 1");
      const int in_id = value(n.input(0), ctx);
      const Shape in = model_.values[in_id];
      const Init &sc = init(n.input(1), ctx), &b = init(n.input(2), ctx), &mu = init(n.input(3), ctx),
                 &var = init(n.input(4), ctx);
      const float eps = float_attr(n, "epsilon", 1e-5f);
      if (static_cast<int>(sc.f.size()) != in.c) reject(n, "parameter length");
      Op op = make_op(OpKind::Affine, n.name(), {in_id});
      op.scale.resize(in.c);
      op.shift.resize(in.c);
      for (int c = 0; c < in.c; ++c) {
        op.scale(c) = sc.f[c] / std::sqrt(var.f[c] + eps);
        op.shift(c) = b.f[c] - mu.f[c] * op.scale(c);
      }
      op.out = define(n.output(0), in);
      model_.ops.push_back(op);
    } else {
      reject(n, "operator (supported: Conv, Gemm, MatMul, BatchNormalization, Relu, Add, MaxPool, AveragePool, "
                "GlobalAveragePool, Flatten, Reshape, Slice, Pad, Constant)");
    }
  }

  const onnx::ModelProto& m_;
  std::string path_;
  Model& model_;
  std::map<std::string, Init> inits_;
  std::map<std::string, int> ids_;
};

}  // namespace

std::vector<double> parse_number_list(const std::string& s, const std::string& key, const std::string& path) {
  std::vector<double> out;
  std::stringstream ss(s);
  std::string item;
  while (std::getline(ss, item, ',')) {
    const auto slash = item.find('/');
    try {
      out.push_back(slash == std::string::npos ? std::stod(item)
                                               : std::stod(item.substr(0, slash)) / std::stod(item.substr(slash + 1)));
    } catch (const std::exception&) {
      throw InputError(path + ": '" + key + "' has a non-numeric entry '" + item + "'");
    }
  }
  return out;
}

Model load_onnx_model(const std::string& path, Shape input) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError("cannot open model '" + path + "'");
  onnx::ModelProto proto;
  if (!proto.ParseFromIstream(&in)) throw InputError("'" + path + "' is not a valid ONNX model");
  Model model;
  model.path = path;
  Loader(proto, path, model).run(input);
  for (const auto& p : proto.metadata_props()) model.metadata[p.key()] = p.value();
  auto meta = [&](const char* k) { return model.metadata.count(k) ? model.metadata[k] : std::string(); };
  if (!meta("input_scale").empty()) model.pre.scale = parse_number_list(meta("input_scale"), "input_scale", path).at(0);
  if (!meta("input_mean").empty()) model.pre.mean = parse_number_list(meta("input_mean"), "input_mean", path);
  if (!meta("input_std").empty()) model.pre.std = parse_number_list(meta("input_std"), "input_std", path);
  model.dataset = meta("dataset");
  if (!meta("software_accuracy_test_batch").empty())
    model.reference_accuracy = std::stod(meta("software_accuracy_test_batch"));
  return model;
}

}  // namespace xbarsim
