#include "sw/nn/network.h"

#include <algorithm>
#include <limits>

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
    const Shape out = m.values[op.out];
    std::vector<float>& y = v[op.out];
    const std::vector<float>& x = v[op.in[0]];
    const Shape in = m.values[op.in[0]];
    switch (op.kind) {
      case OpKind::Linear: {
        const LinearLayer& L = m.linear[op.linear];
        if (trace && trace->record_inputs) {
          im2col(L, x.data(), cols);
          trace->inputs[op.linear] = cols;
          backend.multiply(op.linear, cols, prod);
        } else {
          backend.multiply_activation(op.linear, L, x.data(), cols, prod);
        }
        y.resize(out.size());
        const int pixels = out.h * out.w;
        for (int c = 0; c < L.c_out; ++c)
          for (int p = 0; p < pixels; ++p) y[static_cast<size_t>(c) * pixels + p] = prod(p, c) + L.bias(c);
        if (trace) {
          trace->outputs[op.linear] = prod.rowwise() + L.bias.transpose();
        }
        break;
      }
      case OpKind::Relu:
        y.resize(x.size());
        for (size_t k = 0; k < x.size(); ++k) y[k] = x[k] > 0 ? x[k] : 0.0f;
        break;
      case OpKind::Add: {
        const std::vector<float>& b = v[op.in[1]];
        y.resize(x.size());
        for (size_t k = 0; k < x.size(); ++k) y[k] = x[k] + b[k];
        break;
      }
      case OpKind::Affine: {
        y.resize(x.size());
        const int hw = in.h * in.w;
        for (int c = 0; c < in.c; ++c)
          for (int p = 0; p < hw; ++p)
            y[static_cast<size_t>(c) * hw + p] = x[static_cast<size_t>(c) * hw + p] * op.scale(c) + op.shift(c);
        break;
      }
      case OpKind::MaxPool:
      case OpKind::AvgPool: {
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
                  if (iy < 0 || iy >= in.h || ix < 0 || ix >= in.w) continue;
                  const float val = x[(static_cast<size_t>(c) * in.h + iy) * in.w + ix];
                  acc = is_max ? std::max(acc, val) : acc + val;
                  ++count;
                }
              y[(static_cast<size_t>(c) * out.h + oy) * out.w + ox] = is_max ? acc : acc / count;
            }
        break;
      }
      case OpKind::GlobalAvgPool: {
        y.resize(out.size());
        const int hw = in.h * in.w;
        for (int c = 0; c < in.c; ++c) {
          double s = 0;
          for (int p = 0; p < hw; ++p) s += x[static_cast<size_t>(c) * hw + p];
          y[c] = static_cast<float>(s / hw);
        }
        break;
      }
      case OpKind::Flatten:
        y = x;
        break;
      case OpKind::Slice:
        y.resize(out.size());
        for (int c = 0; c < out.c; ++c)
          for (int yy = 0; yy < out.h; ++yy)
            for (int xx = 0; xx < out.w; ++xx)
              y[(static_cast<size_t>(c) * out.h + yy) * out.w + xx] =
                  x[(static_cast<size_t>(op.start[0] + c * op.step[0]) * in.h + op.start[1] + yy * op.step[1]) * in.w +
                    op.start[2] + xx * op.step[2]];
        break;
      case OpKind::Pad:
        y.assign(out.size(), op.pad_value);
        for (int c = 0; c < in.c; ++c)
          for (int yy = 0; yy < in.h; ++yy)
            for (int xx = 0; xx < in.w; ++xx)
              y[(static_cast<size_t>(c + op.pad_lo[0]) * out.h + yy + op.pad_lo[1]) * out.w + xx + op.pad_lo[2]] =
                  x[(static_cast<size_t>(c) * in.h + yy) * in.w + xx];
        break;
    }
  }
  const std::vector<float>& o = v[m.output];
  return Eigen::Map<const Eigen::VectorXf>(o.data(), static_cast<Eigen::Index>(o.size()));
}

}  // namespace xbarsim
