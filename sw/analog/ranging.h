#pragma once
/// Ranging (section `ranging.`): the full scales of weights, inputs (DACs) and ADCs, chosen from
/// the weights and the calibration images by one of three methods, and the bias correction.
///  - max: the largest magnitude (nothing clipped; the seed paper);
///  - percentile: the given percentile of the magnitudes (the rest clipped);
///  - mse: the clip that minimises the expected squared error of what is represented: the
///    quantizer's rounding, the clipping and (weights) the device's spread on the cells
///    (docs/physics.md, "Ranging").
/// SystemC-free, allocation only in the searches (programming time, not in hot loops).
#include <Eigen/Dense>
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "sw/common/config.h"

namespace xbarsim {

enum class RangeMethod { Max, Percentile, Mse };
const char* to_string(RangeMethod m);  ///< its name in the ranging keys

/// Where one weight scale applies: every crossbar its own (its block's weights), one for the
/// layer, or one per output column (a digital gain per column after the ADC).
enum class WeightScale { Crossbar, Layer, Column };
const char* to_string(WeightScale s);

/// Where one ADC range applies: each column its own reference, or one for the layer.
enum class AdcScope { Column, Layer };
const char* to_string(AdcScope s);

/// Section `ranging.`.
struct RangingSpec {
  RangeMethod weights = RangeMethod::Max;
  double weight_percentile = 99.9;  ///< (0, 100] of |w|, with RangeMethod::Percentile
  WeightScale weight_scale = WeightScale::Crossbar;
  RangeMethod inputs = RangeMethod::Max;
  double input_percentile = 99.99;  ///< (0, 100] of |x| over the calibration images' inputs
  RangeMethod adc = RangeMethod::Max;
  double adc_percentile = 99.99;  ///< (0, 100] of a column's calibration currents
  AdcScope adc_scope = AdcScope::Column;
  /// The mean output shift of every output column over the calibration images' inputs (software
  /// minus crossbars), measured after calibration and folded into the digital bias.
  bool bias_correction = false;
  /// Whether the weights' scales change with the weights' statistics (anything but max per crossbar).
  bool clips_weights() const { return weights != RangeMethod::Max; }
};
RangingSpec parse_ranging_spec(const ConfigTree& cfg);

/// The p-th percentile (0 < p <= 100) of `v` (nearest rank on the sorted values; p = 100 is the
/// maximum); 0 for no values. Reorders v.
double percentile_of(std::vector<double>& v, double p);

/// The clip c in (0, hi] minimising error(c), for an error that is smooth in c away from a few
/// kinks: a grid of kClipGrid points on (0, hi], then a golden-section search on the two grid
/// intervals beside the best point. error(hi) is always evaluated, and hi is kept on ties.
double search_clip(double hi, const std::function<double(double)>& error);
constexpr int kClipGrid = 40;

/// The squared error of a uniform quantizer of `levels` steps on [0, c] (levels = 0: no
/// quantization, only clipping) summed over the magnitudes m (>= 0): rounding below c, and
/// (m - c)^2 above it.
double magnitude_quantization_error(const double* m, Eigen::Index n, double c, double levels);

/// The full scale of magnitudes m by `method` for a quantizer of `levels` steps on [0, c]
/// (0 = none, then mse keeps the maximum): the maximum, the percentile p, or the mse clip.
double magnitude_range(std::vector<double> m, RangeMethod method, double p, double levels);

/// The range [lo, hi] of signed values v (a column's currents) for a uniform quantizer of
/// `levels` steps by `method`: [min, max]; [the (100 - p)-th, the p-th percentile]; or [min, max]
/// shrunk toward its anchor (0 when inside it, else its end nearer 0) by the factor in (0, 1]
/// that minimises the summed squared error of the quantized values (levels = 0: [min, max]).
std::pair<double, double> value_range(std::vector<double> v, RangeMethod method, double p, double levels);

/// The DAC's full scale for input vectors `samples` (rows) whose largest magnitude is
/// `input_max`, by ranging.inputs for `activation_bits`-bit activations (a sign and bits - 1
/// magnitude bits when `signed_inputs`; 0 = analog inputs: `input_max`): never above input_max.
double input_full_scale(const Eigen::MatrixXd& samples, double input_max, bool signed_inputs,
                        const RangingSpec& ranging, int activation_bits);

}  // namespace xbarsim
