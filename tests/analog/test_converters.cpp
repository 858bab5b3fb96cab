// Quantizers, partitioning, calibration fit and metrics against hand-computed values.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "sw/analog/calibration.h"
#include "sw/analog/error_metrics.h"
#include "sw/analog/partition.h"
#include "sw/analog/quantizer.h"

using namespace xbarsim;

TEST(Quantizer, ThreeBitsOnZeroToPointFour) {
  const Quantizer q{3, 0.0, 0.4};  // step 0.4/7
  EXPECT_EQ(q.code(0.1), 2);       // 0.1 / 0.0571 = 1.75 -> 2
  EXPECT_NEAR(q.apply(0.1), 0.8 / 7, 1e-15);
  EXPECT_EQ(q.code(0.0285), 0);  // 0.499 steps
  EXPECT_EQ(q.code(0.0286), 1);  // 0.5005 steps
  EXPECT_EQ(q.code(0.5), 7);     // clipped high
  EXPECT_EQ(q.code(-1.0), 0);    // clipped low
  EXPECT_DOUBLE_EQ(q.apply(0.4), 0.4);
}

TEST(Quantizer, SignedRangeAndNone) {
  const Quantizer q{2, -1.0, 1.0};  // levels -1, -1/3, 1/3, 1
  EXPECT_NEAR(q.apply(-0.2), -1.0 / 3, 1e-15);
  EXPECT_NEAR(q.apply(0.9), 1.0, 1e-15);
  const Quantizer none{0, 0, 1};
  EXPECT_EQ(none.apply(0.123456789), 0.123456789);
  EXPECT_EQ(none.apply(7.0), 7.0);
}

TEST(Partition, BalancedBlocks) {
  auto b = partition(576, 64, 64, 64);
  ASSERT_EQ(b.size(), 9u);
  for (const auto& x : b) {
    EXPECT_EQ(x.rows, 64);
    EXPECT_EQ(x.cols, 64);
  }
  b = partition(10, 5, 4, 0);
  ASSERT_EQ(b.size(), 3u);
  EXPECT_EQ(b[0].rows, 4);
  EXPECT_EQ(b[1].rows, 3);
  EXPECT_EQ(b[2].rows, 3);
  EXPECT_EQ(b[2].row0, 7);
  EXPECT_EQ(b[0].cols, 5);
  EXPECT_EQ(partition(7, 3, 0, 0).size(), 1u);
  EXPECT_EQ(partition(7, 9, 0, 4).size(), 3u);
}

TEST(Calibration, RecoversAnExactAffineMap) {
  Eigen::MatrixXd actual(4, 2), ideal(4, 2);
  actual << 1, 5, 2, 6, 3, 7, 4, 9;
  ideal.col(0) = 2 * actual.col(0).array() + 3;
  ideal.col(1) = -0.5 * actual.col(1).array() + 1;
  const ColumnFit f = fit_columns(actual, ideal);
  EXPECT_NEAR(f.gain(0), 2, 1e-12);
  EXPECT_NEAR(f.offset(0), 3, 1e-12);
  EXPECT_NEAR(f.gain(1), -0.5, 1e-12);
  EXPECT_NEAR(f.offset(1), 1, 1e-12);
  EXPECT_LT((f.apply(actual) - ideal).cwiseAbs().maxCoeff(), 1e-12);
}

TEST(Calibration, MatchesNormalEquations) {
  // The fit is actual ~ a ideal + b (the errors are in the crossbar's outputs), inverted:
  // gain = 1 / a, offset = -b / a. Checked against a QR solve of those normal equations.
  std::mt19937_64 rng(3);
  std::normal_distribution<double> n(0, 1);
  Eigen::MatrixXd actual(10, 3), ideal(10, 3);
  for (int i = 0; i < 10; ++i)
    for (int j = 0; j < 3; ++j) {
      ideal(i, j) = n(rng);
      actual(i, j) = ideal(i, j) / 1.5 + n(rng) * 0.1;
    }
  const ColumnFit f = fit_columns(actual, ideal);
  for (int j = 0; j < 3; ++j) {
    Eigen::MatrixXd a(10, 2);
    a.col(0) = ideal.col(j);
    a.col(1).setOnes();
    const Eigen::Vector2d coef = a.colPivHouseholderQr().solve(actual.col(j));
    EXPECT_TRUE(f.gain_fitted(j));
    EXPECT_NEAR(f.gain(j), 1 / coef(0), 1e-12);
    EXPECT_NEAR(f.offset(j), -coef(1) / coef(0), 1e-12);
  }
  // Constant column: unit gain, mean offset.
  Eigen::MatrixXd c = Eigen::MatrixXd::Constant(3, 1, 2.0), t(3, 1);
  t << 1, 2, 6;
  const ColumnFit g = fit_columns(c, t);
  EXPECT_EQ(g.gain(0), 1.0);
  EXPECT_NEAR(g.offset(0), 1.0, 1e-15);
}

// Issue 39, item 3 follow-up: GoogLeNet's inception4c.branch2.1 showed a mean error of 8e9 of
// its output range. Its crossbars' columns put all ten calibration outputs in one ADC code
// (they differed in the last bits of the recovery) or all but one, and the least-squares gain,
// sxy / sxx over a spread of rounding noise or one code, was -3.6e12 or -4013; real inputs then
// multiplied their errors by it. A gain is fitted only where the data determine it.
TEST(Calibration, OneAdcCodeStepGivesNoGain) {
  // Nine outputs in one code (0.5), one a code lower (step 0.001); the crossbar's error (0.1 on
  // the tenth vector) is not a gain. Hand computation of the old fit: mx = 0.4999, my = 0.51,
  // sxx = 9 (1e-4)^2 + (9e-4)^2 = 9e-7, sxy = 9 (1e-4)(-0.01) + (-9e-4)(0.09) = -9e-5: gain
  // -100, offset 0.51 + 100 x 0.4999 = 50.5, so an output of 0.6 became -9.5.
  Eigen::MatrixXd actual = Eigen::MatrixXd::Constant(10, 1, 0.5), ideal = Eigen::MatrixXd::Constant(10, 1, 0.5);
  actual(9, 0) = 0.499;
  ideal(9, 0) = 0.6;
  const ColumnFit f = fit_columns(actual, ideal, Eigen::VectorXd::Constant(1, 0.001));
  EXPECT_FALSE(f.gain_fitted(0));
  EXPECT_EQ(f.gain(0), 1.0);
  EXPECT_NEAR(f.offset(0), 0.51 - 0.4999, 1e-12);  // mean(ideal) - mean(actual)
  Eigen::MatrixXd real(1, 1);
  real << 0.6;
  EXPECT_NEAR(f.apply(real)(0, 0), 0.6101, 1e-12);
}

TEST(Calibration, OutputsEqualToRoundingGiveNoGain) {
  // Without an ADC step: outputs one unit in the last place apart (what the recovery's rounding
  // leaves of one ADC code) are one value. The old fit divided by sxx ~ 1e-33.
  const double a = 0.3, b = std::nextafter(0.3, 1.0);
  Eigen::MatrixXd actual(4, 1), ideal(4, 1);
  actual << a, b, a, b;
  ideal << 0.29, 0.31, 0.30, 0.30;
  const ColumnFit f = fit_columns(actual, ideal);
  EXPECT_FALSE(f.gain_fitted(0));
  EXPECT_EQ(f.gain(0), 1.0);
  EXPECT_NEAR(f.offset(0), 0.30 - (a + b) / 2, 1e-15);
}

TEST(Calibration, UndeterminedGainFallsBackToOffset) {
  // Four resolved outputs, but the ideal outputs do not follow them: a = s_xi / s_ii = -5 / 50 =
  // -0.1 (gain -10), residuals of actual -1.5, 0, 0, 1.5 (SSR 4.5), se(a) = sqrt(4.5 / 2 / 50)
  // = 0.21, se(gain) = se(a) / a^2 = 21 > 1: no gain; offset mean(ideal) - mean(actual) = -1.5.
  Eigen::MatrixXd actual(4, 1), ideal(4, 1);
  actual << 0, 1, 2, 3;
  ideal << 0, 5, -5, 0;
  const ColumnFit f = fit_columns(actual, ideal, Eigen::VectorXd::Zero(1));
  EXPECT_FALSE(f.gain_fitted(0));
  EXPECT_EQ(f.gain(0), 1.0);
  EXPECT_NEAR(f.offset(0), -1.5, 1e-15);
  // The same outputs with ideal = 2 actual + 1 + small residuals: gain fitted.
  ideal << 1.01, 2.99, 5.0, 7.0;
  const ColumnFit g = fit_columns(actual, ideal, Eigen::VectorXd::Constant(1, 0.01));
  EXPECT_TRUE(g.gain_fitted(0));
  // di = -2.99, -1.01, 1, 3: s_ii = 19.9602, s_xi = 9.99, gain = 1 / a = s_ii / s_xi.
  EXPECT_NEAR(g.gain(0), 19.9602 / 9.99, 1e-12);
}

// Issue 50, item 5: conversion + calibration with a 4-bit ADC fell below conversion alone
// (ResNet-20 80.9 % against 85.7 %). The old fit regressed the ideal outputs on the actual ones,
// whose errors (ADC rounding, device and read noise) are in the regressor: its gain is the true
// gain times var(s) / (var(s) + var(noise)) (regression dilution), so every calibrated output
// shrank. Here actual = ideal / g + noise with ideal ~ U(-1, 1) (variance 1/3) and noise sigma
// 0.3: the old slope is cov(ideal, actual) / var(actual) = (1/3 / g) / (1/3 / g^2 + 0.09),
// 0.787 for g = 1 (where nothing is wrong) and 1.099 for g = 1.25; the fit recovers 1 and 1.25.
TEST(Calibration, NoisyOutputsDoNotAttenuateTheGain) {
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(-1, 1);
  std::normal_distribution<double> noise(0, 0.3);
  const int rows = 20000;
  Eigen::MatrixXd actual(rows, 2), ideal(rows, 2);
  const double g[2] = {1.0, 1.25};
  for (int i = 0; i < rows; ++i)
    for (int j = 0; j < 2; ++j) {
      ideal(i, j) = u(rng);
      actual(i, j) = ideal(i, j) / g[j] + noise(rng);
    }
  const ColumnFit f = fit_columns(actual, ideal);
  EXPECT_NEAR(f.gain(0), 1.0, 0.02);  // old fit: 0.787
  EXPECT_TRUE(f.gain_fitted(1));
  EXPECT_NEAR(f.gain(1), 1.25, 0.02);  // old fit: 1.099
  // The calibrated outputs' mean squared error against the ideal ones is the noise's, g^2 0.09,
  // not more: the unit-gain column is left alone (its gain is not significantly off 1) or fitted
  // to within a few per mille.
  const Eigen::MatrixXd err = f.apply(actual) - ideal;
  EXPECT_NEAR(err.col(0).squaredNorm() / rows, 0.09, 0.005);
  EXPECT_NEAR(err.col(1).squaredNorm() / rows, 1.25 * 1.25 * 0.09, 0.008);
}

// A gain within its noise of 1 is not fitted: the estimate's error would be added to every
// output, and the offset alone does as well.
TEST(Calibration, AGainWithinItsNoiseOfOneIsNotFitted) {
  // Ten outputs at 4-bit steps of 1/8 from ideal = the same values: a = 1, no gain.
  Eigen::MatrixXd actual(10, 1), ideal(10, 1);
  for (int i = 0; i < 10; ++i) {
    ideal(i, 0) = (i - 5) / 8.0 + ((i % 3) - 1) * 0.01;
    actual(i, 0) = std::round(ideal(i, 0) * 8) / 8;
  }
  const ColumnFit f = fit_columns(actual, ideal, Eigen::VectorXd::Constant(1, 1 / 8.0));
  EXPECT_FALSE(f.gain_fitted(0));
  EXPECT_EQ(f.gain(0), 1.0);
}

TEST(Calibration, StepsCountOnlyResolvedOutputs) {
  // Three outputs a quarter step apart are one code's worth: no gain; a step of 0 resolves them.
  Eigen::MatrixXd actual(3, 1), ideal(3, 1);
  actual << 1.0, 1.25, 1.5;
  ideal << 2.0, 2.5, 3.0;
  EXPECT_FALSE(fit_columns(actual, ideal, Eigen::VectorXd::Constant(1, 1.0)).gain_fitted(0));
  const ColumnFit f = fit_columns(actual, ideal, Eigen::VectorXd::Zero(1));
  EXPECT_TRUE(f.gain_fitted(0));
  EXPECT_NEAR(f.gain(0), 2.0, 1e-12);
  EXPECT_NEAR(f.offset(0), 0.0, 1e-12);
}

TEST(Metrics, PaperDefinitions) {
  Eigen::MatrixXd ideal(3, 2), actual(3, 2);
  ideal << 0, 10, 2, 10, 4, 10;  // column 1 constant: falls back to the largest range (4)
  actual << 0.4, 10, 2, 9, 3.6, 10;
  const ErrorStats s = relative_error(actual, ideal);
  EXPECT_NEAR(s.column_mean(0), (0.1 + 0 + 0.1) / 3, 1e-15);
  EXPECT_NEAR(s.column_worst(0), 0.1, 1e-15);
  EXPECT_NEAR(s.column_worst(1), 0.25, 1e-15);
  EXPECT_NEAR(s.mean_relative_error, (0.1 + 0.1 + 0.25) / 6, 1e-15);
  EXPECT_NEAR(s.worst_relative_error, 0.25, 1e-15);
  EXPECT_NEAR(s.bit_accuracy_worst(), std::log2(1 / 0.25 + 1), 1e-12);
}

// Issue 39, item 3: eval's per-layer error divided each output's error by its channel's
// calibration range, which a nearly silent channel makes arbitrarily small (GoogLeNet reported
// a mean of 5.96e9). Now one scale for the layer, its output range over every channel.
TEST(LayerError, IsRelativeToTheLayersOutputRange) {
  // Three outputs of two channels. Channel 0 spans [0, 10] on the calibration images; channel 1
  // barely varies ([0, 2e-5]: a channel a ReLU nearly silenced).
  Eigen::MatrixXd ideal(3, 2), actual(3, 2);
  ideal << 0, 0, 5, 2e-5, 10, 0;
  actual << 0.1, 0.05, 5, 0, 9.8, 0;
  Eigen::VectorXd lo(2), hi(2);
  lo << 0, 0;
  hi << 10, 2e-5;
  const double range = layer_output_range(lo, hi);
  EXPECT_EQ(range, 10.0);  // max(hi) - min(lo)
  const ErrorTally t = layer_error(actual, ideal, range);
  // |errors| 0.1, 0, 0.2 | 0.05, 2e-5, 0, each / 10.
  EXPECT_EQ(t.count, 6);
  EXPECT_NEAR(t.mean(), (0.01 + 0 + 0.02 + 0.005 + 2e-6 + 0) / 6, 1e-15);
  EXPECT_NEAR(t.worst, 0.02, 1e-15);
  // Relative to each channel's own range (the old metric; the paper's for one crossbar), the
  // quiet channel's 0.05 becomes 0.05 / 2e-5 = 2500 and swamps the layer.
  const ErrorStats per_channel = relative_error(actual, ideal);
  EXPECT_NEAR(per_channel.worst_relative_error, 2500, 1e-9);
  // A layer whose outputs never varied: its errors are absolute (range 1).
  EXPECT_EQ(layer_output_range(Eigen::VectorXd::Zero(2), Eigen::VectorXd::Zero(2)), 1.0);
}

TEST(LayerError, WarningNamesTheLayerAndTheThreshold) {
  const std::string w = layer_error_warning("/conv1/Conv", 0.25);
  EXPECT_NE(w.find("layer /conv1/Conv: mean error 0.25 of its output range (over 0.1)"), std::string::npos) << w;
}
