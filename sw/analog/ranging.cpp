#include "sw/analog/ranging.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace xbarsim {

const char* to_string(RangeMethod m) {
  switch (m) {
    case RangeMethod::Max:
      return "max";
    case RangeMethod::Percentile:
      return "percentile";
    case RangeMethod::Mse:
      return "mse";
  }
  return "?";
}

const char* to_string(WeightScale s) {
  switch (s) {
    case WeightScale::Crossbar:
      return "crossbar";
    case WeightScale::Layer:
      return "layer";
    case WeightScale::Column:
      return "column";
  }
  return "?";
}

const char* to_string(AdcScope s) {
  switch (s) {
    case AdcScope::Column:
      return "column";
    case AdcScope::Layer:
      return "layer";
  }
  return "?";
}

namespace {
/// A method key; `automatic` (when given) is what `auto` means.
RangeMethod method_of(const ConfigTree& cfg, const std::string& key, const RangeMethod* automatic = nullptr) {
  std::vector<std::pair<std::string, RangeMethod>> names = {{to_string(RangeMethod::Max), RangeMethod::Max},
                                                            {to_string(RangeMethod::Percentile), RangeMethod::Percentile},
                                                            {to_string(RangeMethod::Mse), RangeMethod::Mse}};
  if (automatic) names.emplace_back("auto", *automatic);
  return require_enum<RangeMethod>(cfg, key, names);
}
}  // namespace

RangingSpec parse_ranging_spec(const ConfigTree& cfg) {
  RangingSpec r;
  // auto: the seed paper's max per crossbar with exact cells; the mse clip per column under a
  // device model (docs/results.md, "Ranging under real devices", the table that chose it).
  const bool device = cfg.get_string("device.model") != "ideal";
  const RangeMethod auto_weights = device ? RangeMethod::Mse : RangeMethod::Max;
  r.weights = method_of(cfg, "ranging.weights", &auto_weights);
  r.weight_percentile = cfg.get_double("ranging.weight_percentile");
  r.weight_scale = require_enum<WeightScale>(cfg, "ranging.weight_scale",
                                             {{to_string(WeightScale::Crossbar), WeightScale::Crossbar},
                                              {to_string(WeightScale::Layer), WeightScale::Layer},
                                              {to_string(WeightScale::Column), WeightScale::Column},
                                              {"auto", device ? WeightScale::Column : WeightScale::Crossbar}});
  r.inputs = method_of(cfg, "ranging.inputs");
  r.input_percentile = cfg.get_double("ranging.input_percentile");
  r.adc = method_of(cfg, "ranging.adc");
  r.adc_percentile = cfg.get_double("ranging.adc_percentile");
  r.adc_scope = require_enum<AdcScope>(
      cfg, "ranging.adc_scope", {{to_string(AdcScope::Column), AdcScope::Column}, {to_string(AdcScope::Layer), AdcScope::Layer}});
  r.bias_correction = cfg.get_bool("ranging.bias_correction");
  return r;
}

double percentile_of(std::vector<double>& v, double p) {
  if (v.empty()) return 0;
  // Nearest rank: the smallest value with at least p % of the values at or below it.
  const auto n = static_cast<double>(v.size());
  const size_t rank = static_cast<size_t>(std::clamp(std::ceil(p / 100.0 * n), 1.0, n)) - 1;
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(rank), v.end());
  return v[rank];
}

double search_clip(double hi, const std::function<double(double)>& error) {
  if (!(hi > 0)) return hi;
  int best = kClipGrid;
  double best_e = error(hi);
  for (int k = kClipGrid - 1; k >= 1; --k) {
    const double e = error(hi * k / kClipGrid);
    if (e < best_e) {
      best_e = e;
      best = k;
    }
  }
  // Golden section on [best - 1, best + 1] grid steps (within (0, hi]).
  double a = hi * std::max(best - 1, 0) / kClipGrid, b = hi * std::min(best + 1, kClipGrid) / kClipGrid;
  const double r = (std::sqrt(5.0) - 1) / 2;
  double c = b - r * (b - a), d = a + r * (b - a);
  double ec = c > 0 ? error(c) : std::numeric_limits<double>::infinity(), ed = error(d);
  for (int it = 0; it < 24; ++it) {
    if (ec < ed) {
      b = d;
      d = c;
      ed = ec;
      c = b - r * (b - a);
      ec = c > 0 ? error(c) : std::numeric_limits<double>::infinity();
    } else {
      a = c;
      c = d;
      ec = ed;
      d = a + r * (b - a);
      ed = error(d);
    }
  }
  const double found = ec < ed ? c : d, found_e = std::min(ec, ed);
  if (found_e < best_e) return found;
  return hi * best / kClipGrid;
}

double magnitude_quantization_error(const double* m, Eigen::Index n, double c, double levels) {
  double e = 0;
  if (levels > 0) {
    const double step = c / levels, inv = 1 / step;
    for (Eigen::Index i = 0; i < n; ++i) {
      const double v = m[i];
      if (v >= c) {
        e += (v - c) * (v - c);
      } else {
        const double q = std::floor(v * inv + 0.5) * step;
        e += (v - q) * (v - q);
      }
    }
  } else {
    for (Eigen::Index i = 0; i < n; ++i)
      if (m[i] > c) e += (m[i] - c) * (m[i] - c);
  }
  return e;
}

double magnitude_range(std::vector<double> m, RangeMethod method, double p, double levels) {
  if (m.empty()) return 0;
  const double hi = *std::max_element(m.begin(), m.end());
  switch (method) {
    case RangeMethod::Max:
      return hi;
    case RangeMethod::Percentile: {
      const double c = percentile_of(m, p);
      return c > 0 ? c : hi;  // a percentile in the zeros leaves no range: nothing clipped
    }
    case RangeMethod::Mse:
      if (!(levels > 0)) return hi;
      return search_clip(hi, [&](double c) {
        return magnitude_quantization_error(m.data(), static_cast<Eigen::Index>(m.size()), c, levels);
      });
  }
  return hi;
}

std::pair<double, double> value_range(std::vector<double> v, RangeMethod method, double p, double levels) {
  if (v.empty()) return {0.0, 0.0};
  const auto [mn, mx] = std::minmax_element(v.begin(), v.end());
  const double lo = *mn, hi = *mx;
  switch (method) {
    case RangeMethod::Max:
      return {lo, hi};
    case RangeMethod::Percentile: {
      // percentile_of only reorders v, so both percentiles come from the same vector
      const double a = percentile_of(v, 100.0 - p), b = percentile_of(v, p);
      return b > a ? std::make_pair(a, b) : std::make_pair(lo, hi);
    }
    case RangeMethod::Mse: {
      if (!(levels > 0) || !(hi > lo)) return {lo, hi};
      const double anchor = lo <= 0 && hi >= 0 ? 0.0 : lo > 0 ? lo : hi;
      const auto n = static_cast<Eigen::Index>(v.size());
      const double* d = v.data();
      const auto error = [&](double t) {
        const double a = anchor + t * (lo - anchor), b = anchor + t * (hi - anchor);
        if (!(b > a)) return std::numeric_limits<double>::infinity();
        const double step = (b - a) / levels, inv = 1 / step;
        double e = 0;
        for (Eigen::Index i = 0; i < n; ++i) {
          const double c = std::min(std::max(d[i], a), b);
          const double q = a + std::floor((c - a) * inv + 0.5) * step;
          e += (d[i] - q) * (d[i] - q);
        }
        return e;
      };
      const double t = search_clip(1.0, error);
      return {anchor + t * (lo - anchor), anchor + t * (hi - anchor)};
    }
  }
  return {lo, hi};
}

double input_full_scale(const Eigen::MatrixXd& samples, double input_max, bool signed_inputs,
                        const RangingSpec& ranging, int activation_bits) {
  if (ranging.inputs == RangeMethod::Max || activation_bits <= 0 || samples.size() == 0) return input_max;
  const int qbits = signed_inputs ? std::max(activation_bits - 1, 1) : activation_bits;
  std::vector<double> mags(static_cast<size_t>(samples.size()));
  Eigen::Map<Eigen::MatrixXd>(mags.data(), samples.rows(), samples.cols()) = samples.cwiseAbs();
  const double c = magnitude_range(std::move(mags), ranging.inputs, ranging.input_percentile,
                                   std::ldexp(1.0, qbits) - 1);
  return c > 0 ? std::min(c, input_max) : input_max;
}

}  // namespace xbarsim
