// Graph import and execution on small hand-built ONNX graphs, checked with direct loops.
#include <gtest/gtest.h>
#include <onnx/onnx_pb.h>

#include <fstream>
#include <functional>
#include <random>

#include "sw/common/errors.h"
#include "sw/nn/network.h"

using namespace xbarsim;

namespace {

void add_init(onnx::GraphProto* g, const std::string& name, std::vector<int64_t> dims, const std::vector<float>& v) {
  auto* t = g->add_initializer();
  t->set_name(name);
  t->set_data_type(onnx::TensorProto::FLOAT);
  for (auto d : dims) t->add_dims(d);
  for (float f : v) t->add_float_data(f);
}
void add_init_i64(onnx::GraphProto* g, const std::string& name, const std::vector<int64_t>& v) {
  auto* t = g->add_initializer();
  t->set_name(name);
  t->set_data_type(onnx::TensorProto::INT64);
  t->add_dims(static_cast<int64_t>(v.size()));
  for (auto x : v) t->add_int64_data(x);
}
onnx::NodeProto* add_node(onnx::GraphProto* g, const std::string& op, const std::string& name,
                          std::vector<std::string> in, std::string out) {
  auto* n = g->add_node();
  n->set_op_type(op);
  n->set_name(name);
  for (auto& s : in) n->add_input(s);
  n->add_output(out);
  return n;
}
void ints_attr(onnx::NodeProto* n, const std::string& name, std::vector<int64_t> v) {
  auto* a = n->add_attribute();
  a->set_name(name);
  a->set_type(onnx::AttributeProto::INTS);
  for (auto x : v) a->add_ints(x);
}
std::string save(onnx::ModelProto& m, int c, int h, int w, const std::string& out, const std::string& file) {
  auto* g = m.mutable_graph();
  auto* in = g->add_input();
  in->set_name("input");
  auto* shape = in->mutable_type()->mutable_tensor_type()->mutable_shape();
  for (int d : {1, c, h, w}) shape->add_dim()->set_dim_value(d);
  g->add_output()->set_name(out);
  const std::string path = "/tmp/xbarsim_test_" + file + ".onnx";
  std::ofstream f(path, std::ios::binary);
  m.SerializeToOstream(&f);
  return path;
}
std::vector<float> randv(size_t n, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<float> d(0, 1);
  std::vector<float> v(n);
  for (auto& x : v) x = d(rng);
  return v;
}

}  // namespace

// With dilations 1 and (2, 3): a dilated kernel maps as the dense kernel it spans.
TEST(Graph, ConvStridePadMatchesDirectLoops) {
  const int C = 3, H = 9, W = 10, O = 4, K = 3;
  for (const auto& dil : {std::vector<int64_t>{1, 1}, std::vector<int64_t>{2, 3}}) {
    SCOPED_TRACE(dil[1]);
    const int dh = static_cast<int>(dil[0]), dw = static_cast<int>(dil[1]);
    onnx::ModelProto m;
    auto* g = m.mutable_graph();
    const auto w = randv(O * C * K * K, 1), b = randv(O, 2);
    add_init(g, "w", {O, C, K, K}, w);
    add_init(g, "b", {O}, b);
    auto* n = add_node(g, "Conv", "conv", {"input", "w", "b"}, "y");
    ints_attr(n, "kernel_shape", {K, K});
    ints_attr(n, "strides", {2, 1});
    ints_attr(n, "pads", {1, 0, 1, 2});
    ints_attr(n, "dilations", dil);
    const Model model = load_onnx_model(save(m, C, H, W, "y", "conv"));
    const auto x = randv(C * H * W, 3);
    SoftwareBackend sw(model);
    const Eigen::VectorXf y = run_image(model, x.data(), sw);
    const int oh = (H + 2 - (K - 1) * dh - 1) / 2 + 1, ow = (W + 2 - (K - 1) * dw - 1) / 1 + 1;
    ASSERT_EQ(y.size(), O * oh * ow);
    for (int o = 0; o < O; ++o)
      for (int oy = 0; oy < oh; ++oy)
        for (int ox = 0; ox < ow; ++ox) {
          double s = b[o];
          for (int c = 0; c < C; ++c)
            for (int ky = 0; ky < K; ++ky)
              for (int kx = 0; kx < K; ++kx) {
                const int iy = oy * 2 - 1 + ky * dh, ix = ox - 0 + kx * dw;
                if (iy < 0 || iy >= H || ix < 0 || ix >= W) continue;
                s += w[((o * C + c) * K + ky) * K + kx] * x[(c * H + iy) * W + ix];
              }
          EXPECT_NEAR(y[(o * oh + oy) * ow + ox], s, 1e-4);
        }
  }
}

TEST(Graph, PoolSlicePadAddGemmBatchNorm) {
  const int C = 2, H = 6, W = 6;
  onnx::ModelProto m;
  auto* g = m.mutable_graph();
  // BN -> Relu -> MaxPool 2x2/2 -> Slice(::2 on H, W) -> Pad channels (1, 1) -> Add with itself
  // -> GlobalAveragePool -> Flatten -> Gemm (transB).
  add_init(g, "s", {C}, {2.0f, 0.5f});
  add_init(g, "bb", {C}, {0.1f, -0.2f});
  add_init(g, "mu", {C}, {0.3f, -0.1f});
  add_init(g, "var", {C}, {4.0f, 1.0f});
  add_node(g, "BatchNormalization", "bn", {"input", "s", "bb", "mu", "var"}, "a");
  add_node(g, "Relu", "relu", {"a"}, "r");
  auto* mp = add_node(g, "MaxPool", "mp", {"r"}, "p");
  ints_attr(mp, "kernel_shape", {2, 2});
  ints_attr(mp, "strides", {2, 2});
  add_init_i64(g, "st", {0, 0});
  add_init_i64(g, "en", {1000, 1000});
  add_init_i64(g, "ax", {2, 3});
  add_init_i64(g, "sp", {2, 2});
  add_node(g, "Slice", "sl", {"p", "st", "en", "ax", "sp"}, "q");
  add_init_i64(g, "pads", {0, 1, 0, 0, 0, 1, 0, 0});
  add_node(g, "Pad", "pad", {"q", "pads"}, "z");
  add_node(g, "Add", "add", {"z", "z"}, "zz");
  add_node(g, "GlobalAveragePool", "gap", {"zz"}, "gp");
  auto* fl = add_node(g, "Flatten", "fl", {"gp"}, "f");
  (void)fl;
  const auto wg = randv(3 * 4, 5);
  add_init(g, "wg", {3, 4}, wg);
  add_init(g, "bg", {3}, {1.0f, 2.0f, 3.0f});
  auto* gemm = add_node(g, "Gemm", "gemm", {"f", "wg", "bg"}, "out");
  auto* tb = gemm->add_attribute();
  tb->set_name("transB");
  tb->set_type(onnx::AttributeProto::INT);
  tb->set_i(1);
  const Model model = load_onnx_model(save(m, C, H, W, "out", "ops"));
  const auto x = randv(C * H * W, 6);
  SoftwareBackend sw(model);
  const Eigen::VectorXf y = run_image(model, x.data(), sw);
  // Direct computation.
  const float sc[2] = {2.0f / std::sqrt(4.0f + 1e-5f), 0.5f / std::sqrt(1.0f + 1e-5f)};
  float feat[4] = {0, 0, 0, 0};  // padded channels 0 and 3 are zero
  for (int c = 0; c < C; ++c) {
    double sum = 0;
    for (int py = 0; py < 3; py += 2)
      for (int px = 0; px < 3; px += 2) {
        float mx = -1e30f;
        for (int dy = 0; dy < 2; ++dy)
          for (int dx = 0; dx < 2; ++dx) {
            const float v = x[(c * H + py * 2 + dy) * W + px * 2 + dx];
            const float bn = (v - (c ? -0.1f : 0.3f)) * sc[c] + (c ? -0.2f : 0.1f);
            mx = std::max(mx, std::max(bn, 0.0f));
          }
        sum += 2 * mx;
      }
    feat[c + 1] = static_cast<float>(sum / 4);
  }
  for (int o = 0; o < 3; ++o) {
    double s = o + 1.0;
    for (int k = 0; k < 4; ++k) s += wg[o * 4 + k] * feat[k];
    EXPECT_NEAR(y[o], s, 1e-5);
  }
}

TEST(Graph, UnsupportedOpNamesNodeAndOp) {
  // Three unsupported nodes: one message names all three (and the supported set).
  onnx::ModelProto m;
  auto* g = m.mutable_graph();
  add_node(g, "LRN", "my_lrn", {"input"}, "a");
  add_node(g, "Relu", "ok_relu", {"a"}, "b");
  add_node(g, "Foo", "my_foo", {"b"}, "c");
  add_node(g, "GRU", "my_gru", {"c"}, "y");
  const std::string path = save(m, 1, 2, 2, "y", "bad");
  try {
    load_onnx_model(path);
    FAIL();
  } catch (const InputError& e) {
    const std::string w = e.what();
    for (const char* s : {"3 nodes have unsupported operators", "'my_lrn' (LRN)", "'my_foo' (Foo)", "'my_gru' (GRU)",
                          "supported: ", "Conv", "Concat"})
      EXPECT_NE(w.find(s), std::string::npos) << s << " in: " << w;
    EXPECT_EQ(w.find("ok_relu"), std::string::npos) << w;
  }
  onnx::ModelProto m2;
  auto* g2 = m2.mutable_graph();
  add_init(g2, "w", {2, 1, 1, 1}, {1, 2});
  auto* n = add_node(g2, "Conv", "grouped", {"input", "w"}, "y");
  auto* a = n->add_attribute();
  a->set_name("group");
  a->set_type(onnx::AttributeProto::INT);
  a->set_i(2);
  EXPECT_THROW(load_onnx_model(save(m2, 1, 2, 2, "y", "bad2")), InputError);
  EXPECT_THROW(load_onnx_model("/nonexistent.onnx"), InputError);
}

// The operators of standard CNNs (issue 26), each against its formula: Clip, Sigmoid, Tanh,
// LeakyRelu, HardSigmoid, HardSwish, Concat, Mul/Div/Sub by constants, Identity, Dropout,
// ReduceMean, MatMul + Add (the bias folded into the layer) and Softmax.
TEST(Graph, ActivationsConcatConstantsReduceMeanMatMulAddSoftmax) {
  const int H = 3, W = 4;
  onnx::ModelProto m;
  auto* g = m.mutable_graph();
  const auto wc = randv(2 * 2, 11), bc = randv(2, 12);
  add_init(g, "wc", {2, 2, 1, 1}, wc);
  add_init(g, "bc", {2}, bc);
  add_node(g, "Conv", "conv", {"input", "wc", "bc"}, "a");
  add_init(g, "lo", {}, {0.0f});
  add_init(g, "hi", {}, {0.5f});
  add_node(g, "Clip", "clip", {"a", "lo", "hi"}, "c1");
  add_node(g, "Sigmoid", "sig", {"a"}, "c2");
  add_node(g, "Tanh", "tanh", {"a"}, "c3");
  auto* lr = add_node(g, "LeakyRelu", "leaky", {"a"}, "c4");
  auto* al = lr->add_attribute();
  al->set_name("alpha");
  al->set_type(onnx::AttributeProto::FLOAT);
  al->set_f(0.1f);
  add_node(g, "HardSigmoid", "hsig", {"a"}, "c5");
  add_node(g, "HardSwish", "hswish", {"a"}, "c6");
  add_node(g, "Concat", "cat", {"c1", "c2", "c3", "c4", "c5", "c6"}, "cat")->add_attribute()->set_name("axis");
  g->mutable_node(g->node_size() - 1)->mutable_attribute(0)->set_type(onnx::AttributeProto::INT);
  g->mutable_node(g->node_size() - 1)->mutable_attribute(0)->set_i(1);
  add_init(g, "two", {}, {2.0f});
  add_node(g, "Mul", "mul", {"cat", "two"}, "m");
  std::vector<float> div(12);
  for (int c = 0; c < 12; ++c) div[c] = 1.0f + 0.25f * c;
  add_init(g, "div", {1, 12, 1, 1}, div);
  add_node(g, "Div", "div", {"m", "div"}, "d");
  add_init(g, "one", {1}, {1.0f});
  add_node(g, "Sub", "sub", {"d", "one"}, "s");
  add_node(g, "Identity", "id", {"s"}, "i");
  add_node(g, "Dropout", "drop", {"i"}, "dr");
  auto* rm = add_node(g, "ReduceMean", "mean", {"dr"}, "rm");
  ints_attr(rm, "axes", {2, 3});
  add_node(g, "Flatten", "flat", {"rm"}, "f");
  const auto wm = randv(12 * 3, 13);
  add_init(g, "wm", {12, 3}, wm);
  add_node(g, "MatMul", "mm", {"f", "wm"}, "mm");
  add_init(g, "bm", {3}, {0.5f, -1.0f, 2.0f});
  add_node(g, "Add", "bias", {"mm", "bm"}, "logits");
  add_node(g, "Softmax", "softmax", {"logits"}, "out");
  const Model model = load_onnx_model(save(m, 2, H, W, "out", "ops26"));
  // The bias is the MatMul layer's, not a digital op; Mul, Div and Sub are affine ops.
  ASSERT_EQ(model.linear.size(), 2u);
  EXPECT_FLOAT_EQ(model.linear[1].bias(1), -1.0f);
  int affine = 0;
  for (const Op& op : model.ops) affine += op.kind == OpKind::Affine;
  EXPECT_EQ(affine, 3);
  const auto x = randv(2 * H * W, 14);
  SoftwareBackend sw(model);
  const Eigen::VectorXf y = run_image(model, x.data(), sw);
  // Direct computation.
  std::vector<double> feat(12, 0.0);
  for (int p = 0; p < H * W; ++p)
    for (int o = 0; o < 2; ++o) {
      double a = bc[o];
      for (int c = 0; c < 2; ++c) a += wc[o * 2 + c] * x[c * H * W + p];
      const double f[6] = {std::min(std::max(a, 0.0), 0.5),
                           1 / (1 + std::exp(-a)),
                           std::tanh(a),
                           a >= 0 ? a : 0.1 * a,
                           std::max(0.0, std::min(1.0, 0.2 * a + 0.5)),
                           a * std::max(0.0, std::min(1.0, a / 6 + 0.5))};
      for (int k = 0; k < 6; ++k) feat[k * 2 + o] += (2 * f[k] / (1.0 + 0.25 * (k * 2 + o)) - 1) / (H * W);
    }
  double logit[3], mx = -1e300, sum = 0;
  for (int j = 0; j < 3; ++j) {
    logit[j] = j == 0 ? 0.5 : j == 1 ? -1.0 : 2.0;
    for (int k = 0; k < 12; ++k) logit[j] += feat[k] * wm[k * 3 + j];
    mx = std::max(mx, logit[j]);
  }
  for (double l : logit) sum += std::exp(l - mx);
  ASSERT_EQ(y.size(), 3);
  for (int j = 0; j < 3; ++j) EXPECT_NEAR(y[j], std::exp(logit[j] - mx) / sum, 1e-5) << j;
}

// AveragePool with ceil_mode and count_include_pad, MaxPool with ceil_mode, against PyTorch's
// rules: a last window that starts inside the input or its leading pad is kept; the divisor
// counts the padding, not what lies past it.
TEST(Graph, PoolingCeilModeAndCountIncludePad) {
  const int H = 6, W = 6, k = 3, s = 2, p = 1;
  for (const char* kind : {"AveragePool", "MaxPool"}) {
    onnx::ModelProto m;
    auto* g = m.mutable_graph();
    add_init(g, "w", {1, 1, 1, 1}, {1.0f});
    add_node(g, "Conv", "conv", {"input", "w"}, "a");
    auto* n = add_node(g, kind, "pool", {"a"}, "out");
    ints_attr(n, "kernel_shape", {k, k});
    ints_attr(n, "strides", {s, s});
    ints_attr(n, "pads", {p, p, p, p});
    for (const char* name : {"ceil_mode", "count_include_pad"}) {
      if (std::string(kind) == "MaxPool" && std::string(name) == "count_include_pad") continue;
      auto* a = n->add_attribute();
      a->set_name(name);
      a->set_type(onnx::AttributeProto::INT);
      a->set_i(1);
    }
    const Model model = load_onnx_model(save(m, 1, H, W, "out", std::string("ceil_") + kind));
    const int out = 4;  // ceil((6 + 2 - 3) / 2) + 1; floor mode gives 3
    ASSERT_EQ(model.values[model.output].h, out);
    ASSERT_EQ(model.values[model.output].w, out);
    const auto x = randv(H * W, 15);
    SoftwareBackend sw(model);
    const Eigen::VectorXf y = run_image(model, x.data(), sw);
    for (int oy = 0; oy < out; ++oy)
      for (int ox = 0; ox < out; ++ox) {
        const int hs = oy * s - p, ws = ox * s - p;
        const int he = std::min(hs + k, H + p), we = std::min(ws + k, W + p);
        const int divisor = (he - hs) * (we - ws);  // the window within the padded input
        double sum = 0, mx = -1e300;
        for (int yy = std::max(hs, 0); yy < std::min(he, H); ++yy)
          for (int xx = std::max(ws, 0); xx < std::min(we, W); ++xx) {
            sum += x[yy * W + xx];
            mx = std::max(mx, static_cast<double>(x[yy * W + xx]));
          }
        const double want = std::string(kind) == "MaxPool" ? mx : sum / divisor;
        EXPECT_NEAR(y[oy * out + ox], want, 1e-5) << kind << " " << oy << "," << ox;
      }
  }
}

#include "sw/nn/toeplitz.h"

TEST(Mapping, DenseAndToeplitzMatchDirectConvolution) {
  // Dense mapping (im2col rows x unrolled kernel columns) and sparse (Toeplitz) mapping of
  // the same kernel, against a direct convolution loop.
  const int C = 3, H = 6, W = 7, O = 5, K = 3;
  for (int pad : {0, 1})
    for (int stride : {1, 2}) {
      LinearLayer L;
      L.c_in = C;
      L.c_out = O;
      L.k_h = L.k_w = K;
      L.stride_h = L.stride_w = stride;
      L.pad_t = L.pad_l = L.pad_b = L.pad_r = pad;
      L.in = {C, H, W};
      L.out = {O, (H + 2 * pad - K) / stride + 1, (W + 2 * pad - K) / stride + 1};
      const auto w = randv(O * C * K * K, 11);  // OIHW
      L.weight.resize(L.rows(), O);
      for (int o = 0; o < O; ++o)
        for (int c = 0; c < C; ++c)
          for (int ky = 0; ky < K; ++ky)
            for (int kx = 0; kx < K; ++kx) L.weight((kx * K + ky) * C + c, o) = w[((o * C + c) * K + ky) * K + kx];
      const auto x = randv(C * H * W, 12);
      RowMatrixXf cols;
      im2col(L, x.data(), cols);
      const Eigen::MatrixXf dense = cols * L.weight;  // pixels x O
      const Eigen::SparseMatrix<float> T = toeplitz_matrix(L);
      ASSERT_EQ(T.rows(), C * H * W);
      ASSERT_EQ(T.cols(), L.out.h * L.out.w * O);
      const Eigen::RowVectorXf sparse = Eigen::Map<const Eigen::RowVectorXf>(x.data(), C * H * W) * T;
      for (int o = 0; o < O; ++o)
        for (int oy = 0; oy < L.out.h; ++oy)
          for (int ox = 0; ox < L.out.w; ++ox) {
            double s = 0;
            for (int c = 0; c < C; ++c)
              for (int ky = 0; ky < K; ++ky)
                for (int kx = 0; kx < K; ++kx) {
                  const int iy = oy * stride - pad + ky, ix = ox * stride - pad + kx;
                  if (iy >= 0 && iy < H && ix >= 0 && ix < W)
                    s += w[((o * C + c) * K + ky) * K + kx] * x[(c * H + iy) * W + ix];
                }
            const int p = oy * L.out.w + ox;
            EXPECT_NEAR(dense(p, o), s, 1e-4);
            EXPECT_NEAR(sparse(p * O + o), s, 1e-4);
          }
      if (pad == 0) {
        EXPECT_EQ(toeplitz_matrix(L, true).cols(), T.cols());
      }
    }
}

// ShuffleNet's channel shuffle as exporters write it: the target shapes computed from Shape,
// Gather, Div, Unsqueeze, Cast and Concat (folded at load time), a Reshape to 5-D, a Transpose
// of the two channel axes, a Reshape back, then Split; checked against the permutation by hand.
TEST(Graph, ChannelShuffleFromShapeArithmeticAndSplit) {
  const int C = 6, H = 2, W = 3;
  onnx::ModelProto m;
  auto* g = m.mutable_graph();
  std::vector<float> eye(C * C, 0.0f);  // a 1x1 identity convolution first: a model needs a layer
  for (int c = 0; c < C; ++c) eye[c * C + c] = 1.0f;
  add_init(g, "eye", {C, C, 1, 1}, eye);
  add_node(g, "Conv", "conv", {"input", "eye"}, "xc");
  add_node(g, "Shape", "shape", {"xc"}, "shp");
  add_init_i64(g, "i1", {1});
  add_node(g, "Gather", "gather_c", {"shp", "i1"}, "c");  // [6]
  add_init_i64(g, "two", {2});
  add_node(g, "Div", "cpg", {"c", "two"}, "cpg");  // [3]
  auto* i2 = g->add_initializer();                  // a scalar index: a scalar result
  i2->set_name("i2");
  i2->set_data_type(onnx::TensorProto::INT64);
  i2->add_int64_data(2);
  add_node(g, "Gather", "gather_h", {"shp", "i2"}, "h");  // 2
  add_init_i64(g, "ax0", {0});
  add_node(g, "Unsqueeze", "unsq", {"h", "ax0"}, "hv");  // [2]
  add_init(g, "wf", {1}, {3.0f});
  auto* cast = add_node(g, "Cast", "cast", {"wf"}, "wv");  // [3]
  auto* to = cast->add_attribute();
  to->set_name("to");
  to->set_type(onnx::AttributeProto::INT);
  to->set_i(onnx::TensorProto::INT64);
  add_init_i64(g, "head", {1, 2});
  auto* cat = add_node(g, "Concat", "target", {"head", "cpg", "hv", "wv"}, "t5");  // [1, 2, 3, 2, 3]
  auto* ax = cat->add_attribute();
  ax->set_name("axis");
  ax->set_type(onnx::AttributeProto::INT);
  ax->set_i(0);
  add_node(g, "Reshape", "r5", {"xc", "t5"}, "x5");
  ints_attr(add_node(g, "Transpose", "shuffle", {"x5"}, "y5"), "perm", {0, 2, 1, 3, 4});
  add_init_i64(g, "t4", {1, -1, 0, 3});
  add_node(g, "Reshape", "r4", {"y5", "t4"}, "y");
  add_init_i64(g, "parts", {2, 4});
  auto* split = add_node(g, "Split", "split", {"y", "parts"}, "a");
  split->add_output("b");
  auto* sa = split->add_attribute();
  sa->set_name("axis");
  sa->set_type(onnx::AttributeProto::INT);
  sa->set_i(1);
  add_node(g, "Concat", "join", {"b", "a"}, "out")->add_attribute()->CopyFrom(*ax);
  g->mutable_node(g->node_size() - 1)->mutable_attribute(0)->set_i(1);
  const Model model = load_onnx_model(save(m, C, H, W, "out", "shuffle"));
  // Only data movement: the shuffle, two slices and a concatenation.
  std::vector<OpKind> kinds;
  for (const Op& op : model.ops) kinds.push_back(op.kind);
  EXPECT_EQ(kinds, (std::vector<OpKind>{OpKind::Linear, OpKind::Shuffle, OpKind::Slice, OpKind::Slice, OpKind::Concat}));
  // Shuffled: channel j * 2 + i is input channel i * 3 + j -> 0 3 1 4 2 5; split (2, 4) and
  // joined the other way round -> 1 4 2 5 0 3.
  const int want[C] = {1, 4, 2, 5, 0, 3};
  const auto x = randv(C * H * W, 21);
  SoftwareBackend sw(model);
  const Eigen::VectorXf y = run_image(model, x.data(), sw);
  ASSERT_EQ(y.size(), C * H * W);
  for (int c = 0; c < C; ++c)
    for (int p = 0; p < H * W; ++p) EXPECT_EQ(y[c * H * W + p], x[want[c] * H * W + p]) << c << " " << p;

  // A transpose that moves the spatial axes is refused, naming what is supported.
  onnx::ModelProto m2;
  ints_attr(add_node(m2.mutable_graph(), "Transpose", "hw", {"input"}, "y"), "perm", {0, 1, 3, 2});
  try {
    load_onnx_model(save(m2, C, H, W, "y", "transpose_hw"));
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("only channel permutations"), std::string::npos) << e.what();
  }
}

namespace {

void int_attr(onnx::NodeProto* n, const std::string& name, int64_t v) {
  auto* a = n->add_attribute();
  a->set_name(name);
  a->set_type(onnx::AttributeProto::INT);
  a->set_i(v);
}

/// The InputError message of loading `m` (saved as `file`), "" when it loads.
std::string load_error(onnx::ModelProto& m, int c, int h, int w, const std::string& out, const std::string& file) {
  try {
    load_onnx_model(save(m, c, h, w, out, file));
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

}  // namespace

// Issue 38, item 3: MatMul -> Identity/Dropout -> Add(b) where the MatMul's output is also read
// directly (through the same name, or another alias defined later): out = y + (y + b) = 2 y + b
// with y = W x. Folding b into the layer gave 2 y + 2 b.
TEST(Graph, BiasIsNotFoldedWhenTheLayerOutputIsReadThroughAnAlias) {
  const int K = 4, N = 3;
  const auto w = randv(K * N, 31);
  const std::vector<float> b = {0.5f, -1.0f, 2.0f};
  for (const char* alias : {"Identity", "Dropout"})
    for (bool later_alias : {false, true}) {
      SCOPED_TRACE(std::string(alias) + (later_alias ? " + later alias" : ""));
      onnx::ModelProto m;
      auto* g = m.mutable_graph();
      add_init(g, "w", {K, N}, w);
      add_init(g, "b", {N}, b);
      add_node(g, "Flatten", "flat", {"input"}, "f");
      add_node(g, "MatMul", "mm", {"f", "w"}, "y");
      add_node(g, alias, "alias", {"y"}, "ya");
      add_node(g, "Add", "bias", {"ya", "b"}, "z");
      if (later_alias) add_node(g, "Identity", "alias2", {"y"}, "y2");
      add_node(g, "Add", "sum", {later_alias ? "y2" : "y", "z"}, "out");
      const Model model = load_onnx_model(save(m, K, 1, 1, "out", "fold_alias"));
      const auto x = randv(K, 32);
      SoftwareBackend sw(model);
      const Eigen::VectorXf out = run_image(model, x.data(), sw);
      ASSERT_EQ(out.size(), N);
      for (int j = 0; j < N; ++j) {
        double y = 0;
        for (int k = 0; k < K; ++k) y += x[k] * w[k * N + j];
        EXPECT_NEAR(out[j], 2 * y + b[j], 1e-5) << j;
      }
    }
  // Read only through the alias: still folded into the layer (no digital op for the bias).
  onnx::ModelProto m;
  auto* g = m.mutable_graph();
  add_init(g, "w", {K, N}, w);
  add_init(g, "b", {N}, b);
  add_node(g, "Flatten", "flat", {"input"}, "f");
  add_node(g, "MatMul", "mm", {"f", "w"}, "y");
  add_node(g, "Identity", "alias", {"y"}, "ya");
  add_node(g, "Add", "bias", {"ya", "b"}, "out");
  const Model model = load_onnx_model(save(m, K, 1, 1, "out", "fold_alias_only"));
  ASSERT_EQ(model.ops.size(), 2u);
  EXPECT_EQ(model.ops[1].kind, OpKind::Linear);
  EXPECT_FLOAT_EQ(model.linear[0].bias(2), 2.0f);
}

// Issue 38, item 11: a node output that names an existing value (another node's output, the
// graph input or an initializer) is refused, naming the node and the value.
TEST(Graph, ANodeThatRedefinesAValueIsRefused) {
  for (const char* clash : {"a", "input", "w"}) {
    SCOPED_TRACE(clash);
    onnx::ModelProto m;
    auto* g = m.mutable_graph();
    add_init(g, "w", {2, 2, 1, 1}, {1, 0, 0, 1});
    add_node(g, "Conv", "conv", {"input", "w"}, "a");
    add_node(g, "Relu", "again", {"a"}, clash);
    add_node(g, "Relu", "last", {clash}, "out");
    const std::string e = load_error(m, 2, 2, 2, "out", "redefine");
    EXPECT_NE(e.find("node 'again' (Relu)"), std::string::npos) << e;
    EXPECT_NE(e.find("'" + std::string(clash) + "'"), std::string::npos) << e;
  }
}

namespace {

/// input (1 x 8 x 1 x 1) -> a 1x1 Conv (8 -> 8, seeded) -> "c", then Transpose perm (0, 2, 1, 3)
/// -> "t" of shape 1 x 1 x 8 x 1. Returns the conv's output for `x` through `c`.
void conv_then_transpose(onnx::GraphProto* g, const std::vector<float>& wc, const std::vector<float>& x,
                         std::vector<double>& c) {
  add_init(g, "wc", {8, 8, 1, 1}, wc);
  add_node(g, "Conv", "conv", {"input", "wc"}, "c");
  ints_attr(add_node(g, "Transpose", "tr", {"c"}, "t"), "perm", {0, 2, 1, 3});
  c.assign(8, 0.0);
  for (int o = 0; o < 8; ++o)
    for (int k = 0; k < 8; ++k) c[o] += wc[o * 8 + k] * x[k];
}

}  // namespace

// Issue 38, item 4: shapes after a Transpose follow ONNX's rules. Expected values by ONNX's
// definitions, by hand: 1 x 8 x 1 x 1 transposed (0, 2, 1, 3) is 1 x 1 x 8 x 1.
TEST(Graph, ShapesAfterTransposeFollowOnnx) {
  const auto wc = randv(64, 41), x = randv(8, 42);
  std::vector<double> c;
  {  // Softmax over axis 1, now of size 1: every value is 1 (it was a softmax over 8 values).
    onnx::ModelProto m;
    auto* g = m.mutable_graph();
    conv_then_transpose(g, wc, x, c);
    int_attr(add_node(g, "Softmax", "sm", {"t"}, "out"), "axis", 1);
    const Model model = load_onnx_model(save(m, 8, 1, 1, "out", "tr_softmax"));
    EXPECT_EQ(model.values[model.output], (Shape{1, 8, 1}));
    SoftwareBackend sw(model);
    const Eigen::VectorXf y = run_image(model, x.data(), sw);
    ASSERT_EQ(y.size(), 8);
    for (int k = 0; k < 8; ++k) EXPECT_NEAR(y[k], 1.0, 1e-6) << k;
  }
  {  // Split along axis 2 (the 8) into 3 + 5: the second part is c[3..7] (it read out of bounds).
    onnx::ModelProto m;
    auto* g = m.mutable_graph();
    conv_then_transpose(g, wc, x, c);
    add_init_i64(g, "parts", {3, 5});
    auto* sp = add_node(g, "Split", "split", {"t", "parts"}, "a");
    sp->add_output("out");
    int_attr(sp, "axis", 2);
    const Model model = load_onnx_model(save(m, 8, 1, 1, "out", "tr_split"));
    EXPECT_EQ(model.values[model.output], (Shape{1, 5, 1}));
    SoftwareBackend sw(model);
    const Eigen::VectorXf y = run_image(model, x.data(), sw);
    ASSERT_EQ(y.size(), 5);
    for (int k = 0; k < 5; ++k) EXPECT_NEAR(y[k], c[3 + k], 1e-5) << k;
  }
  {  // Split (4, 4) -> Flatten (1 x 4) -> Gemm 4 -> 3: a valid model (it was refused, "inner
     // dimension 4 vs input 32").
    onnx::ModelProto m;
    auto* g = m.mutable_graph();
    conv_then_transpose(g, wc, x, c);
    add_init_i64(g, "parts", {4, 4});
    auto* sp = add_node(g, "Split", "split", {"t", "parts"}, "a");
    sp->add_output("b");
    int_attr(sp, "axis", 2);
    add_node(g, "Flatten", "flat", {"b"}, "f");
    const auto wg = randv(3 * 4, 43);
    add_init(g, "wg", {4, 3}, wg);
    add_node(g, "Gemm", "gemm", {"f", "wg"}, "out");
    const Model model = load_onnx_model(save(m, 8, 1, 1, "out", "tr_split_gemm"));
    SoftwareBackend sw(model);
    const Eigen::VectorXf y = run_image(model, x.data(), sw);
    ASSERT_EQ(y.size(), 3);
    for (int j = 0; j < 3; ++j) {
      double s = 0;
      for (int k = 0; k < 4; ++k) s += wg[k * 3 + j] * c[4 + k];
      EXPECT_NEAR(y[j], s, 1e-5) << j;
    }
  }
  // What the internal C x H x W cannot express is refused, naming the node: a Softmax over the
  // last axis of 1 x 8 x 1 x 1 (its W, of size 1; it was taken as the channels).
  {
    onnx::ModelProto m;
    auto* g = m.mutable_graph();
    conv_then_transpose(g, wc, x, c);
    add_node(g, "Softmax", "sm", {"c"}, "out");  // default axis -1
    const std::string e = load_error(m, 8, 1, 1, "out", "softmax_w");
    EXPECT_NE(e.find("node 'sm' (Softmax)"), std::string::npos) << e;
  }
}

// Issue 38, item 4: axes are read in the value's actual rank (ONNX's rules), and what the
// C x H x W representation cannot express is refused naming the node, not computed otherwise.
TEST(Graph, AxesAreInterpretedInTheActualShape) {
  auto base = [](onnx::GraphProto* g) {  // input 1 x 4 x 1 x 1 -> Conv -> "c" (1 x 4 x 1 x 1)
    add_init(g, "wc", {4, 4, 1, 1}, randv(16, 51));
    add_node(g, "Conv", "conv", {"input", "wc"}, "c");
    add_node(g, "Flatten", "flat", {"c"}, "v");  // 1 x 4
  };
  struct Case {
    const char* name;
    std::function<void(onnx::GraphProto*)> add;
    const char* node;
  };
  const std::vector<Case> cases = {
      // Concat along W of two 1 x 4 x 1 x 1: 1 x 4 x 1 x 2, interleaved (was a channel concat).
      {"concat_w",
       [](onnx::GraphProto* g) { int_attr(add_node(g, "Concat", "cat", {"c", "c"}, "out"), "axis", -1); },
       "node 'cat' (Concat)"},
      // ReduceMean over the last axis of a 1 x 4 vector: 1 x 1 (was an identity).
      {"reduce_vector",
       [](onnx::GraphProto* g) { ints_attr(add_node(g, "ReduceMean", "rm", {"v"}, "out"), "axes", {-2, -1}); },
       "node 'rm' (ReduceMean)"},
      // Softmax over axis -3 of a vector: no such axis.
      {"softmax_rank2",
       [](onnx::GraphProto* g) { int_attr(add_node(g, "Softmax", "sm", {"v"}, "out"), "axis", -3); },
       "node 'sm' (Softmax)"},
      // A [1, 4] vector plus a 1 x 4 x 1 x 1 map broadcasts to 1 x 4 x 1 x 4 (was element-wise).
      {"add_ranks", [](onnx::GraphProto* g) { add_node(g, "Add", "add", {"v", "c"}, "out"); }, "node 'add' (Add)"},
      // A constant [4] against 1 x 4 x 1 x 1 aligns with W (size 1): 1 x 4 x 1 x 4 (was per channel).
      {"add_const_w",
       [](onnx::GraphProto* g) {
         add_init(g, "k", {4}, {1, 2, 3, 4});
         add_node(g, "Mul", "mul", {"c", "k"}, "out");
       },
       "node 'mul' (Mul)"},
      // Slice of axis 2 of a vector: no such axis.
      {"slice_rank2",
       [](onnx::GraphProto* g) {
         add_init_i64(g, "s0", {0});
         add_init_i64(g, "s1", {1});
         add_init_i64(g, "s2", {2});
         add_node(g, "Slice", "sl", {"v", "s0", "s1", "s2"}, "out");
       },
       "node 'sl' (Slice)"},
      // Gemm of a 1 x 4 x 1 x 1 map (Gemm reads N x K).
      {"gemm_rank4",
       [](onnx::GraphProto* g) {
         add_init(g, "wg", {4, 2}, randv(8, 52));
         add_node(g, "Gemm", "gemm", {"c", "wg"}, "out");
       },
       "node 'gemm' (Gemm)"},
  };
  for (const Case& k : cases) {
    SCOPED_TRACE(k.name);
    onnx::ModelProto m;
    auto* g = m.mutable_graph();
    base(g);
    k.add(g);
    const std::string e = load_error(m, 4, 1, 1, "out", std::string("axes_") + k.name);
    EXPECT_NE(e.find(k.node), std::string::npos) << "'" << e << "'";
  }
}

// Issue 38, item 11: exporters may leave node names empty, and every layer, report row and
// message then named nothing ("layer : analog layer: ..."). An unnamed node is called by its
// first output.
TEST(Graph, AnUnnamedNodeIsCalledByItsOutput) {
  onnx::ModelProto m;
  auto* g = m.mutable_graph();
  add_init(g, "w", {2, 2, 1, 1}, {1, 0, 0, 1});
  add_node(g, "Conv", "", {"input", "w"}, "features");
  add_node(g, "Relu", "", {"features"}, "out");
  const Model model = load_onnx_model(save(m, 2, 2, 2, "out", "unnamed"));
  ASSERT_EQ(model.linear.size(), 1u);
  EXPECT_EQ(model.linear[0].name, "features");
  bool relu = false;
  for (const Op& op : model.ops) relu = relu || (op.kind == OpKind::Relu && op.name == "out");
  EXPECT_TRUE(relu);
}

// Issue 39, item 2: Mul, Div, Sub and Add of two computed values, with numpy-style
// broadcasting over the axes of extent 1: SiLU (x * sigmoid x), a squeeze-excitation (a
// C x 1 x 1 scale, HardSigmoid as torch exports it, times the C x H x W map, the scale first),
// a row (C x 1 x W) subtracted from every row, a channel (1 x H x W) dividing every channel,
// and a C x 1 x 1 value added. Against direct loops.
TEST(Graph, ArithmeticOfTwoComputedValuesBroadcasts) {
  const int C = 2, H = 3, W = 4;
  onnx::ModelProto m;
  auto* g = m.mutable_graph();
  const auto wc = randv(C * C, 61), wq = randv(C * C, 62), bq = randv(C, 63);
  add_init(g, "wc", {C, C, 1, 1}, wc);
  add_node(g, "Conv", "conv", {"input", "wc"}, "a");
  add_node(g, "Sigmoid", "sig", {"a"}, "sg");
  add_node(g, "Mul", "silu", {"a", "sg"}, "silu");
  add_node(g, "GlobalAveragePool", "gap", {"silu"}, "p");
  add_init(g, "wq", {C, C, 1, 1}, wq);
  add_init(g, "bq", {C}, bq);
  add_node(g, "Conv", "fc", {"p", "wq", "bq"}, "q");
  auto* hs = add_node(g, "HardSigmoid", "hsig", {"q"}, "hs");
  auto* alpha = hs->add_attribute();
  alpha->set_name("alpha");
  alpha->set_type(onnx::AttributeProto::FLOAT);
  alpha->set_f(1.0f / 6);
  add_node(g, "Mul", "se", {"hs", "silu"}, "se");
  add_init_i64(g, "r0", {0});
  add_init_i64(g, "r1", {1});
  add_init_i64(g, "ax2", {2});
  add_init_i64(g, "ax1", {1});
  add_node(g, "Slice", "row", {"a", "r0", "r1", "ax2"}, "row");  // C x 1 x W: row 0
  add_node(g, "Sub", "sub", {"se", "row"}, "sb");
  add_node(g, "Slice", "chan", {"a", "r0", "r1", "ax1"}, "ch");  // 1 x H x W: channel 0
  add_node(g, "Sigmoid", "sig_ch", {"ch"}, "sc");
  add_node(g, "Div", "div", {"sb", "sc"}, "dv");
  add_node(g, "Add", "add", {"dv", "q"}, "out");
  const Model model = load_onnx_model(save(m, C, H, W, "out", "binary"));
  int binary = 0;
  for (const Op& op : model.ops)
    binary += op.kind == OpKind::Add || op.kind == OpKind::Sub || op.kind == OpKind::Mul || op.kind == OpKind::Div;
  EXPECT_EQ(binary, 5);
  ASSERT_EQ(model.values[model.output].c, C);
  ASSERT_EQ(model.values[model.output].h, H);
  ASSERT_EQ(model.values[model.output].w, W);
  const auto x = randv(C * H * W, 64);
  SoftwareBackend sw(model);
  const Eigen::VectorXf y = run_image(model, x.data(), sw);
  ASSERT_EQ(y.size(), C * H * W);
  auto at = [&](int c, int yy, int xx) { return (c * H + yy) * W + xx; };
  std::vector<double> a(C * H * W), silu(C * H * W);
  for (int c = 0; c < C; ++c)
    for (int p = 0; p < H * W; ++p) {
      double s = 0;
      for (int k = 0; k < C; ++k) s += wc[c * C + k] * x[k * H * W + p];
      a[c * H * W + p] = s;
      silu[c * H * W + p] = s / (1 + std::exp(-s));
    }
  std::vector<double> q(C), scale(C);
  for (int c = 0; c < C; ++c) {
    q[c] = bq[c];
    for (int k = 0; k < C; ++k) {
      double mean = 0;
      for (int p = 0; p < H * W; ++p) mean += silu[k * H * W + p] / (H * W);
      q[c] += wq[c * C + k] * mean;
    }
    scale[c] = std::max(0.0, std::min(1.0, q[c] / 6 + 0.5));
  }
  for (int c = 0; c < C; ++c)
    for (int yy = 0; yy < H; ++yy)
      for (int xx = 0; xx < W; ++xx) {
        const double se = scale[c] * silu[at(c, yy, xx)];
        const double sub = se - a[at(c, 0, xx)];
        const double div = sub / (1 / (1 + std::exp(-a[at(0, yy, xx)])));
        EXPECT_NEAR(y[at(c, yy, xx)], div + q[c], 1e-4 * (1 + std::abs(div))) << c << "," << yy << "," << xx;
      }
}

// Shapes that do not broadcast (3 against 2 channels; values of ranks 2 and 4) are refused
// naming the node and both shapes.
TEST(Graph, ArithmeticOfValuesThatDoNotBroadcastIsRefused) {
  onnx::ModelProto m;
  auto* g = m.mutable_graph();
  add_init(g, "w2", {2, 2, 1, 1}, randv(4, 65));
  add_init(g, "w3", {3, 2, 1, 1}, randv(6, 66));
  add_node(g, "Conv", "c2", {"input", "w2"}, "a");
  add_node(g, "Conv", "c3", {"input", "w3"}, "b");
  add_node(g, "Mul", "bad_mul", {"a", "b"}, "out");
  const std::string e = load_error(m, 2, 3, 3, "out", "binary_bad");
  for (const char* s : {"node 'bad_mul' (Mul)", "1x2x3x3", "1x3x3x3"})
    EXPECT_NE(e.find(s), std::string::npos) << s << ": " << e;
}
