#include "sw/analog/analog_spec.h"

#include "sw/analog/quantizer.h"

namespace xbarsim {

namespace {
struct MitigationName {
  const char* name;
  Mitigation method;
};
constexpr MitigationName kMitigations[] = {
    {"none", Mitigation::None},
    {"calibration", Mitigation::Calibration},
    {"conversion", Mitigation::Conversion},
    {"conversion+calibration", Mitigation::ConversionCalibration},
    {"matrix-conversion", Mitigation::MatrixConversion},
    {"matrix-conversion+calibration", Mitigation::MatrixConversionCalibration},
};
}  // namespace

ConversionKind MitigationSpec::conversion() const {
  switch (method) {
    case Mitigation::Conversion:
    case Mitigation::ConversionCalibration:
      return ConversionKind::Signal;
    case Mitigation::MatrixConversion:
    case Mitigation::MatrixConversionCalibration:
      return ConversionKind::Matrix;
    case Mitigation::None:
    case Mitigation::Calibration:
      return ConversionKind::None;
  }
  return ConversionKind::None;
}

bool MitigationSpec::calibrate() const {
  return method == Mitigation::Calibration || method == Mitigation::ConversionCalibration ||
         method == Mitigation::MatrixConversionCalibration;
}

const char* MitigationSpec::name() const {
  for (const auto& m : kMitigations)
    if (m.method == method) return m.name;
  return "?";
}

MitigationSpec mitigation_from_name(const std::string& name, const std::string& key) {
  for (const auto& m : kMitigations)
    if (name == m.name) return MitigationSpec{m.method};
  std::string list;
  for (const auto& m : kMitigations) list += (list.empty() ? "" : ", ") + std::string(m.name);
  throw InputError("configuration key '" + key + "': '" + name + "' is not one of: " + list);
}

int MappingSpec::logical_columns_per_crossbar() const {
  if (max_cols == 0) return 0;
  const int n = (max_cols - (analog_sum() ? 1 : 0)) / columns_per_weight();
  if (n < 1)
    throw InputError("configuration key 'mapping.max_cols' (" + std::to_string(max_cols) +
                     ") cannot hold one weight column (" + std::to_string(columns_per_weight()) +
                     " cells with this mapping.negative, weight_bits and crossbar.cell_bits" +
                     (analog_sum() ? ", plus the sum(X) column" : "") + ")");
  return n;
}

MappingSpec parse_mapping_spec(const ConfigTree& cfg, const CrossbarParams& xbar) {
  MappingSpec m;
  m.max_rows = require_size_or_unbounded(cfg, "mapping.max_rows");
  m.max_cols = require_size_or_unbounded(cfg, "mapping.max_cols");
  // auto: the shift with exact cells, differential pairs under a device model. The shift holds
  // every zero weight mid-range, where a real device's spread is largest, on one range of twice
  // the largest |w|: under any device model it loses most of the accuracy (docs/physics.md,
  // "Shift or differential under a device"), so it is refused there rather than run.
  const std::string device = cfg.get_string("device.model");
  const std::string negative = cfg.get_string("mapping.negative");
  if (negative == "auto") {
    m.negative = device == "ideal" ? NegativeWeights::Shift : NegativeWeights::Differential;
  } else {
    m.negative = require_enum<NegativeWeights>(
        cfg, "mapping.negative",
        {{"auto", NegativeWeights::Shift}, {"shift", NegativeWeights::Shift}, {"differential", NegativeWeights::Differential}});
    if (m.negative == NegativeWeights::Shift && device != "ideal")
      throw InputError(
          "configuration key 'mapping.negative' (shift) with device.model " + excerpt(device) +
          ": the shift mapping holds every zero weight mid-range, where the device's spread is largest, on a range "
          "twice as wide as a differential pair's, and loses most of the accuracy under any device model (ResNet-20: "
          "13 % against 71 % for differential pairs under rram-wan2022; docs/physics.md, shift or differential under "
          "a device); set mapping.negative: differential, or auto (the default: differential under a device model)");
  }
  m.sum_x = require_enum<SumX>(cfg, "mapping.sum_x", {{"digital", SumX::Digital}, {"analog", SumX::Analog}});
  // auto: 0.2 with exact cells (room for conversion's gains above 1), none under a device model,
  // whose spread is a fraction of the conductance: the widest span has the best signal to spread
  // (docs/results.md, "Ranging under real devices", the table that chose it).
  m.g_headroom = cfg.get_string("mapping.g_headroom") == "auto" ? (device == "ideal" ? kIdealHeadroom : 0.0)
                                                                 : cfg.get_double("mapping.g_headroom");
  if (xbar.g_max_s * (1 - m.g_headroom) <= xbar.g_min_s)
    throw InputError(
        "configuration key 'mapping.g_headroom' leaves no conductance range (needs g_max (1 - h) > g_min)");
  m.scheme = require_enum<MappingScheme>(cfg, "mapping.scheme",
                                         {{"dense", MappingScheme::Dense}, {"sparse", MappingScheme::Sparse}});
  m.cell_bits = parse_bits(cfg, "crossbar.cell_bits");
  m.weight_bits = parse_bits(cfg, "mapping.weight_bits");
  if (m.differential() && m.weight_bits == 1)
    throw InputError(
        "configuration key 'mapping.weight_bits' (1): differential weights need a sign and at least one magnitude "
        "bit (2 or more), or mapping.negative: shift");
  m.logical_columns_per_crossbar();  // validates max_cols against the column layout
  m.spare_columns = cfg.get_int32("device.spare_columns");
  return m;
}

ConversionSpec parse_conversion_spec(const ConfigTree& cfg) {
  ConversionSpec c;
  c.signal = require_enum<ConversionSignal>(cfg, "conversion.signal",
                                            {{"constant", ConversionSignal::Constant},
                                             {"max_input", ConversionSignal::MaxInput},
                                             {"mean_input", ConversionSignal::MeanInput}});
  const std::string amp = cfg.get_string("conversion.amplitude");
  if (amp == "optimize") {
    c.amplitude_mode = AmplitudeMode::Optimize;
  } else if (amp == "paper") {
    c.amplitude_mode = AmplitudeMode::Paper;
  } else {
    c.amplitude = cfg.get_double("conversion.amplitude");
  }
  c.column_scaling = cfg.get_bool("conversion.column_scaling");
  c.max_iterations = cfg.get_int32("conversion.max_iterations");
  c.tolerance = cfg.get_double("conversion.tolerance");
  return c;
}

CalibrationSpec parse_calibration_spec(const ConfigTree& cfg) {
  CalibrationSpec c;
  c.samples = cfg.get_int32("calibration.samples");
  c.signal = require_enum<CalibrationSignal>(cfg, "calibration.signal",
                                             {{"random", CalibrationSignal::Random},
                                              {"random_decreasing", CalibrationSignal::RandomDecreasing},
                                              {"shuffled", CalibrationSignal::Shuffled}});
  c.seed = static_cast<uint64_t>(cfg.get_int("calibration.seed"));
  return c;
}

const char* to_string(AdcRange r) {
  switch (r) {
    case AdcRange::Calibrated:
      return "calibrated";
    case AdcRange::PerRead:
      return "per_read";
    case AdcRange::Full:
      return "full";
  }
  return "?";
}

ConvertersSpec parse_converters_spec(const ConfigTree& cfg) {
  ConvertersSpec c;
  c.input_bits = parse_bits(cfg, "converters.input_bits");
  c.dac_bits = parse_bits(cfg, "converters.dac_bits");
  c.image_bits = parse_bits(cfg, "converters.image_bits");
  c.adc_range = require_enum<AdcRange>(cfg, "converters.adc_range",
                                       {{to_string(AdcRange::Calibrated), AdcRange::Calibrated},
                                        {to_string(AdcRange::PerRead), AdcRange::PerRead},
                                        {to_string(AdcRange::Full), AdcRange::Full}});
  c.adc_bits = parse_bits(cfg, "converters.adc_bits");
  c.adc_margin = cfg.get_double("converters.adc_margin");
  c.adc_offset_subtraction = cfg.get_bool("converters.adc_offset_subtraction");
  c.adc_columns_per_adc = cfg.get_int32("converters.adc_columns_per_adc");
  c.dac_predistortion = cfg.get_bool("converters.dac_predistortion");
  c.readout_noise_a = cfg.get_double("converters.readout_noise_na") * 1e-9;
  return c;
}


}  // namespace xbarsim
