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
  AnalogLayer::RowMat<double> xq = synthetic_inputs(vectors, 64, 0.3, x_max, 22), xs;
  layer.dac_inplace<double>(xq);
  layer.slice_inputs<double>(xq, xs);
  ASSERT_EQ(xs.rows(), 8 * vectors);
  AnalogLayer::Mat<double> got;
  layer.analog<double>(0, xs, got);
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
      EXPECT_LT(d, 1e-6) << "read " << r << " (slice " << r / vectors << ") column " << j;
    }
  ::testing::Test::RecordProperty("worst_difference_of_largest_current", std::to_string(worst));
}
}  // namespace

TEST(BitSlicedNgspice, EverySliceLinear) { expect_slices_agree(false, 6); }
TEST(BitSlicedNgspice, EverySliceNonlinear) { expect_slices_agree(true, 1); }
