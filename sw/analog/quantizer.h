#pragma once
/// Uniform converters (DAC/ADC): round-to-nearest with clipping, or analog forwarding.
#include <cmath>
#include <string>

#include "sw/common/config.h"

namespace xbarsim {

/// A uniform quantizer over [lo, hi] with 2^bits levels (codes 0 .. 2^bits - 1).
/// bits = 0 means "none": values pass through unchanged (analog forwarding).
struct Quantizer {
  int bits = 0;
  double lo = 0.0;
  double hi = 1.0;

  bool enabled() const { return bits > 0; }
  double step() const { return (hi - lo) / ((1 << bits) - 1); }
  /// Code of x: round((clip(x) - lo) / step), halves rounded up.
  long code(double x) const {
    const double c = std::min(std::max(x, lo), hi);
    return static_cast<long>(std::floor((c - lo) / step() + 0.5));
  }
  /// Reconstructed value lo + code * step (x itself when disabled).
  double apply(double x) const {
    if (bits <= 0 || !(hi > lo)) return x;
    return lo + static_cast<double>(code(x)) * step();
  }
};

/// The same quantizer with its step precomputed, for hot loops (identical results).
struct FastQuantizer {
  explicit FastQuantizer(const Quantizer& q)
      : on(q.bits > 0 && q.hi > q.lo), lo(q.lo), hi(q.hi), step(on ? q.step() : 1.0) {}
  double apply(double x) const {
    if (!on) return x;
    const double c = std::min(std::max(x, lo), hi);
    return lo + std::floor((c - lo) / step + 0.5) * step;
  }
  bool on;
  double lo, hi, step;
};

/// Reads a bit count that may be the word `none` (0). Valid: none or 1..24.
int parse_bits(const ConfigTree& cfg, const std::string& key);

}  // namespace xbarsim
