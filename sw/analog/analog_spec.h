#pragma once
/// Typed specifications of the analog datapath, parsed once from the configuration and
/// validated (timeloop style): every key of the sections mapping, mitigation, conversion,
/// calibration, converters and noise is read here and nowhere else. Names carry units.
#include <cstdint>
#include <string>

#include "sw/circuit/crossbar_params.h"
#include "sw/common/config.h"

namespace xbarsim {

enum class NegativeWeights { Shift, Differential };
enum class SumX { Digital, Analog };
enum class MappingScheme { Dense, Sparse };

/// Section `mapping.`: how a weight matrix becomes crossbar conductances.
struct MappingSpec {
  int max_rows = 0, max_cols = 0;  ///< largest crossbar; 0 = unbounded (one crossbar per layer)
  NegativeWeights negative = NegativeWeights::Shift;
  SumX sum_x = SumX::Digital;
  double g_headroom = 0;  ///< weights map to [g_min, g_max (1 - headroom)]
  MappingScheme scheme = MappingScheme::Dense;
  bool differential() const { return negative == NegativeWeights::Differential; }
  bool analog_sum() const { return sum_x == SumX::Analog; }
  /// Physical columns holding `logical` weight columns: a pair per column (differential),
  /// plus the sum(X) reference column (analog sum).
  int physical_columns(int logical) const { return logical * (differential() ? 2 : 1) + (analog_sum() ? 1 : 0); }
  /// Weight columns one crossbar of max_cols physical columns holds (0 = unbounded).
  /// InputError when max_cols cannot hold one column.
  int logical_columns_per_crossbar() const;
};

enum class ConversionKind { None, Signal, Matrix };
enum class Mitigation {
  None,
  Calibration,
  Conversion,
  ConversionCalibration,
  MatrixConversion,
  MatrixConversionCalibration
};

/// Section `mitigation.` (or `study.method`): the mitigation method.
struct MitigationSpec {
  Mitigation method = Mitigation::ConversionCalibration;
  ConversionKind conversion() const;
  bool calibrate() const;
  const char* name() const;
};
/// The method of that name; InputError naming `key` for anything else.
MitigationSpec mitigation_from_name(const std::string& name, const std::string& key = "mitigation.method");

enum class ConversionSignal { Constant, MaxInput, MeanInput };
enum class AmplitudeMode { Fixed, Optimize, Paper };

/// Section `conversion.`.
struct ConversionSpec {
  ConversionSignal signal = ConversionSignal::Constant;
  AmplitudeMode amplitude_mode = AmplitudeMode::Fixed;
  double amplitude = 0.1;  ///< constant signal as a fraction of crossbar.v_in_max (Fixed)
  bool column_scaling = true;
  int max_iterations = 60;  ///< matrix conversion fixed-point iterations
  double tolerance = 1e-9;  ///< matrix conversion: max |G_eff - T| / max T
};

enum class CalibrationSignal { Random, RandomDecreasing, Shuffled };

/// Section `calibration.`.
struct CalibrationSpec {
  int samples = 10;
  CalibrationSignal signal = CalibrationSignal::Shuffled;
  uint64_t seed = 7;
};

/// Section `converters.`: one key per converter property, serving function and cost alike.
struct ConvertersSpec {
  int dac_bits = 0;  ///< 0 = none (ideal analog forwarding; priced at the library's reference bits)
  int adc_bits = 0;
  double adc_margin = 0.05;
  bool adc_offset_subtraction = true;
  int adc_columns_per_adc = 0;  ///< crossbar columns sharing one ADC; 0 = the component library's
  /// Input pre-distortion: each DAC code goes through a lookup table to V = f^-1(x), so that an
  /// isolated memristor's current is linear in the code (sinh memristors; a no-op for linear ones).
  bool dac_predistortion = false;
};

/// Section `noise.`.
struct NoiseSpec {
  double sigma_s = 0;  ///< programming error (S)
  uint64_t seed = 11;
};

MappingSpec parse_mapping_spec(const ConfigTree& cfg, const CrossbarParams& xbar);
ConversionSpec parse_conversion_spec(const ConfigTree& cfg);
CalibrationSpec parse_calibration_spec(const ConfigTree& cfg);
ConvertersSpec parse_converters_spec(const ConfigTree& cfg);
NoiseSpec parse_noise_spec(const ConfigTree& cfg);

}  // namespace xbarsim
