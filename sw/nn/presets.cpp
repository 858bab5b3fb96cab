#include "sw/nn/presets.h"

#include <cmath>
#include <random>

#include "sw/common/errors.h"

namespace xbarsim {

namespace {

class Builder {
 public:
  Builder(Model& m, uint64_t seed) : m_(m), rng_(seed) {}

  int input(Shape s) {
    m_.input = s;
    m_.values = {s};
    return 0;
  }
  int conv(int in, const std::string& name, int c_out, int k, int stride, int pad) {
    const Shape s = m_.values[in];
    LinearLayer L;
    L.name = name;
    L.c_in = s.c;
    L.c_out = c_out;
    L.k_h = L.k_w = k;
    L.stride_h = L.stride_w = stride;
    L.pad_t = L.pad_l = L.pad_b = L.pad_r = pad;
    L.in = s;
    L.out = {c_out, (s.h + 2 * pad - k) / stride + 1, (s.w + 2 * pad - k) / stride + 1};
    return linear(in, std::move(L));
  }
  int fc(int in, const std::string& name, int n) {
    LinearLayer L;
    L.name = name;
    L.is_conv = false;
    L.c_in = m_.values[in].size();
    L.c_out = n;
    L.in = {L.c_in, 1, 1};
    L.out = {n, 1, 1};
    return linear(in, std::move(L));
  }
  int op(OpKind kind, const std::string& name, std::vector<int> in, Shape out) {
    Op o;
    o.kind = kind;
    o.name = name;
    o.in = std::move(in);
    o.out = value(out);
    m_.ops.push_back(o);
    return o.out;
  }
  int pool(int in, const std::string& name, int k) {
    const Shape s = m_.values[in];
    Op o;
    o.kind = OpKind::MaxPool;
    o.name = name;
    o.in = {in};
    o.k_h = o.k_w = o.s_h = o.s_w = k;
    o.out = value({s.c, (s.h - k) / k + 1, (s.w - k) / k + 1});
    m_.ops.push_back(o);
    return o.out;
  }
  /// Option-A shortcut: x[:, :, ::2, ::2] then zero channel padding to c_out.
  int shortcut_a(int in, const std::string& name, int c_out) {
    const Shape s = m_.values[in];
    Op sl;
    sl.kind = OpKind::Slice;
    sl.name = name + "/Slice";
    sl.in = {in};
    sl.step[1] = sl.step[2] = 2;
    sl.out = value({s.c, (s.h + 1) / 2, (s.w + 1) / 2});
    m_.ops.push_back(sl);
    Op pd;
    pd.kind = OpKind::Pad;
    pd.name = name + "/Pad";
    pd.in = {sl.out};
    pd.pad_lo[0] = (c_out - s.c) / 2;
    pd.pad_hi[0] = c_out - s.c - pd.pad_lo[0];
    pd.out = value({c_out, (s.h + 1) / 2, (s.w + 1) / 2});
    m_.ops.push_back(pd);
    return pd.out;
  }

 private:
  int value(Shape s) {
    m_.values.push_back(s);
    return static_cast<int>(m_.values.size()) - 1;
  }
  int linear(int in, LinearLayer L) {
    const int K = L.rows();
    std::normal_distribution<float> n(0.0f, std::sqrt(2.0f / K));
    L.weight.resize(K, L.c_out);
    for (Eigen::Index k = 0; k < L.weight.size(); ++k) L.weight.data()[k] = n(rng_);
    L.bias = Eigen::VectorXf::Zero(L.c_out);
    Op o;
    o.kind = OpKind::Linear;
    o.name = L.name;
    o.in = {in};
    o.linear = static_cast<int>(m_.linear.size());
    o.out = value(L.out);
    m_.linear.push_back(std::move(L));
    m_.ops.push_back(o);
    return o.out;
  }
  Model& m_;
  std::mt19937_64 rng_;
};

}  // namespace

Model make_preset(const std::string& name, uint64_t seed) {
  Model m;
  m.path = "preset:" + name;
  Builder b(m, seed);
  if (name == "lenet") {
    int x = b.input({1, 28, 28});
    x = b.conv(x, "conv1", 20, 5, 1, 0);
    x = b.pool(x, "pool1", 2);
    x = b.conv(x, "conv2", 50, 5, 1, 0);
    x = b.pool(x, "pool2", 2);
    x = b.op(OpKind::Flatten, "flatten", {x}, {m.values[x].size(), 1, 1});
    x = b.fc(x, "ip1", 500);
    x = b.op(OpKind::Relu, "relu", {x}, m.values[x]);
    m.output = b.fc(x, "ip2", 10);
    m.dataset = "mnist";
    m.pre.scale = 1.0 / 256;
    return m;
  }
  int blocks = 0;
  if (name == "resnet20") blocks = 3;
  if (name == "resnet32") blocks = 5;
  if (name == "resnet56") blocks = 9;
  if (!blocks) throw InputError("unknown preset '" + name + "' (lenet, resnet20, resnet32, resnet56)");
  int x = b.input({3, 32, 32});
  x = b.conv(x, "conv1", 16, 3, 1, 1);
  x = b.op(OpKind::Relu, "relu", {x}, m.values[x]);
  const int widths[3] = {16, 32, 64};
  for (int stage = 0; stage < 3; ++stage)
    for (int k = 0; k < blocks; ++k) {
      const std::string p = "layer" + std::to_string(stage + 1) + "." + std::to_string(k);
      const int stride = stage > 0 && k == 0 ? 2 : 1;
      int y = b.conv(x, p + "/conv1", widths[stage], 3, stride, 1);
      y = b.op(OpKind::Relu, p + "/relu", {y}, m.values[y]);
      y = b.conv(y, p + "/conv2", widths[stage], 3, 1, 1);
      const int sc = stride == 2 ? b.shortcut_a(x, p + "/shortcut", widths[stage]) : x;
      y = b.op(OpKind::Add, p + "/add", {y, sc}, m.values[y]);
      x = b.op(OpKind::Relu, p + "/relu_1", {y}, m.values[y]);
    }
  x = b.op(OpKind::GlobalAvgPool, "gap", {x}, {64, 1, 1});
  x = b.op(OpKind::Flatten, "flatten", {x}, {64, 1, 1});
  m.output = b.fc(x, "linear", 10);
  m.dataset = "cifar10";
  m.pre.mean = {0.485, 0.456, 0.406};
  m.pre.std = {0.229, 0.224, 0.225};
  return m;
}

}  // namespace xbarsim
