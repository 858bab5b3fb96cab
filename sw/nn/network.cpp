#include "sw/nn/network.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace xbarsim {

void im2col(const LinearLayer& L, const float* chw, RowMatrixXf& cols) {
  const int oh = L.out.h, ow = L.out.w, H = L.in.h, W = L.in.w, C = L.c_in;
  cols.resize(oh * ow, L.rows());
  if (!L.is_conv) {
    cols = Eigen::Map<const Eigen::RowVectorXf>(chw, C);
    return;
  }
  const size_t plane = static_cast<size_t>(H) * W;
  for (int oy = 0; oy < oh; ++oy)
    for (int ox = 0; ox < ow; ++ox) {
      float* row = cols.row(oy * ow + ox).data();
      for (int kx = 0; kx < L.k_w; ++kx) {
        const int x = ox * L.stride_w - L.pad_l + kx;
        for (int ky = 0; ky < L.k_h; ++ky) {
          const int y = oy * L.stride_h - L.pad_t + ky;
          float* dst = row + (kx * L.k_h + ky) * C;
          if (y < 0 || y >= H || x < 0 || x >= W) {
            std::fill(dst, dst + C, 0.0f);
            continue;
          }
          const float* src = chw + static_cast<size_t>(y) * W + x;
          for (int c = 0; c < C; ++c) dst[c] = src[c * plane];
        }
      }
    }
}

void LinearBackend::multiply_activation(int layer, const LinearLayer& L, const float* chw, RowMatrixXf& scratch,
                                        Eigen::MatrixXf& out) const {
  im2col(L, chw, scratch);
  multiply(layer, scratch, out);
}

namespace {

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

/// y = a op b element-wise (float32, IEEE: a division by zero is an infinity, as in torch),
/// each input repeated along its axes of extent 1.
void binary(OpKind kind, const Shape& sa, const Shape& sb, const Shape& out, const std::vector<float>& a,
            const std::vector<float>& b, std::vector<float>& y) {
  switch (kind) {
    case OpKind::Add:
      return broadcast(sa, sb, out, a, b, y, [](float u, float v) { return u + v; });
    case OpKind::Sub:
      return broadcast(sa, sb, out, a, b, y, [](float u, float v) { return u - v; });
    case OpKind::Mul:
      return broadcast(sa, sb, out, a, b, y, [](float u, float v) { return u * v; });
    case OpKind::Div:
      return broadcast(sa, sb, out, a, b, y, [](float u, float v) { return u / v; });
    case OpKind::Linear:
    case OpKind::Relu:
    case OpKind::MaxPool:
    case OpKind::AvgPool:
    case OpKind::GlobalAvgPool:
    case OpKind::Flatten:
    case OpKind::Slice:
    case OpKind::Pad:
    case OpKind::Affine:
    case OpKind::Activation:
    case OpKind::Softmax:
    case OpKind::Concat:
    case OpKind::Shuffle:
      break;
  }
  throw std::logic_error("binary: not an element-wise operation of two values");
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

/// A linear layer through the backend: y (C x H x W) = W x + bias.
void linear_op(const Model& m, const Op& op, const LinearBackend& backend, const std::vector<float>& x,
               std::vector<float>& y, LayerTrace* trace, RowMatrixXf& cols, Eigen::MatrixXf& prod) {
  const LinearLayer& L = m.linear[op.linear];
  if (trace && trace->record_inputs) {
    im2col(L, x.data(), cols);
    trace->inputs[op.linear] = cols;
    backend.multiply(op.linear, cols, prod);
  } else {
    backend.multiply_activation(op.linear, L, x.data(), cols, prod);
  }
  y.resize(L.out.size());
  const int pixels = L.out.h * L.out.w;
  for (int c = 0; c < L.c_out; ++c)
    for (int p = 0; p < pixels; ++p) y[static_cast<size_t>(c) * pixels + p] = prod(p, c) + L.bias(c);
  if (trace) trace->outputs[op.linear] = prod.rowwise() + L.bias.transpose();
}

}  // namespace

void digital_op(const Op& op, const std::vector<Shape>& shapes, const std::vector<const std::vector<float>*>& xs,
                std::vector<float>& y) {
  const std::vector<float>& x = *xs.at(0);
  const Shape& in = shapes.at(static_cast<size_t>(op.in.at(0)));
  const Shape& out = shapes.at(static_cast<size_t>(op.out));
  switch (op.kind) {
    case OpKind::Relu:
      y.resize(x.size());
      for (size_t k = 0; k < x.size(); ++k) y[k] = x[k] > 0 ? x[k] : 0.0f;
      return;
    case OpKind::Add:
    case OpKind::Sub:
    case OpKind::Mul:
    case OpKind::Div:
      return binary(op.kind, in, shapes.at(static_cast<size_t>(op.in.at(1))), out, x, *xs.at(1), y);
    case OpKind::Affine: {
      y.resize(x.size());
      const int hw = in.h * in.w;
      for (int c = 0; c < in.c; ++c)
        for (int p = 0; p < hw; ++p)
          y[static_cast<size_t>(c) * hw + p] = x[static_cast<size_t>(c) * hw + p] * op.scale(c) + op.shift(c);
      return;
    }
    case OpKind::MaxPool:
    case OpKind::AvgPool:
      return pool(op, in, out, x, y);
    case OpKind::GlobalAvgPool:
      return global_avg_pool(in, x, y);
    case OpKind::Flatten:
      y = x;
      return;
    case OpKind::Slice:
      return slice(op, in, out, x, y);
    case OpKind::Pad:
      return pad(op, in, out, x, y);
    case OpKind::Activation:
      y.resize(x.size());
      for (size_t k = 0; k < x.size(); ++k) y[k] = activation(op, x[k]);
      return;
    case OpKind::Softmax:
      return softmax(in, x, y);
    case OpKind::Concat: {  // C x H x W blocks one after the other: the channels concatenated
      y.resize(out.size());
      size_t at = 0;
      for (const std::vector<float>* v : xs) {
        std::copy(v->begin(), v->end(), y.begin() + static_cast<std::ptrdiff_t>(at));
        at += v->size();
      }
      return;
    }
    case OpKind::Shuffle: {
      const size_t plane = static_cast<size_t>(in.h) * in.w;
      y.resize(x.size());
      for (int c = 0; c < out.c; ++c)
        std::copy_n(x.begin() + static_cast<std::ptrdiff_t>(op.perm[static_cast<size_t>(c)] * plane), plane,
                    y.begin() + static_cast<std::ptrdiff_t>(c * plane));
      return;
    }
    case OpKind::Linear:
      throw std::logic_error("digital_op: a linear layer runs on a backend");
  }
}

Eigen::VectorXf run_image(const Model& m, const float* input, const LinearBackend& backend, LayerTrace* trace) {
  std::vector<std::vector<float>> v(m.values.size());
  v[0].assign(input, input + m.input.size());
  if (trace) {
    trace->inputs.resize(m.linear.size());
    trace->outputs.resize(m.linear.size());
  }
  RowMatrixXf cols;
  Eigen::MatrixXf prod;
  for (const Op& op : m.ops) {
    if (op.kind == OpKind::Linear) {
      linear_op(m, op, backend, v[op.in[0]], v[op.out], trace, cols, prod);
      if (trace && trace->stop_after_linear == op.linear) return Eigen::VectorXf();
    } else {
      std::vector<const std::vector<float>*> xs;
      for (int i : op.in) xs.push_back(&v[i]);
      digital_op(op, m.values, xs, v[op.out]);
    }
  }
  const std::vector<float>& o = v[m.output];
  return Eigen::Map<const Eigen::VectorXf>(o.data(), static_cast<Eigen::Index>(o.size()));
}

std::vector<bool> linear_inputs_signed(const Model& m) {
  std::vector<char> nonnegative(m.values.size(), 0);
  bool input_nonnegative = m.pre.scale >= 0;
  for (size_t c = 0; c < m.pre.mean.size(); ++c)
    input_nonnegative = input_nonnegative && m.pre.mean[c] <= 0 && (c >= m.pre.std.size() || m.pre.std[c] > 0);
  if (!nonnegative.empty()) nonnegative[0] = input_nonnegative;
  std::vector<bool> out(m.linear.size(), true);
  for (const Op& op : m.ops) {
    auto in_nonneg = [&](size_t k) { return k < op.in.size() && nonnegative.at(op.in[k]) != 0; };
    bool result = false;
    switch (op.kind) {
      case OpKind::Linear:
        out.at(op.linear) = !in_nonneg(0);
        break;
      case OpKind::Relu:
        result = true;
        break;
      case OpKind::Add:
      case OpKind::Mul:
      case OpKind::Div:
        result = in_nonneg(0) && in_nonneg(1);
        break;
      case OpKind::Sub:
        break;
      case OpKind::MaxPool:
      case OpKind::AvgPool:
      case OpKind::GlobalAvgPool:
      case OpKind::Flatten:
      case OpKind::Slice:
      case OpKind::Shuffle:
        result = in_nonneg(0);
        break;
      case OpKind::Pad:
        result = in_nonneg(0) && op.pad_value >= 0;
        break;
      case OpKind::Concat:
        result = true;
        for (size_t k = 0; k < op.in.size(); ++k) result = result && in_nonneg(k);
        break;
      case OpKind::Activation:
        // Clip with a bound >= 0 below, and the sigmoids, never give a negative value.
        result = (op.activation == Activation::Clip && op.lo >= 0) || op.activation == Activation::Sigmoid ||
                 op.activation == Activation::HardSigmoid;
        break;
      case OpKind::Softmax:
        result = true;
        break;
      case OpKind::Affine:
        break;
    }
    if (op.out >= 0) nonnegative.at(op.out) = result;
  }
  return out;
}

std::vector<bool> linear_reads_image(const Model& m) {
  std::vector<bool> out(m.linear.size(), false);
  for (const Op& op : m.ops)
    if (reads_image(op)) out.at(op.linear) = true;
  return out;
}

}  // namespace xbarsim
