// Each bit-serial read of a bit-sliced crossbar against ngspice: a 64 x 32 array (8 weight
// columns of four 2-bit cells, 8-bit weights) read by 1-bit DACs (8 reads per vector).
#include <gtest/gtest.h>

#include "sw/analog/analog_layer.h"
#include "sw/analog/synthetic.h"
#include "tests/circuit/ngspice_reference.h"

using namespace xbarsim;
using namespace xbarsim::testing_ngspice;

namespace {
void expect_slices_agree(bool nonlinear, int vectors) {
  ASSERT_TRUE(have_ngspice()) << "ngspice is required as the circuit reference: run scripts/setup.sh";
  AnalogConfig c;
  c.set_method("none", "test");
  if (nonlinear) {
    c.xbar.memristor.model = MemristorModel::Sinh;
    c.xbar.transistor.model = TransistorModel::Level1;
  }
  c.converters.input_bits = 8;
  c.converters.dac_bits = 1;
  c.converters.adc_bits = 0;
  c.mapping.cell_bits = 2;
  c.mapping.weight_bits = 8;
  const double x_max = 1.0;
  const Eigen::MatrixXd w = synthetic_kernel("gaussian", 64, 8, 21);
  AnalogLayer layer(c, w, x_max, false);
  layer.program(Eigen::MatrixXd());
  ASSERT_EQ(layer.crossbars(), 1);
  AnalogLayer::RowMat<double> xq = synthetic_inputs(vectors, 64, 0.3, x_max, 22);
  layer.dac_inplace<double>(xq);
  AnalogLayer::Codes codes;
  layer.slice_inputs<double>(xq, codes);
  AnalogLayer::ReadCurrents<double> cur;
  layer.analog<double>(0, codes, 0, vectors, cur);
  const Eigen::MatrixXd got = cur.i.matrix();
  ASSERT_EQ(got.rows(), 8 * vectors);
  // The values each read applies, from the slicing's definition: read v * 8 + s applies digit
  // s of vector v's codes.
  const InputSlicing& sl = layer.input_slicing();
  Eigen::MatrixXd xs(8 * vectors, 64);
  for (int v = 0; v < vectors; ++v)
    for (int s = 0; s < 8; ++s)
      for (int k = 0; k < 64; ++k) xs(v * 8 + s, k) = sl.digit_value(std::lround(xq(v, k) / sl.step), s);
  // The conductances the layer programs (no conversion, no noise) and the read voltages.
  const Eigen::MatrixXd g = map_weights(w, layer.block(0), c.mapping, c.xbar).g_target;
  ASSERT_EQ(g.cols(), 32);
  const Eigen::MatrixXd ref = ngspice_currents(c.xbar, g, layer.volts(xs));
  const double scale = ref.cwiseAbs().maxCoeff();
  double worst = 0;
  for (Eigen::Index r = 0; r < ref.rows(); ++r)
    for (Eigen::Index j = 0; j < ref.cols(); ++j) {
      const double d = std::abs(got(r, j) - ref(r, j)) / scale;
      worst = std::max(worst, d);
      EXPECT_LT(d, 1e-6) << "read " << r << " (slice " << r % 8 << ") column " << j;
    }
  ::testing::Test::RecordProperty("worst_difference_of_largest_current", std::to_string(worst));
}
}  // namespace

TEST(BitSlicedNgspice, EverySliceLinear) { expect_slices_agree(false, 6); }
TEST(BitSlicedNgspice, EverySliceNonlinear) { expect_slices_agree(true, 1); }
