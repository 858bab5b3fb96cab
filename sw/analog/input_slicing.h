#pragma once
/// Bit-serial inputs: how one layer's activation codes are streamed through dac_bits-wide
/// DACs. An input quantized to a code q (converters.input_bits, or the DAC's bits) is applied
/// in `slices` crossbar reads, LSB first; read s applies digit u_s as u_s x_max / (2^dac_bits - 1)
/// (the DAC's full scale is the layer's x_max) and its recovered output is weighted by
/// weight[s] in the shift-and-add, so that sum_s weight[s] * digit value[s] = q * step.
///  - unsigned inputs: q in [0, 2^B - 1], digits of dac_bits bits, place 2^(s dac_bits);
///  - signed inputs: sign-magnitude quantization (q in [-(2^m - 1), 2^m - 1], m = B - 1, zero
///    a level), streamed as the (m+1)-bit two's complement pattern: ceil(m / dac_bits)
///    magnitude slices of its low m bits (place 2^(s dac_bits)) and one sign slice, bit m
///    applied at full scale with place -2^m. Every read is unipolar (0 .. v_in_max).
/// One slice (dac_bits >= B, or no DAC) applies the code itself, signed inputs as negative
/// voltages: the seed paper's multi-bit DAC.
#include <algorithm>
#include <cmath>
#include <vector>

namespace xbarsim {

struct InputSlicing {
  int slices = 1;
  int dac_bits = 0;            ///< bits of one digit
  int magnitude_bits = 0;      ///< m: bits of the code's magnitude (B unsigned, B - 1 signed)
  bool sign_slice = false;     ///< the last slice is the two's complement sign bit
  double step = 1;             ///< input units per code
  double x_max = 1;            ///< the DAC's full scale (input units)
  std::vector<double> weight;  ///< per slice: shift-and-add weight of its recovered output

  bool serial() const { return slices > 1; }
  /// Full-scale digit of one DAC read.
  long digit_max() const { return (1L << dac_bits) - 1; }
  /// The (m+1)-bit two's complement pattern of code q (q itself when q >= 0).
  long pattern(long q) const { return q & ((1L << (magnitude_bits + 1)) - 1); }
  /// Digit s of a pattern p is (p >> digit_shift(s)) & digit_mask(s); read s applies it as
  /// that many digit_unit(s) (input units).
  int digit_shift(int s) const { return is_sign(s) ? magnitude_bits : s * dac_bits; }
  long digit_mask(int s) const {
    if (is_sign(s)) return 1;
    return digit_max() & (((1L << magnitude_bits) - 1) >> (s * dac_bits));  // the low m bits only
  }
  double digit_unit(int s) const { return is_sign(s) ? x_max : x_max / static_cast<double>(digit_max()); }
  long digit(long p, int s) const { return (p >> digit_shift(s)) & digit_mask(s); }
  /// The value (input units) read s applies for code q.
  double digit_value(long q, int s) const { return static_cast<double>(digit(pattern(q), s)) * digit_unit(s); }

 private:
  bool is_sign(int s) const { return sign_slice && s == slices - 1; }
};

/// The slicing of a layer whose inputs span [0, x_max] (or [-x_max, x_max] when signed),
/// quantized to `activation_bits` (0 = analog) and read through `dac_bits`-wide DACs.
inline InputSlicing make_input_slicing(int activation_bits, int dac_bits, bool signed_inputs, double x_max) {
  InputSlicing s;
  s.x_max = x_max;
  s.dac_bits = dac_bits;
  if (activation_bits <= 0) return s;
  s.magnitude_bits = signed_inputs ? std::max(activation_bits - 1, 1) : activation_bits;
  s.step = x_max / static_cast<double>((1L << s.magnitude_bits) - 1);
  if (dac_bits <= 0 || dac_bits >= activation_bits) return s;  // one multi-bit read
  const int magnitude_slices = (s.magnitude_bits + dac_bits - 1) / dac_bits;
  s.sign_slice = signed_inputs;
  s.slices = magnitude_slices + (signed_inputs ? 1 : 0);
  const double per_digit = s.step * static_cast<double>(s.digit_max()) / x_max;
  for (int k = 0; k < magnitude_slices; ++k) s.weight.push_back(std::ldexp(per_digit, k * dac_bits));
  if (signed_inputs) s.weight.push_back(-std::ldexp(s.step / x_max, s.magnitude_bits));
  return s;
}

}  // namespace xbarsim
