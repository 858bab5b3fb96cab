#include "sw/nn/ops.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace xbarsim {

namespace {

// ---- What the operations compute on one image (C x H x W float32 values).

void pool(const Op& op, const Shape& in, const Shape& out, const std::vector<float>& x, std::vector<float>& y) {
  y.assign(out.size(), 0.0f);
  const bool is_max = op.kind == OpKind::MaxPool;
  for (int c = 0; c < out.c; ++c)
    for (int oy = 0; oy < out.h; ++oy)
      for (int ox = 0; ox < out.w; ++ox) {
        float acc = is_max ? -std::numeric_limits<float>::infinity() : 0.0f;
        int count = 0;
        for (int ky = 0; ky < op.k_h; ++ky)
          for (int kx = 0; kx < op.k_w; ++kx) {
            const int iy = oy * op.s_h - op.p_t + ky, ix = ox * op.s_w - op.p_l + kx;
            // count_include_pad: the padding counts, what lies past it (ceil_mode) does not.
            if (op.count_include_pad && iy < in.h + op.p_b && ix < in.w + op.p_r && !(iy >= 0 && iy < in.h && ix >= 0 && ix < in.w))
              ++count;
            if (iy < 0 || iy >= in.h || ix < 0 || ix >= in.w) continue;
            const float val = x[(static_cast<size_t>(c) * in.h + iy) * in.w + ix];
            acc = is_max ? std::max(acc, val) : acc + val;
            ++count;
          }
        y[(static_cast<size_t>(c) * out.h + oy) * out.w + ox] = is_max ? acc : acc / count;
      }
}

void slice(const Op& op, const Shape& in, const Shape& out, const std::vector<float>& x, std::vector<float>& y) {
  y.resize(out.size());
  for (int c = 0; c < out.c; ++c)
    for (int yy = 0; yy < out.h; ++yy)
      for (int xx = 0; xx < out.w; ++xx)
        y[(static_cast<size_t>(c) * out.h + yy) * out.w + xx] =
            x[(static_cast<size_t>(op.start[0] + c * op.step[0]) * in.h + op.start[1] + yy * op.step[1]) * in.w +
              op.start[2] + xx * op.step[2]];
}

void pad(const Op& op, const Shape& in, const Shape& out, const std::vector<float>& x, std::vector<float>& y) {
  y.assign(out.size(), op.pad_value);
  for (int c = 0; c < in.c; ++c)
    for (int yy = 0; yy < in.h; ++yy)
      for (int xx = 0; xx < in.w; ++xx)
        y[(static_cast<size_t>(c + op.pad_lo[0]) * out.h + yy + op.pad_lo[1]) * out.w + xx + op.pad_lo[2]] =
            x[(static_cast<size_t>(c) * in.h + yy) * in.w + xx];
}

template <typename F>
void broadcast(const Shape& sa, const Shape& sb, const Shape& out, const std::vector<float>& a,
               const std::vector<float>& b, std::vector<float>& y, F f) {
  y.resize(static_cast<size_t>(out.size()));
  if (sa == out && sb == out) {  // the common case: no index arithmetic
    for (size_t k = 0; k < y.size(); ++k) y[k] = f(a[k], b[k]);
    return;
  }
  // Strides of an input over the output's (c, y, x): 0 along an axis of extent 1 (repeated).
  auto strides = [&](const Shape& s) {
    return std::array<size_t, 3>{s.c == 1 ? 0 : static_cast<size_t>(s.h) * s.w, s.h == 1 ? 0 : static_cast<size_t>(s.w),
                                 s.w == 1 ? 0 : size_t{1}};
  };
  const std::array<size_t, 3> ta = strides(sa), tb = strides(sb);
  size_t k = 0;
  for (int c = 0; c < out.c; ++c)
    for (int yy = 0; yy < out.h; ++yy)
      for (int xx = 0; xx < out.w; ++xx, ++k)
        y[k] = f(a[c * ta[0] + yy * ta[1] + xx * ta[2]], b[c * tb[0] + yy * tb[1] + xx * tb[2]]);
}

float activation(const Op& op, float x) {
  switch (op.activation) {
    case Activation::Clip:
      return std::min(std::max(x, op.lo), op.hi);
    case Activation::LeakyRelu:
      return x >= 0 ? x : op.alpha * x;
    case Activation::Sigmoid:
      return 1.0f / (1.0f + std::exp(-x));
    case Activation::Tanh:
      return std::tanh(x);
    case Activation::HardSigmoid:
      return std::max(0.0f, std::min(1.0f, op.alpha * x + op.beta));
    case Activation::HardSwish:
      return x * std::max(0.0f, std::min(1.0f, x / 6.0f + 0.5f));
  }
  return x;
}

/// Softmax over the channels of every pixel (max subtracted first, summed in double).
void softmax(const Shape& in, const std::vector<float>& x, std::vector<float>& y) {
  y.resize(x.size());
  const size_t hw = static_cast<size_t>(in.h) * in.w;
  for (size_t p = 0; p < hw; ++p) {
    float m = -std::numeric_limits<float>::infinity();
    for (int c = 0; c < in.c; ++c) m = std::max(m, x[c * hw + p]);
    double s = 0;
    for (int c = 0; c < in.c; ++c) s += std::exp(static_cast<double>(x[c * hw + p] - m));
    for (int c = 0; c < in.c; ++c) y[c * hw + p] = static_cast<float>(std::exp(static_cast<double>(x[c * hw + p] - m)) / s);
  }
}

void global_avg_pool(const Shape& in, const std::vector<float>& x, std::vector<float>& y) {
  y.resize(in.c);
  const int hw = in.h * in.w;
  for (int c = 0; c < in.c; ++c) {
    double s = 0;
    for (int p = 0; p < hw; ++p) s += x[static_cast<size_t>(c) * hw + p];
    y[c] = static_cast<float>(s / hw);
  }
}

const Shape& in_shape(const Op& op, const std::vector<Shape>& shapes, size_t k = 0) {
  return shapes.at(static_cast<size_t>(op.in.at(k)));
}
const Shape& out_shape(const Op& op, const std::vector<Shape>& shapes) { return shapes.at(static_cast<size_t>(op.out)); }

/// y = a op b element-wise (float32, IEEE: a division by zero is an infinity, as in torch),
/// each input repeated along its axes of extent 1.
template <typename F>
void run_binary(const Op& op, const std::vector<Shape>& shapes, const OpInputs& xs, std::vector<float>& y, F f) {
  broadcast(in_shape(op, shapes), in_shape(op, shapes, 1), out_shape(op, shapes), *xs.at(0), *xs.at(1), y, f);
}

void run_relu(const Op&, const std::vector<Shape>&, const OpInputs& xs, std::vector<float>& y) {
  const std::vector<float>& x = *xs.at(0);
  y.resize(x.size());
  for (size_t k = 0; k < x.size(); ++k) y[k] = x[k] > 0 ? x[k] : 0.0f;
}
void run_add(const Op& op, const std::vector<Shape>& shapes, const OpInputs& xs, std::vector<float>& y) {
  run_binary(op, shapes, xs, y, [](float u, float v) { return u + v; });
}
void run_sub(const Op& op, const std::vector<Shape>& shapes, const OpInputs& xs, std::vector<float>& y) {
  run_binary(op, shapes, xs, y, [](float u, float v) { return u - v; });
}
void run_mul(const Op& op, const std::vector<Shape>& shapes, const OpInputs& xs, std::vector<float>& y) {
  run_binary(op, shapes, xs, y, [](float u, float v) { return u * v; });
}
void run_div(const Op& op, const std::vector<Shape>& shapes, const OpInputs& xs, std::vector<float>& y) {
  run_binary(op, shapes, xs, y, [](float u, float v) { return u / v; });
}
void run_affine(const Op& op, const std::vector<Shape>& shapes, const OpInputs& xs, std::vector<float>& y) {
  const std::vector<float>& x = *xs.at(0);
  const Shape& in = in_shape(op, shapes);
  y.resize(x.size());
  const int hw = in.h * in.w;
  for (int c = 0; c < in.c; ++c)
    for (int p = 0; p < hw; ++p)
      y[static_cast<size_t>(c) * hw + p] = x[static_cast<size_t>(c) * hw + p] * op.scale(c) + op.shift(c);
}
void run_pool(const Op& op, const std::vector<Shape>& shapes, const OpInputs& xs, std::vector<float>& y) {
  pool(op, in_shape(op, shapes), out_shape(op, shapes), *xs.at(0), y);
}
void run_global_avg_pool(const Op& op, const std::vector<Shape>& shapes, const OpInputs& xs, std::vector<float>& y) {
  global_avg_pool(in_shape(op, shapes), *xs.at(0), y);
}
void run_flatten(const Op&, const std::vector<Shape>&, const OpInputs& xs, std::vector<float>& y) { y = *xs.at(0); }
void run_slice(const Op& op, const std::vector<Shape>& shapes, const OpInputs& xs, std::vector<float>& y) {
  slice(op, in_shape(op, shapes), out_shape(op, shapes), *xs.at(0), y);
}
void run_pad(const Op& op, const std::vector<Shape>& shapes, const OpInputs& xs, std::vector<float>& y) {
  pad(op, in_shape(op, shapes), out_shape(op, shapes), *xs.at(0), y);
}
void run_activation(const Op& op, const std::vector<Shape>&, const OpInputs& xs, std::vector<float>& y) {
  const std::vector<float>& x = *xs.at(0);
  y.resize(x.size());
  for (size_t k = 0; k < x.size(); ++k) y[k] = activation(op, x[k]);
}
void run_softmax(const Op& op, const std::vector<Shape>& shapes, const OpInputs& xs, std::vector<float>& y) {
  softmax(in_shape(op, shapes), *xs.at(0), y);
}
void run_concat(const Op& op, const std::vector<Shape>& shapes, const OpInputs& xs, std::vector<float>& y) {
  y.resize(out_shape(op, shapes).size());  // C x H x W blocks one after the other: the channels concatenated
  size_t at = 0;
  for (const std::vector<float>* v : xs) {
    std::copy(v->begin(), v->end(), y.begin() + static_cast<std::ptrdiff_t>(at));
    at += v->size();
  }
}
void run_shuffle(const Op& op, const std::vector<Shape>& shapes, const OpInputs& xs, std::vector<float>& y) {
  const std::vector<float>& x = *xs.at(0);
  const Shape& in = in_shape(op, shapes);
  const Shape& out = out_shape(op, shapes);
  const size_t plane = static_cast<size_t>(in.h) * in.w;
  y.resize(x.size());
  for (int c = 0; c < out.c; ++c)
    std::copy_n(x.begin() + static_cast<std::ptrdiff_t>(op.perm[static_cast<size_t>(c)] * plane), plane,
                y.begin() + static_cast<std::ptrdiff_t>(c * plane));
}

// ---- What an output row costs a tile's digital units.

long long per_value(const Op&, const Shape& out, const Shape&) { return static_cast<long long>(out.c) * out.w; }
long long per_softmax_value(const Op&, const Shape& out, const Shape&) {
  return 3LL * out.c * out.w;  // per value: an exponential, its share of the sum, a division
}
long long per_window_tap(const Op& op, const Shape& out, const Shape&) {
  return static_cast<long long>(out.c) * out.w * op.k_h * op.k_w;
}
long long per_input_value(const Op&, const Shape&, const Shape& in0) { return static_cast<long long>(in0.size()); }
long long no_ops(const Op&, const Shape&, const Shape&) { return 0; }  // data movement, or a tile's crossbars

// ---- Whether the output is non-negative, given which inputs are.

bool input(const std::vector<bool>& in, size_t k) { return k < in.size() && in[k]; }
bool never(const Op&, const std::vector<bool>&) { return false; }
bool always(const Op&, const std::vector<bool>&) { return true; }
bool as_first(const Op&, const std::vector<bool>& in) { return input(in, 0); }
bool as_both(const Op&, const std::vector<bool>& in) { return input(in, 0) && input(in, 1); }
bool as_all(const Op&, const std::vector<bool>& in) {
  for (size_t k = 0; k < in.size(); ++k)
    if (!in[k]) return false;
  return true;
}
bool pad_nonnegative(const Op& op, const std::vector<bool>& in) { return input(in, 0) && op.pad_value >= 0; }
bool activation_nonnegative(const Op& op, const std::vector<bool>&) {
  // Clip with a bound >= 0 below, and the sigmoids, never give a negative value.
  return (op.activation == Activation::Clip && op.lo >= 0) || op.activation == Activation::Sigmoid ||
         op.activation == Activation::HardSigmoid;
}

// ---- The table: one row per operation.
//                                        unit op          rows                    row ops            sign           run
const OpInfo kLinear{"", RowRule::Layer, no_ops, never, nullptr};  // its input's sign: linear_inputs_signed
const OpInfo kRelu{"relu", RowRule::RowWise, per_value, always, run_relu};
const OpInfo kAdd{"add", RowRule::Elementwise, per_value, as_both, run_add};
const OpInfo kSub{"add", RowRule::Elementwise, per_value, never, run_sub};  // an adder subtracts
const OpInfo kMul{"mul", RowRule::Elementwise, per_value, as_both, run_mul};
const OpInfo kDiv{"div", RowRule::Elementwise, per_value, as_both, run_div};
const OpInfo kMaxPool{"maxpool", RowRule::Window, per_window_tap, as_first, run_pool};
const OpInfo kAvgPool{"avgpool", RowRule::Window, per_window_tap, as_first, run_pool};
const OpInfo kGlobalAvgPool{"globalavgpool", RowRule::Whole, per_input_value, as_first, run_global_avg_pool};
const OpInfo kFlatten{"", RowRule::Whole, no_ops, as_first, run_flatten};
const OpInfo kSlice{"", RowRule::Slice, no_ops, as_first, run_slice};
const OpInfo kPad{"", RowRule::Pad, no_ops, pad_nonnegative, run_pad};
const OpInfo kAffine{"affine", RowRule::RowWise, per_value, never, run_affine};
const OpInfo kActivation{"activation", RowRule::RowWise, per_value, activation_nonnegative, run_activation};
const OpInfo kSoftmax{"softmax", RowRule::RowWise, per_softmax_value, always, run_softmax};
const OpInfo kConcat{"", RowRule::Channels, no_ops, as_all, run_concat};
const OpInfo kShuffle{"", RowRule::RowWise, no_ops, as_first, run_shuffle};

}  // namespace

const OpInfo& op_info(OpKind k) {
  switch (k) {
    case OpKind::Linear:
      return kLinear;
    case OpKind::Relu:
      return kRelu;
    case OpKind::Add:
      return kAdd;
    case OpKind::Sub:
      return kSub;
    case OpKind::Mul:
      return kMul;
    case OpKind::Div:
      return kDiv;
    case OpKind::MaxPool:
      return kMaxPool;
    case OpKind::AvgPool:
      return kAvgPool;
    case OpKind::GlobalAvgPool:
      return kGlobalAvgPool;
    case OpKind::Flatten:
      return kFlatten;
    case OpKind::Slice:
      return kSlice;
    case OpKind::Pad:
      return kPad;
    case OpKind::Affine:
      return kAffine;
    case OpKind::Activation:
      return kActivation;
    case OpKind::Softmax:
      return kSoftmax;
    case OpKind::Concat:
      return kConcat;
    case OpKind::Shuffle:
      return kShuffle;
  }
  throw std::logic_error("op_info: unknown operation kind");
}

}  // namespace xbarsim
