// Graph import and execution on small hand-built ONNX graphs, checked with direct loops.
#include <gtest/gtest.h>
#include <onnx/onnx_pb.h>

#include <fstream>
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

TEST(Graph, ConvStridePadMatchesDirectLoops) {
  const int C = 3, H = 7, W = 6, O = 4, K = 3;
  onnx::ModelProto m;
  auto* g = m.mutable_graph();
  const auto w = randv(O * C * K * K, 1), b = randv(O, 2);
  add_init(g, "w", {O, C, K, K}, w);
  add_init(g, "b", {O}, b);
  auto* n = add_node(g, "Conv", "conv", {"input", "w", "b"}, "y");
  ints_attr(n, "kernel_shape", {K, K});
  ints_attr(n, "strides", {2, 1});
  ints_attr(n, "pads", {1, 0, 1, 2});
  const Model model = load_onnx_model(save(m, C, H, W, "y", "conv"));
  const auto x = randv(C * H * W, 3);
  SoftwareBackend sw(model);
  const Eigen::VectorXf y = run_image(model, x.data(), sw);
  const int oh = (H + 2 - K) / 2 + 1, ow = (W + 2 - K) / 1 + 1;
  ASSERT_EQ(y.size(), O * oh * ow);
  for (int o = 0; o < O; ++o)
    for (int oy = 0; oy < oh; ++oy)
      for (int ox = 0; ox < ow; ++ox) {
        double s = b[o];
        for (int c = 0; c < C; ++c)
          for (int ky = 0; ky < K; ++ky)
            for (int kx = 0; kx < K; ++kx) {
              const int iy = oy * 2 - 1 + ky, ix = ox - 0 + kx;
              if (iy < 0 || iy >= H || ix < 0 || ix >= W) continue;
              s += w[((o * C + c) * K + ky) * K + kx] * x[(c * H + iy) * W + ix];
            }
        EXPECT_NEAR(y[(o * oh + oy) * ow + ox], s, 1e-4);
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
  onnx::ModelProto m;
  auto* g = m.mutable_graph();
  add_node(g, "Sigmoid", "my_sigmoid", {"input"}, "y");
  const std::string path = save(m, 1, 2, 2, "y", "bad");
  try {
    load_onnx_model(path);
    FAIL();
  } catch (const InputError& e) {
    const std::string w = e.what();
    EXPECT_NE(w.find("my_sigmoid"), std::string::npos) << w;
    EXPECT_NE(w.find("Sigmoid"), std::string::npos) << w;
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
