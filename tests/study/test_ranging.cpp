// Ranging (issue 50): the full scales of weights, inputs and ADCs by max, percentile or mse,
// checked against hand computations, closed forms and published clips; the keys' defaults
// under a device model and the refusals.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "sw/analog/analog_layer.h"
#include "sw/analog/ranging.h"
#include "sw/analog/weight_mapping.h"
#include "sw/common/config.h"
#include "sw/inference/crossbar_backend.h"
#include "sw/nn/dataset.h"
#include "sw/nn/presets.h"

using namespace xbarsim;

TEST(Ranging, PercentileIsTheNearestRank) {
  std::vector<double> v = {10, 9, 8, 7, 6, 5, 4, 3, 2, 1};
  EXPECT_EQ(percentile_of(v, 50), 5);    // ceil(0.5 x 10) = 5th value
  EXPECT_EQ(percentile_of(v, 95), 10);   // ceil(9.5) = 10th
  EXPECT_EQ(percentile_of(v, 100), 10);  // the maximum
  EXPECT_EQ(percentile_of(v, 10), 1);
  EXPECT_EQ(percentile_of(v, 0.01), 1);  // at least the first
  std::vector<double> none;
  EXPECT_EQ(percentile_of(none, 50), 0);
}

TEST(Ranging, QuantizationErrorByHand) {
  // Two levels on [0, 1] (step 0.5): 0.3 rounds to 0.5 (0.04), 1.2 clips to 1 (0.04), 0.75
  // rounds to 1 (0.0625); without levels only the clip counts.
  const double m[] = {0.3, 1.2, 0.75};
  EXPECT_NEAR(magnitude_quantization_error(m, 3, 1.0, 2), 0.04 + 0.04 + 0.0625, 1e-15);
  EXPECT_NEAR(magnitude_quantization_error(m, 3, 1.0, 0), 0.04, 1e-15);
}

TEST(Ranging, ClipSearchFindsTheMinimum) {
  // A smooth error with its minimum at 0.37 of the range, and one falling all the way to hi.
  const double c = search_clip(2.0, [](double x) { return (x - 0.74) * (x - 0.74) + 1; });
  EXPECT_NEAR(c, 0.74, 1e-6);
  EXPECT_EQ(search_clip(2.0, [](double x) { return 5 - x; }), 2.0);
  EXPECT_EQ(search_clip(0.0, [](double) { return 1.0; }), 0.0);
}

// The mse clip of a Gaussian at b bits against ACIQ's (Banner et al., NeurIPS 2019, Table 1:
// alpha / sigma = 1.71, 2.15, 2.55 for 2, 3, 4 bits of a symmetric uniform quantizer). ACIQ
// approximates the rounding noise as step^2 / 12 (2^b bins on [-alpha, alpha]); the exact
// rounding of the mse search differs by about 1 % at these widths.
TEST(Ranging, MseClipOfAGaussianIsAciqs) {
  std::mt19937_64 rng(1);
  std::normal_distribution<double> n(0, 1);
  std::vector<double> mags(200000);
  for (double& m : mags) m = std::abs(n(rng));
  const double aciq[] = {1.71, 2.15, 2.55};
  for (int b = 2; b <= 4; ++b) {
    // 2^b bins two-sided: 2^(b-1) steps of the magnitude on [0, c].
    const double c = magnitude_range(mags, RangeMethod::Mse, 100, std::ldexp(1.0, b - 1));
    EXPECT_NEAR(c, aciq[b - 2], 0.03 * aciq[b - 2]) << b << " bits";  // 1.69, 2.13, 2.55 here
  }
  // Max and percentile by rank.
  std::vector<double> sorted = mags;
  std::sort(sorted.begin(), sorted.end());
  EXPECT_EQ(magnitude_range(mags, RangeMethod::Max, 0, 4), sorted.back());
  EXPECT_EQ(magnitude_range(mags, RangeMethod::Percentile, 99, 4), sorted[static_cast<size_t>(0.99 * 200000) - 1]);
}

TEST(Ranging, ValueRangeByHand) {
  const std::vector<double> v = {-1, 0, 1, 2, 3, 4, 5, 6, 7, 100};
  const auto mx = value_range(v, RangeMethod::Max, 0, 255);
  EXPECT_EQ(mx.first, -1);
  EXPECT_EQ(mx.second, 100);
  const auto pc = value_range(v, RangeMethod::Percentile, 90, 255);  // 10th and 90th by rank
  EXPECT_EQ(pc.first, -1);
  EXPECT_EQ(pc.second, 7);
  // mse with 2 levels: the outlier costs (100 - hi)^2 if clipped, the rest step^2 / 4 each;
  // clipping is worth it only when the nine small values' rounding outweighs 100 - hi.
  const auto ms = value_range(v, RangeMethod::Mse, 0, 255);
  EXPECT_LE(ms.second, 100);
  EXPECT_GT(ms.second, 7);  // at 255 levels the outlier's clip costs more than all the rounding
  EXPECT_EQ(value_range(v, RangeMethod::Mse, 0, 0), mx);  // no quantizer: nothing to gain
}

namespace {
MappingSpec differential(int weight_bits) {
  MappingSpec m;
  m.negative = NegativeWeights::Differential;
  m.weight_bits = weight_bits;
  return m;
}
CrossbarParams params() {
  CrossbarParams x;
  x.g_min_s = 1e-6;
  x.g_max_s = 1e-4;
  return x;
}
}  // namespace

TEST(Ranging, WeightRangesByHand) {
  // Column 0: ten weights 0.1..1.0 and an outlier 10; column 1: -0.5, 0.2, ... small.
  Eigen::MatrixXd w(11, 2);
  for (int i = 0; i < 10; ++i) {
    w(i, 0) = 0.1 * (i + 1);
    w(i, 1) = (i % 2 ? -0.05 : 0.05) * (i + 1) / 10.0;
  }
  w(10, 0) = 10;
  w(10, 1) = -0.5;
  RangingSpec r;
  r.weights = RangeMethod::Max;
  r.weight_scale = WeightScale::Crossbar;
  WeightRanges max = weight_ranges(w, differential(4), r, params());
  EXPECT_EQ(max.clipped, 0);
  EXPECT_EQ(max.hi(0), 10);
  EXPECT_EQ(max.hi(1), 10);  // one range for the crossbar
  EXPECT_EQ(max.lo(1), -0.5);
  // Percentile 90 of the crossbar's 22 |w|: rank ceil(19.8) = 20 of the sorted magnitudes
  // (0.005.. 0.05 ten, 0.1..1.0 ten, 0.5, 10): the 20th is 0.9 (0.5 sits among them).
  r.weights = RangeMethod::Percentile;
  r.weight_percentile = 90;
  WeightRanges pc = weight_ranges(w, differential(4), r, params());
  EXPECT_NEAR(pc.hi(0), 0.9, 1e-15);
  EXPECT_EQ(pc.clipped, 2);  // 1.0 and 10
  // Per column: column 0's rank ceil(9.9) = 10 of 11 is 1.0 (10 clipped); column 1's is 0.05.
  r.weight_scale = WeightScale::Column;
  WeightRanges col = weight_ranges(w, differential(4), r, params());
  EXPECT_NEAR(col.hi(0), 1.0, 1e-15);
  EXPECT_NEAR(col.lo(1), -0.05, 1e-15);
  EXPECT_EQ(col.clipped, 2);  // 10, and -0.5 below -0.05
  // mse at 4 bits (sign + 3 bits: 7 steps of c / 7) on exact cells: the clip minimising the
  // rounding and clipping error of column 0, by brute force over a fine grid.
  r.weights = RangeMethod::Mse;
  WeightRanges mse = weight_ranges(w, differential(4), r, params());
  double best_c = 0, best_e = 1e300;
  for (int k = 1; k <= 100000; ++k) {
    const double c = 10.0 * k / 100000, step = c / 7;
    double e = 0;
    for (int i = 0; i < 11; ++i) {
      const double v = std::min(w(i, 0), c);
      const double q = std::round(v / step) * step;
      e += (w(i, 0) - q) * (w(i, 0) - q);
    }
    if (e < best_e) best_e = e, best_c = c;
  }
  EXPECT_NEAR(mse.hi(0), best_c, 2e-3 * best_c);
  EXPECT_LT(best_c, 10.0);  // the outlier is clipped a little: the bulk's rounding gains more
}

TEST(Ranging, MapWeightsWithoutRangesIsTheMaxMapping) {
  std::mt19937_64 rng(2);
  std::uniform_real_distribution<double> u(-1, 1);
  Eigen::MatrixXd w(16, 5);
  for (Eigen::Index k = 0; k < w.size(); ++k) w.data()[k] = u(rng);
  const Block blk{0, 0, 16, 5};
  for (int bits : {0, 5}) {
    const MappingSpec m = differential(bits);
    RangingSpec r;
    const MappedWeights a = map_weights(w, blk, m, params());
    const MappedWeights b = map_weights(w, blk, m, params(), weight_ranges(w, m, r, params()));
    EXPECT_EQ(a.g_target, b.g_target);
    EXPECT_EQ(a.s, b.s);
    // Per column: each pair's span is its own column's largest |w| (S per weight unit g_span / max).
    r.weight_scale = WeightScale::Column;
    const MappedWeights c = map_weights(w, blk, m, params(), weight_ranges(w, m, r, params()));
    const double span = params().g_max_s - params().g_min_s;
    for (int j = 0; j < 5; ++j) EXPECT_NEAR(c.s(2 * j), span / w.col(j).cwiseAbs().maxCoeff(), 1e-9 * c.s(2 * j));
  }
}

TEST(Ranging, DefaultsFollowTheDevice) {
  const AnalogConfig ideal = parse_analog_config(ConfigTree::load("", {}));
  EXPECT_EQ(ideal.mapping.negative, NegativeWeights::Shift);
  EXPECT_EQ(ideal.ranging.weights, RangeMethod::Max);
  EXPECT_EQ(ideal.ranging.weight_scale, WeightScale::Crossbar);
  EXPECT_EQ(ideal.mapping.g_headroom, 0.2);
  const AnalogConfig rram = parse_analog_config(ConfigTree::load("", {"device.model=rram-wan2022"}));
  EXPECT_EQ(rram.mapping.negative, NegativeWeights::Differential);
  EXPECT_EQ(rram.ranging.weights, RangeMethod::Mse);
  EXPECT_EQ(rram.ranging.weight_scale, WeightScale::Column);
  EXPECT_EQ(rram.mapping.g_headroom, 0.0);
  // Set explicitly, they are what they say.
  const AnalogConfig set = parse_analog_config(ConfigTree::load(
      "", {"device.model=rram-wan2022", "ranging.weights=max", "ranging.weight_scale=layer", "mapping.g_headroom=0.1"}));
  EXPECT_EQ(set.ranging.weights, RangeMethod::Max);
  EXPECT_EQ(set.ranging.weight_scale, WeightScale::Layer);
  EXPECT_EQ(set.mapping.g_headroom, 0.1);
}

namespace {
std::string refusal(const std::vector<std::string>& sets) {
  try {
    parse_analog_config(ConfigTree::load("", sets));
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}
}  // namespace

TEST(Ranging, RefusalsNameTheKey) {
  const std::string shift = refusal({"device.model=pcm-joshi2020", "mapping.negative=shift"});
  EXPECT_NE(shift.find("'mapping.negative' (shift)"), std::string::npos) << shift;
  EXPECT_NE(shift.find("differential"), std::string::npos) << shift;
  const std::string column = refusal({"ranging.weight_scale=column", "mapping.negative=shift"});
  EXPECT_NE(column.find("'ranging.weight_scale' (column)"), std::string::npos) << column;
  EXPECT_EQ(refusal({"ranging.weight_scale=column", "mapping.negative=differential"}), "");
  EXPECT_EQ(refusal({"ranging.weight_scale=column", "converters.adc_offset_subtraction=false"}), "");
  const std::string method = refusal({"ranging.adc=median"});
  EXPECT_NE(method.find("'ranging.adc': 'median' is not one of: max, percentile, mse"), std::string::npos) << method;
  const std::string weights = refusal({"ranging.weights=median"});
  EXPECT_NE(weights.find("max, percentile, mse, auto"), std::string::npos) << weights;
  for (const char* p : {"ranging.weight_percentile=0", "ranging.input_percentile=100.5", "ranging.adc_percentile=-1"}) {
    const std::string e = refusal({p});
    EXPECT_NE(e.find("must be in (0, 100]"), std::string::npos) << p << ": " << e;
  }
  EXPECT_NE(refusal({"converters.adc_margin=-0.1"}).find("converters.adc_margin"), std::string::npos);
}

// Bias correction folds the mean output shift into the digital bias: over the calibration
// images the bias passes read, the first layer's mean output per channel equals the
// software's (computed here by the software backend), where without it a device's spread and
// the ADC leave it off.
TEST(Ranging, BiasCorrectionMatchesTheSoftwareMeanOnTheCalibrationImages) {
  const Model m = make_preset("lenet", 3);
  const Dataset calib = random_dataset(m.input, 8, 4);
  const auto first_layer_mean = [&](const LinearBackend& b) {
    Eigen::VectorXd sum = Eigen::VectorXd::Zero(m.linear[0].c_out);
    double rows = 0;
    std::vector<float> x(m.input.size());
    for (int k = 0; k < calib.count(); ++k) {
      calib.preprocess(k, m.pre, x.data());
      CrossbarBackend::set_image(CrossbarBackend::kBiasImages + static_cast<uint64_t>(k));
      LayerTrace t;
      t.record_inputs = false;
      t.stop_after_linear = 0;
      run_image(m, x.data(), b, &t);
      sum += t.outputs[0].colwise().sum().transpose().cast<double>();
      rows += static_cast<double>(t.outputs[0].rows());
    }
    return Eigen::VectorXd(sum / rows);
  };
  const Eigen::VectorXd soft = first_layer_mean(SoftwareBackend(m));
  const auto mean_error = [&](bool correct) {
    AnalogConfig ac = parse_analog_config(ConfigTree::load(
        "", {"device.model=constant", "device.program_sigma_us=3", "converters.adc_bits=5", "calibration.samples=20", "mitigation.method=calibration",
             std::string("ranging.bias_correction=") + (correct ? "true" : "false")}));
    CrossbarBackend xb(m, ac);
    xb.program(calib, 256);
    return (first_layer_mean(xb) - soft).cwiseAbs().maxCoeff() / soft.cwiseAbs().maxCoeff();
  };
  const double off = mean_error(false), on = mean_error(true);
  EXPECT_GT(off, 1e-3) << off;
  EXPECT_LT(on, 1e-5) << on << " against " << off;  // float outputs: the mean to their rounding
}
