#pragma once
/// Typed specifications of the analog datapath, parsed once from the configuration and
/// validated (timeloop style): every key of the sections mapping, mitigation, conversion,
/// calibration and converters is read here (device: sw/device/device.h) and nowhere else. Names carry units.
#include <algorithm>
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
  /// crossbar.cell_bits: a cell holds one of 2^cell_bits conductance levels evenly spaced on
  /// [g_min, g_max (1 - headroom)]; 0 = an analog cell (any conductance in that range).
  int cell_bits = 0;
  /// mapping.weight_bits: weights are quantized to this many bits (shift: an unsigned code of
  /// W - w_lo; differential: a sign and weight_bits - 1 magnitude bits per column of the pair);
  /// 0 = unquantized, or cell_bits when cells have levels (one cell per weight).
  int weight_bits = 0;
  /// device.spare_columns: columns every crossbar holds besides its mapped ones, to replace
  /// faulty columns (the inventory prices them as crossbar columns with their readout).
  int spare_columns = 0;
  bool differential() const { return negative == NegativeWeights::Differential; }
  bool analog_sum() const { return sum_x == SumX::Analog; }
  /// Columns of one polarity: 2 (differential pair) or 1 (shift).
  int polarities() const { return differential() ? 2 : 1; }
  /// Bits of one polarity's weight code (0 = unquantized).
  int code_bits() const {
    const int w = weight_bits ? weight_bits : cell_bits;
    return differential() && weight_bits ? w - 1 : w;
  }
  /// Cells (adjacent columns) one polarity of a weight occupies: ceil(code bits / cell_bits).
  int weight_slices() const {
    return cell_bits && code_bits() > cell_bits ? (code_bits() + cell_bits - 1) / cell_bits : 1;
  }
  /// Physical columns of one weight column: its polarities times its slices.
  int columns_per_weight() const { return polarities() * weight_slices(); }
  /// Physical columns holding `logical` weight columns: every weight's slices of each polarity
  /// (differential pairs), plus the sum(X) reference column (analog sum).
  int physical_columns(int logical) const { return logical * columns_per_weight() + (analog_sum() ? 1 : 0); }
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

enum class AdcRange { Calibrated, PerRead, Full };
const char* to_string(AdcRange r);  ///< its name in converters.adc_range

/// Section `converters.`: one key per converter property, serving function and cost alike.
struct ConvertersSpec {
  /// Activation precision: inputs are quantized to input_bits and streamed in slices of
  /// dac_bits (see InputSlicing); 0 = none: the DAC's resolution, one slice (the seed paper).
  int input_bits = 0;
  int dac_bits = 0;  ///< bits per input slice; 0 = none (ideal DAC; priced at the library's reference bits)
  int adc_bits = 0;
  /// Bits of an activation code: input_bits, or dac_bits when input_bits is none (0 = analog).
  int activation_bits() const { return input_bits ? input_bits : dac_bits; }
  /// The precision of the network's image: the inputs of the layers that read the network's
  /// input itself (NeuRRAM reads 4-bit pixels and 3-bit activations); 0 = none: as every layer.
  int image_bits = 0;
  /// The converters of one layer: a layer that reads the image takes image_bits as its
  /// input_bits, and as its dac_bits too when one read takes a whole activation (dac_bits >=
  /// activation_bits(): the DAC reads a whole code in one read); every other layer these.
  ConvertersSpec for_layer(bool reads_image) const {
    if (!reads_image || image_bits == 0) return *this;
    ConvertersSpec c = *this;
    if (dac_bits != 0 && dac_bits >= activation_bits()) c.dac_bits = std::max(dac_bits, image_bits);
    c.input_bits = image_bits;
    c.image_bits = 0;
    return c;
  }
  /// calibrated: each column's range from calibration currents (+ adc_margin); per_read: the
  /// same for each read (input slice) of a vector, the ADC's reference set per read; full: the
  /// physical full range of a slice column, rows x (2^cell_bits - 1) x (2^dac_bits - 1) levels,
  /// one level per code while adc_bits suffice (else 2^k levels per code).
  AdcRange adc_range = AdcRange::Calibrated;
  double adc_margin = 0.05;
  bool adc_offset_subtraction = true;
  int adc_columns_per_adc = 0;  ///< crossbar columns sharing one ADC; 0 = the component library's
  /// Input pre-distortion: each DAC code goes through a lookup table to V = f^-1(x), so that an
  /// isolated memristor's current is linear in the code (sinh memristors; a no-op for linear ones).
  bool dac_predistortion = false;
  /// The readout's input-referred noise per read and column (A, Gaussian sigma): thermal and
  /// kT/C noise of the column and sense circuit, independent of the signal.
  double readout_noise_a = 0;
};


/// mapping.g_headroom: auto with device.model ideal.
constexpr double kIdealHeadroom = 0.2;
MappingSpec parse_mapping_spec(const ConfigTree& cfg, const CrossbarParams& xbar);
ConversionSpec parse_conversion_spec(const ConfigTree& cfg);
CalibrationSpec parse_calibration_spec(const ConfigTree& cfg);
ConvertersSpec parse_converters_spec(const ConfigTree& cfg);

}  // namespace xbarsim
