// Read noise (issue 40, item 3): every read of a crossbar sees a fresh fluctuation of every
// cell's conductance. For linear devices the layer adds it to the column currents in one product
// with the squared inputs, first order in dG through the exact G_eff; the reference here is a
// Monte Carlo of full circuit solves, each with its own noisy conductances, on a wired 64 x 32
// crossbar. Nonlinear devices solve every read with its noisy conductances (the same reference).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>

#include "sw/analog/analog_layer.h"
#include "sw/analog/synthetic.h"
#include "sw/circuit/crossbar_solver.h"

using namespace xbarsim;

namespace {

constexpr int kRows = 64, kCols = 32;

/// One 64 x 32 crossbar (shift mapping, the sum(X) digital), no converters, no mitigation, a
/// constant read fluctuation of `sigma_s` on every cell.
AnalogConfig config(double r_wire, double sigma_s, bool sinh) {
  AnalogConfig c;
  c.set_method("none", "test");
  c.mapping.max_rows = kRows;
  c.mapping.max_cols = kCols;
  c.xbar.r_wire_ohm = r_wire;
  c.xbar.r_in_ohm = r_wire;
  c.xbar.r_out_ohm = r_wire;
  if (sinh) c.xbar.memristor.model = MemristorModel::Sinh;
  c.device.kind = DeviceKind::Constant;
  c.device.read_sigma_s = sigma_s;
  return c;
}

/// Per column, the standard deviation of `samples` (reads x columns).
Eigen::VectorXd column_std(const Eigen::MatrixXd& samples) {
  const Eigen::RowVectorXd mean = samples.colwise().mean();
  return ((samples.rowwise() - mean).array().square().colwise().sum() / (samples.rows() - 1)).sqrt().transpose();
}

/// The reference: `n` full solves of the crossbar's conductances g, each read with its own
/// fluctuation N(0, sigma) on every cell, at the row voltages v.
Eigen::MatrixXd monte_carlo(const AnalogConfig& c, const Eigen::MatrixXd& g, const Eigen::RowVectorXd& v, double sigma,
                            int n, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> nd(0.0, sigma);
  SolverOptions one = c.solver;
  one.threads = 1;
  Eigen::MatrixXd out(n, g.cols());
  for (int s = 0; s < n; ++s) {
    Eigen::MatrixXd gs = g;
    for (Eigen::Index k = 0; k < gs.size(); ++k) gs.data()[k] += nd(rng);
    const auto solver = make_crossbar_solver(c.xbar, one);
    solver->program(gs);
    out.row(s) = solver->column_currents(v);
  }
  return out;
}

struct Comparison {
  double mean_ratio = 0, worst = 0;  ///< fast / reference column sigma: mean over columns, worst |1 - ratio|
};

/// The layer's column sigma for input x (fast, `fast_reads` reads of the same vector, one read
/// each) against the Monte Carlo's (`mc_reads` solves).
Comparison compare(const AnalogConfig& c, double sigma, int fast_reads, int mc_reads) {
  const Eigen::MatrixXd w = synthetic_kernel("gaussian", kRows, kCols, 5);
  AnalogLayer layer(c, w, 1.0, false);
  layer.program(Eigen::MatrixXd());
  const Eigen::RowVectorXd x = synthetic_inputs(1, kRows, 0.3, 1.0, 9).row(0);
  AnalogLayer::RowMat<double> xs = x.replicate(fast_reads, 1);
  AnalogLayer::Mat<double> cur;
  layer.analog<double>(0, xs, cur, /*image=*/3);
  const Eigen::VectorXd fast = column_std(cur);
  const Eigen::VectorXd ref =
      column_std(monte_carlo(c, layer.conductances(0), layer.volts(x), sigma, mc_reads, 17));
  Comparison r;
  const Eigen::ArrayXd ratio = fast.array() / ref.array();
  r.mean_ratio = ratio.mean();
  r.worst = (ratio - 1).abs().maxCoeff();
  return r;
}

}  // namespace

TEST(ReadNoise, LinearFastPathEqualsFullSolveMonteCarlo) {
  // 0.5 uS on cells of 3.3..67 uS, wires of 20 ohm (the series resistance a far cell sees is up to
  // ~2.6 kohm, so (G_eff / G)^2 is ~0.7 there: the sensitivity matters). The Monte Carlo's
  // column sigma from 3000 solves has a relative sampling error of 1/sqrt(2 x 2999) = 1.3 %;
  // the fast path's from 100 000 reads 0.22 %. Per column within 5.5 % (4 standard errors of
  // their ratio), the mean over the 32 columns within 1 % (4 of its 0.24 %).
  const double sigma = 0.5e-6;
  const Comparison wired = compare(config(20.0, sigma, false), sigma, 100000, 3000);
  EXPECT_NEAR(wired.mean_ratio, 1.0, 0.01);
  EXPECT_LT(wired.worst, 0.055);
  // Without the sensitivity (G_eff / G)^2 the fast sigma would be the ideal-wire one: the same
  // comparison on ideal wires must agree as well (and the wired sigma is measurably smaller).
  const Comparison ideal = compare(config(1e-6, sigma, false), sigma, 100000, 3000);
  EXPECT_NEAR(ideal.mean_ratio, 1.0, 0.01);
  std::printf("fast / Monte Carlo column sigma: wired %.4f (worst column %.3f), ideal wires %.4f\n", wired.mean_ratio,
              wired.worst, ideal.mean_ratio);
}

TEST(ReadNoise, EveryReadDrawsAFreshFluctuationKeyedByImageAndRead) {
  const AnalogConfig c = config(1.0, 1e-6, false);
  const Eigen::MatrixXd w = synthetic_kernel("gaussian", kRows, kCols, 5);
  AnalogLayer layer(c, w, 1.0, false);
  layer.program(Eigen::MatrixXd());
  const AnalogLayer::RowMat<double> x = synthetic_inputs(4, kRows, 0.3, 1.0, 9);
  AnalogLayer::Mat<double> a, b, other;
  layer.analog<double>(0, x, a, 7);
  layer.analog<double>(0, x, b, 7);
  layer.analog<double>(0, x, other, 8);
  EXPECT_EQ(a, b);  // the same image and reads: the same draws
  EXPECT_GT((a - other).cwiseAbs().minCoeff(), 0.0);
  // Read r of a batch is read r of the image: a batch of the first vector alone draws as row 0.
  AnalogLayer::Mat<double> first;
  layer.analog<double>(0, AnalogLayer::RowMat<double>(x.topRows(1)), first, 7);
  // (Equal up to the rounding of a product of one row against one of four: the noise's float
  // variance to 1e-7 of a sigma of about 1 % of the current.)
  EXPECT_LT((first.row(0) - a.row(0)).cwiseAbs().maxCoeff(), 1e-8 * a.cwiseAbs().maxCoeff());
}

TEST(ReadNoise, NonlinearDevicesSolveEveryReadWithItsNoisyConductances) {
  // sinh devices (k = 5): no first-order path, every read a Newton solve with G + dG. Its column
  // sigma against the same Monte Carlo: 300 reads each, relative sampling error 4.1 % each, the
  // mean over 32 columns within 5 % (about 3.5 standard errors of the ratio's mean).
  const double sigma = 0.5e-6;
  const AnalogConfig c = config(5.0, sigma, true);
  const Comparison r = compare(c, sigma, 300, 300);
  EXPECT_NEAR(r.mean_ratio, 1.0, 0.05);
}

TEST(ReadNoise, BitSerialReadsOfBinaryDigitsAddTheSameNoiseAsTheDenseProduct) {
  // 1-bit DACs, 8-bit signed inputs, 2-bit cells: float sums each read's digit rows of the
  // variance model (sparse), double multiplies the squared read values (dense). The draws are the
  // same; the two may differ only by float rounding, far below the noise itself.
  AnalogConfig c = config(1.0, 1e-6, false);
  c.mapping.cell_bits = 2;
  c.mapping.weight_bits = 8;
  c.converters.input_bits = 8;
  c.converters.dac_bits = 1;
  c.converters.readout_noise_a = 1e-8;
  const Eigen::MatrixXd w = synthetic_kernel("gaussian", kRows, 8, 5);
  AnalogLayer layer(c, w, 1.0, true);
  layer.program(Eigen::MatrixXd());
  Eigen::MatrixXd xs = synthetic_inputs(6, kRows, 0.3, 1.0, 9);
  xs.bottomRows(3) *= -1;  // signed: the sign slice's digits are negative
  const AnalogLayer::RowMat<double> xd = xs;
  const AnalogLayer::RowMat<float> xf = xs.cast<float>();
  AnalogLayer::Mat<double> yd, other;
  AnalogLayer::Mat<float> yf;
  layer.forward<double>(xd, yd, false, 5);
  layer.forward<double>(xd, other, false, 6);
  layer.forward<float>(xf, yf, false, 5);
  const double noise = std::sqrt((yd - other).squaredNorm() / yd.size());
  EXPECT_GT(noise, 0.0);
  EXPECT_LT((yf.cast<double>() - yd).cwiseAbs().maxCoeff(), 0.01 * noise);
}
