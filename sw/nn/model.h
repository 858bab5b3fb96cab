#pragma once
/// A CNN as a straight-line program over per-image activations (C x H x W, float32),
/// imported from ONNX. Conv and Gemm/MatMul are "linear layers" whose multiply can be
/// executed by a backend (software GEMM or crossbars); everything else runs digitally.
#include <Eigen/Dense>
#include <map>
#include <string>
#include <vector>

namespace xbarsim {

/// Shape of one image's activation; vectors are C x 1 x 1.
struct Shape {
  int c = 0, h = 1, w = 1;
  int size() const { return c * h * w; }
  bool operator==(const Shape& o) const { return c == o.c && h == o.h && w == o.w; }
};

/// A convolution (or fully connected layer as a 1x1 convolution on a 1x1 input).
/// `weight` is K x c_out with K = k_h*k_w*c_in in the dense-mapping row order
///   r = (kx * k_h + ky) * c_in + c
/// (window column-major, channels innermost), the order the shift-register buffer feeds.
struct LinearLayer {
  std::string name;
  bool is_conv = true;
  int c_in = 0, c_out = 0, k_h = 1, k_w = 1;
  int stride_h = 1, stride_w = 1;
  int pad_t = 0, pad_l = 0, pad_b = 0, pad_r = 0;
  /// Grouped (depthwise when group = c_in) convolution: output channel o reads only the input
  /// channels of its group. `weight` holds the whole K x c_out matrix, block-diagonal (zeros
  /// outside each group's block); each group is mapped onto crossbars of its own (RowGroups).
  int group = 1;
  Shape in, out;
  Eigen::MatrixXf weight;  ///< K x c_out
  Eigen::VectorXf bias;    ///< c_out (zeros when absent)
  int rows() const { return k_h * k_w * c_in; }
  int iterations() const { return out.h * out.w; }  ///< output pixels (dense mapping)
};

enum class OpKind {
  Linear,
  Relu,
  /// Add, Sub, Mul, Div: element-wise, in[0] op in[1], of two values with numpy-style
  /// broadcasting: along each of C, H and W an input's extent is the output's or 1, and a value
  /// of extent 1 repeats along that axis (a squeeze-excitation's C x 1 x 1 scale of a C x H x W
  /// map). An operand that is a constant is an Affine op instead.
  Add,
  Sub,
  Mul,
  Div,
  MaxPool,
  AvgPool,
  GlobalAvgPool,
  Flatten,
  Slice,
  Pad,
  Affine,
  Activation,  ///< an element-wise nonlinearity (Op::activation)
  Softmax,     ///< over the channels of every pixel
  Concat,      ///< of every input, along the channels
  Shuffle,     ///< a permutation of the channels (Op::perm): a channel shuffle
};

/// The element-wise functions of OpKind::Activation (ONNX semantics, parameters in Op).
enum class Activation {
  Clip,         ///< min(max(x, lo), hi): Clip, ReLU6
  LeakyRelu,    ///< x >= 0 ? x : alpha x
  Sigmoid,      ///< 1 / (1 + e^-x)
  Tanh,         ///< tanh x
  HardSigmoid,  ///< max(0, min(1, alpha x + beta))
  HardSwish,    ///< x max(0, min(1, x / 6 + 1 / 2))
};

struct Op {
  OpKind kind = OpKind::Relu;
  std::string name;                                                            ///< ONNX node name
  std::vector<int> in;                                                         ///< value ids
  int out = -1;                                                                ///< value id
  int linear = -1;                                                             ///< index into Model::linear (Linear)
  int k_h = 1, k_w = 1, s_h = 1, s_w = 1, p_t = 0, p_l = 0, p_b = 0, p_r = 0;  ///< pooling
  int start[3] = {0, 0, 0}, step[3] = {1, 1, 1};                               ///< Slice over (C, H, W)
  int pad_lo[3] = {0, 0, 0}, pad_hi[3] = {0, 0, 0};                            ///< Pad over (C, H, W)
  float pad_value = 0;
  Eigen::VectorXf scale, shift;  ///< Affine (BatchNormalization): y = x * scale[c] + shift[c]
  Activation activation = Activation::Clip;
  float alpha = 0, beta = 0, lo = 0, hi = 0;  ///< Activation parameters (LeakyRelu, HardSigmoid, Clip)
  /// AvgPool: divide by the whole window, padding included (count_include_pad), not only by
  /// the input values it covers; the window never reaches past the padding (ceil_mode).
  bool count_include_pad = false;
  std::vector<int> perm;  ///< Shuffle: output channel c is input channel perm[c]
};

/// Input preprocessing from the model's metadata_props: x = (pixel * scale - mean[c]) / std[c].
struct Preprocessing {
  double scale = 1.0 / 255;
  std::vector<double> mean{0.0}, std{1.0};
};

struct Model {
  std::string path;
  Shape input;
  std::vector<Shape> values;  ///< shape of every value; value 0 is the input
  std::vector<Op> ops;        ///< topological order
  std::vector<LinearLayer> linear;
  int output = -1;
  Preprocessing pre;
  std::string dataset;             ///< metadata "dataset"
  double reference_accuracy = -1;  ///< metadata "software_accuracy_test_batch"
  std::map<std::string, std::string> metadata;
  /// The metadata gave input_scale, input_mean or input_std (otherwise `pre` holds defaults).
  bool preprocessing_in_metadata = false;
};

/// Loads an ONNX model (opset 13 ops listed in docs/commands.md). Any other op or attribute
/// value throws InputError naming the node and op. `input` gives C,H,W when the model's
/// input has symbolic dimensions (0 = take them from the model).
Model load_onnx_model(const std::string& path, Shape input = Shape{0, 0, 0});
/// The same from the serialized bytes of a model; `origin` names it in messages.
Model load_onnx_model_from_bytes(const std::string& bytes, const std::string& origin, Shape input = Shape{0, 0, 0});

/// Comma-separated numbers, each possibly a fraction "a/b" (e.g. "1/255"); errors name
/// `origin` and `key`.
std::vector<double> parse_number_list(const std::string& s, const std::string& key, const std::string& origin);

}  // namespace xbarsim
