#include "sw/nn/network.h"

#include <algorithm>
#include <stdexcept>

#include "sw/nn/ops.h"

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
  const OpInfo& info = op_info(op.kind);
  if (!info.run) throw std::logic_error("digital_op: a linear layer runs on a backend");
  info.run(op, shapes, xs, y);
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
    std::vector<bool> in(op.in.size());
    for (size_t k = 0; k < op.in.size(); ++k) in[k] = nonnegative.at(op.in[k]) != 0;
    if (op.kind == OpKind::Linear) out.at(op.linear) = in.empty() || !in[0];
    const bool result = op_info(op.kind).nonnegative(op, in);
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
