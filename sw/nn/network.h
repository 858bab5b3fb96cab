#pragma once
/// Per-image execution of a Model with a pluggable backend for the linear layers.
#include <Eigen/Dense>
#include <vector>

#include "sw/nn/model.h"

namespace xbarsim {

/// Row-major float matrix: one im2col row (one iteration's input vector) is contiguous.
using RowMatrixXf = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

/// Executes the multiply of the linear layers (Conv/Gemm) of a model.
class LinearBackend {
 public:
  virtual ~LinearBackend() = default;
  /// `cols`: iterations x K (one image's im2col matrix, dense-mapping row order);
  /// `out`: iterations x c_out, without the bias (added digitally by the caller).
  virtual void multiply(int layer, const RowMatrixXf& cols, Eigen::MatrixXf& out) const = 0;
  /// Called by run_image with the layer's input activation (C x H x W). The default builds
  /// the im2col matrix in `scratch` and calls multiply(); a backend that builds the input
  /// vectors itself (the SystemC platform's shift registers) overrides it.
  virtual void multiply_activation(int layer, const LinearLayer& L, const float* chw, RowMatrixXf& scratch,
                                   Eigen::MatrixXf& out) const;
};

/// Exact float32 software GEMM.
class SoftwareBackend : public LinearBackend {
 public:
  explicit SoftwareBackend(const Model& m) : model_(m) {}
  void multiply(int layer, const RowMatrixXf& cols, Eigen::MatrixXf& out) const override {
    out.noalias() = cols * model_.linear[layer].weight;
  }

 private:
  const Model& model_;
};

/// im2col of one image (C x H x W, row-major) for layer L: one row per output pixel
/// (row-major over out_h x out_w), columns in the order r = (kx*k_h + ky)*c_in + c;
/// padding taps are zero.
void im2col(const LinearLayer& L, const float* chw, RowMatrixXf& cols);

/// What one image's pass recorded: every linear layer's input (im2col) and output (with
/// bias; iterations x c_out).
struct LayerTrace {
  bool record_inputs = true;  ///< false: outputs only (saves one im2col copy per layer)
  /// >= 0: the pass stops after this linear layer (run_image then returns no logits).
  int stop_after_linear = -1;
  std::vector<RowMatrixXf> inputs;
  std::vector<Eigen::MatrixXf> outputs;
};

/// One digital (non-linear-layer) op on one image: ReLU, Add/Sub/Mul/Div of two values
/// (broadcasting), BatchNorm as affine, the element-wise activations, softmax, max/average
/// pooling, global average pooling, flatten, slice, pad, concatenation. `shapes`: every value's
/// shape (Model::values, indexed by op.in and op.out); `xs`: its inputs' values, in op.in order.
void digital_op(const Op& op, const std::vector<Shape>& shapes, const std::vector<const std::vector<float>*>& xs,
                std::vector<float>& y);

/// Per linear layer: its inputs may be negative. Static: the network input is non-negative
/// when every preprocessing mean is <= 0; a ReLU's output is non-negative, and pooling,
/// flatten, slice, pad (with a value >= 0), Add, Mul and Div keep non-negative inputs so;
/// everything else (Sub among them) may be negative. The crossbars quantize and stream a
/// layer's inputs by it (signed inputs take a sign), so every command counts the same reads.
std::vector<bool> linear_inputs_signed(const Model& m);

/// A linear op reads the network's input itself (value 0, the preprocessed image): the layers
/// that converters.image_bits quantizes.
inline bool reads_image(const Op& op) { return op.kind == OpKind::Linear && !op.in.empty() && op.in[0] == 0; }
/// Per linear layer: reads_image of its op.
std::vector<bool> linear_reads_image(const Model& m);

/// Runs one preprocessed image (C x H x W floats) through the model; returns the logits.
Eigen::VectorXf run_image(const Model& m, const float* input, const LinearBackend& backend,
                          LayerTrace* trace = nullptr);

}  // namespace xbarsim
