// Bit-serial inputs and bit-sliced weights against hand-computed integer products.
// On ideal wires the crossbar computes every slice's dot product of integer digits and
// levels; after shift-and-add the layer must return exactly (to far below one code step)
// q_x * step_x * W_q, with q_x and W_q quantized here by hand from their definitions
// (docs/physics.md, "Bit-serial inputs and bit-sliced weights").
#include <gtest/gtest.h>

#include <cmath>
#include <tuple>

#include "sw/analog/analog_layer.h"
#include "sw/analog/synthetic.h"

using namespace xbarsim;

namespace {

AnalogConfig ideal() {
  AnalogConfig c;
  c.xbar.r_wire_ohm = c.xbar.r_in_ohm = c.xbar.r_out_ohm = 1e-9;  // parasitics negligible
  c.set_method("none", "test");
  c.converters.adc_bits = 0;
  return c;
}

/// Inputs quantized by hand: unsigned codes round(x / step) on [0, 2^B - 1]; signed:
/// sign-magnitude with B - 1 magnitude bits.
Eigen::MatrixXd quantize_inputs(const Eigen::MatrixXd& x, int bits, bool is_signed, double x_max, double& step) {
  const int m = is_signed ? bits - 1 : bits;
  step = x_max / (std::ldexp(1.0, m) - 1);
  Eigen::MatrixXd q = x;
  for (Eigen::Index k = 0; k < q.size(); ++k) {
    const double v = std::min(std::abs(x.data()[k]), x_max);
    q.data()[k] = std::copysign(std::floor(v / step + 0.5), x.data()[k]) * step;
  }
  return q;
}

/// Weights quantized by hand, one crossbar: shift = w_lo + round((w - w_lo) / dw) dw with
/// dw = (max - w_lo) / (2^B - 1); differential = round(w / dw) dw with dw = max|w| / (2^(B-1) - 1).
Eigen::MatrixXd quantize_weights(const Eigen::MatrixXd& w, int bits, bool differential, double& dw) {
  Eigen::MatrixXd q = w;
  if (differential) {
    dw = w.cwiseAbs().maxCoeff() / (std::ldexp(1.0, bits - 1) - 1);
    for (Eigen::Index k = 0; k < q.size(); ++k)
      q.data()[k] = std::copysign(std::floor(std::abs(w.data()[k]) / dw + 0.5), w.data()[k]) * dw;
  } else {
    const double lo = std::min(w.minCoeff(), 0.0);
    dw = (w.maxCoeff() - lo) / (std::ldexp(1.0, bits) - 1);
    for (Eigen::Index k = 0; k < q.size(); ++k) q.data()[k] = lo + std::floor((w.data()[k] - lo) / dw + 0.5) * dw;
  }
  return q;
}

Eigen::MatrixXd signed_inputs(int n, int k, double x_max, uint64_t seed) {
  Eigen::MatrixXd x = synthetic_inputs(n, k, 0.3, x_max, seed);
  for (Eigen::Index i = 0; i < x.size(); i += 2) x.data()[i] = -x.data()[i];
  return x;
}

}  // namespace

TEST(InputSlicing, SliceCountsAndTwosComplementDigits) {
  EXPECT_EQ(make_input_slicing(8, 1, false, 1.0).slices, 8);
  EXPECT_EQ(make_input_slicing(8, 3, false, 1.0).slices, 3);
  EXPECT_EQ(make_input_slicing(8, 8, false, 1.0).slices, 1);
  EXPECT_EQ(make_input_slicing(8, 1, true, 1.0).slices, 8);  // 7 magnitude bits + the sign slice
  EXPECT_EQ(make_input_slicing(8, 2, true, 1.0).slices, 5);
  EXPECT_EQ(make_input_slicing(0, 1, false, 1.0).slices, 1);
  // q = -3 with B = 4: the pattern 1101; low bits 1, 0, 1 and the sign bit (place -8).
  const InputSlicing s = make_input_slicing(4, 1, true, 2.0);
  ASSERT_EQ(s.slices, 4);
  const double expect[] = {2.0, 0.0, 2.0, 2.0};
  double sum = 0;
  for (int k = 0; k < 4; ++k) {
    EXPECT_EQ(s.digit_value(-3, k), expect[k]) << k;
    sum += s.weight[k] * s.digit_value(-3, k);
  }
  EXPECT_NEAR(sum, -3 * s.step, 1e-15);
}

TEST(WeightSlicing, ColumnsPerWeightAndPartition) {
  MappingSpec m;
  m.cell_bits = 2;
  m.weight_bits = 8;
  EXPECT_EQ(m.weight_slices(), 4);
  EXPECT_EQ(m.physical_columns(16), 64);
  m.max_cols = 128;
  EXPECT_EQ(m.logical_columns_per_crossbar(), 32);
  m.negative = NegativeWeights::Differential;  // 7 magnitude bits per polarity: 4 cells each
  EXPECT_EQ(m.weight_slices(), 4);
  EXPECT_EQ(m.physical_columns(16), 128);
  EXPECT_EQ(m.logical_columns_per_crossbar(), 16);
  m.sum_x = SumX::Analog;
  EXPECT_EQ(m.logical_columns_per_crossbar(), 15);
  m.cell_bits = 3;  // ceil(7 / 3)
  EXPECT_EQ(m.weight_slices(), 3);
}

// Every slice count, signed and unsigned inputs, shift and differential weights, one and
// several crossbars: exact before the ADC.
class SlicedProduct : public ::testing::TestWithParam<std::tuple<int, int, bool, bool>> {};

TEST_P(SlicedProduct, EqualsTheIntegerProductBeforeTheAdc) {
  const auto [dac_bits, cell_bits, is_signed, differential] = GetParam();
  const int input_bits = 8, weight_bits = 8, K = 40, N = 6;
  const double x_max = 1.5;
  const Eigen::MatrixXd w = synthetic_kernel("gaussian", K, N, 17);
  const Eigen::MatrixXd x = is_signed ? signed_inputs(25, K, x_max, 3) : synthetic_inputs(25, K, 0.4, x_max, 3);
  for (int max_rows : {0, 16}) {
    AnalogConfig c = ideal();
    c.converters.input_bits = input_bits;
    c.converters.dac_bits = dac_bits;
    c.mapping.cell_bits = cell_bits;
    c.mapping.weight_bits = weight_bits;
    c.mapping.negative = differential ? NegativeWeights::Differential : NegativeWeights::Shift;
    c.mapping.max_rows = max_rows;
    AnalogLayer layer(c, w, x_max, is_signed);
    layer.program(Eigen::MatrixXd());
    // The reference: per crossbar (its own weight range) the integer product of codes.
    double step = 0;
    const Eigen::MatrixXd xq = quantize_inputs(x, input_bits, is_signed, x_max, step);
    Eigen::MatrixXd ref = Eigen::MatrixXd::Zero(x.rows(), N);
    double unit = 0;
    for (int b = 0; b < layer.crossbars(); ++b) {
      const Block& blk = layer.block(b);
      double dw = 0;
      const Eigen::MatrixXd wq =
          quantize_weights(w.block(blk.row0, blk.col0, blk.rows, blk.cols), weight_bits, differential, dw);
      ref.middleCols(blk.col0, blk.cols) += xq.middleCols(blk.row0, blk.rows) * wq;
      unit = std::max(unit, step * dw);
    }
    const double err = (layer.forward(x) - ref).cwiseAbs().maxCoeff();
    // Far below one unit of the integer product (a wrong digit or level is off by at least
    // one): the integers are recovered exactly; what remains is the 1e-9 ohm wires' residue.
    EXPECT_LT(err, 1e-3 * unit) << "max_rows " << max_rows << ": " << layer.input_slicing().slices << " input slices";
  }
}

INSTANTIATE_TEST_SUITE_P(Slices, SlicedProduct,
                         ::testing::Combine(::testing::Values(1, 2, 3, 8), ::testing::Values(1, 2, 4),
                                            ::testing::Bool(), ::testing::Bool()));

// With the full-range ADC and enough bits every slice column's level count is converted
// exactly; with fewer the low levels are lost (the test can fail).
TEST(SlicedProduct, FullRangeAdcIsExactWithEnoughBits) {
  const int K = 32, N = 4, cell_bits = 2, dac_bits = 1;
  const double x_max = 1.0;
  const Eigen::MatrixXd w = synthetic_kernel("gaussian", K, N, 5);
  const Eigen::MatrixXd x = synthetic_inputs(30, K, 0.3, x_max, 6);
  auto error_with = [&](int adc_bits) {
    AnalogConfig c = ideal();
    c.converters.input_bits = 8;
    c.converters.dac_bits = dac_bits;
    c.converters.adc_bits = adc_bits;
    c.converters.adc_range = AdcRange::Full;
    c.mapping.cell_bits = cell_bits;
    c.mapping.weight_bits = 8;
    AnalogLayer layer(c, w, x_max, false);
    layer.program(Eigen::MatrixXd());
    double step = 0, dw = 0;
    const Eigen::MatrixXd ref = quantize_inputs(x, 8, false, x_max, step) * quantize_weights(w, 8, false, dw);
    return (layer.forward(x) - ref).cwiseAbs().maxCoeff() / (step * dw);
  };
  // rows x (2^cell_bits - 1) x (2^dac_bits - 1) = 96 levels: 7 bits.
  EXPECT_LT(error_with(7), 1e-6);
  EXPECT_LT(error_with(12), 1e-6);
  EXPECT_GT(error_with(5), 0.5);
}

// Action counts of the shift-and-add: one read per slice, every slice column converted.
TEST(SlicedProduct, ReadsAndConversionsPerVector) {
  AnalogConfig c = ideal();
  c.converters.input_bits = 8;
  c.converters.dac_bits = 2;
  c.mapping.cell_bits = 2;
  c.mapping.weight_bits = 8;
  const Eigen::MatrixXd w = synthetic_kernel("gaussian", 10, 3, 1);
  AnalogLayer layer(c, w, 1.0, false);
  layer.program(Eigen::MatrixXd());
  AnalogLayer::RowMat<float> xq = synthetic_inputs(5, 10, 0.2, 1.0, 2).cast<float>();
  layer.dac_inplace<float>(xq);
  AnalogLayer::Codes codes;
  layer.slice_inputs<float>(xq, codes);
  AnalogLayer::ReadCurrents<float> cur;
  layer.analog<float>(0, codes, 0, 5, cur);
  EXPECT_EQ(cur.i.rows(), 4 * 5);  // 8 bits / 2 per read
  EXPECT_EQ(cur.i.cols(), 3 * 4);  // 4 cells per weight
  // Each read's input sum is its digits' sum at the read's unit.
  const InputSlicing& sl = layer.input_slicing();
  for (int v = 0; v < 5; ++v)
    for (int s = 0; s < 4; ++s) {
      double sum = 0;
      for (int k = 0; k < 10; ++k) sum += sl.digit_value(std::lround(xq(v, k) / sl.step), s);
      EXPECT_NEAR(cur.sum_x[v * 4 + s], sum, 1e-6) << v << " " << s;
    }
}
