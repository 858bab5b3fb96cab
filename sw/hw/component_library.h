#pragma once
/// Component library (YAML, configs/components/), in the style of Accelergy: every
/// component's area, leakage power and energy per action, with the rules that scale
/// converters to other resolutions. Parsed once and validated; costs are computed from
/// it in one place (sw/hw/cost.h).
#include <map>
#include <string>

#include "sw/common/config.h"
#include "sw/hw/components.h"

namespace xbarsim {

/// How a converter figure changes with resolution (YAML `energy_scaling` / `area_scaling`).
enum class Scaling {
  Exponential,  ///< value * 2^(bits - reference_bits) (the paper: 1-bit DAC to 8 bits = x256)
  Linear,       ///< value * bits / reference_bits
  Constant      ///< value
};

/// One converter type (YAML sections `adc`, `dac`): figures at `reference_bits`, scaled to `bits`.
struct ConverterModel {
  double area_mm2 = 0;       ///< one unit at reference_bits
  double leakage_mw = 0;     ///< one unit, not scaled
  double conversion_pj = 0;  ///< one conversion at reference_bits
  int reference_bits = 8;
  Scaling energy_scaling = Scaling::Exponential, area_scaling = Scaling::Exponential;
  double conversion_pj_at(int bits) const;
  double area_at(int bits) const;
};

struct ComponentLibrary {
  std::string source;  ///< file it was read from
  /// Components by name, priced by price() (sw/hw/components.h). A library in the named form
  /// (a top-level `components:` section, such as configs/components/neurram.yaml) is all here,
  /// and the fixed sections below are unset (zero); a fixed library has its `units` here (mm^2,
  /// mW, pJ per `action`), and CostModel::components() gives its fixed sections the same way.
  NamedLibrary named;
  bool named_form = false;
  bool is_named() const { return named_form; }
  ConverterModel adc, dac;
  int adc_columns_per_unit = 128;      ///< crossbar columns sharing one ADC (default of converters.adc_columns_per_adc)
  double adc_sample_rate_gsps = 1.28;  ///< conversions per ns of one ADC (timing and peak power)
  struct DacLut {
    double area_mm2 = 0, leakage_mw = 0, read_pj = 0;  ///< one DAC's pre-distortion table, one lookup
  } dac_lut;
  struct Cell {
    double area_mm2 = 0, leakage_mw = 0, read_pj = 0;  ///< one memristor cell, one read
  } cell;
  struct Accumulator {
    double area_mm2 = 0, leakage_mw = 0, accumulate_pj = 0;  ///< one per crossbar; per output value
  } accumulator;
  struct ShiftRegister {  ///< the input register (shift register) of a layer, per 8-bit entry
    double area_mm2_per_entry = 0, leakage_mw_per_entry = 0;
    double shift_pj = 0;  ///< per entry shifted in
    double read_pj = 0;   ///< per entry read into a DAC (every DAC conversion)
  } shift_register;
  struct SampleHold {  ///< one per physical column: holds the column's read for its (shared) ADC
    double area_mm2 = 0, leakage_mw = 0, sample_pj = 0;
  } sample_hold;
  struct ShiftAdd {         ///< shift-and-add of sliced reads (bit-serial inputs, bit-sliced weights)
    int adcs_per_unit = 1;  ///< ADCs whose results one unit combines
    double area_mm2 = 0, leakage_mw = 0, op_pj = 0;  ///< one unit; one converted value shifted and added
  } shift_add;
  struct OutputRegister {  ///< holds the shift-and-add results: 2 bytes per weight column of a crossbar
    double area_mm2_per_byte = 0, leakage_mw_per_byte = 0, write_pj = 0;  ///< write: one shift-and-add result
  } output_register;
  struct Buffer {
    double area_mm2_per_kib = 0, leakage_mw_per_kib = 0, read_pj_per_byte = 0, write_pj_per_byte = 0;
  } buffer;
  struct Interconnect {
    double area_mm2 = 0, leakage_mw = 0, transfer_pj_per_byte = 0;  ///< the shared bus
  } interconnect;
  struct Digital {
    double area_mm2 = 0, leakage_mw = 0, op_pj = 0;  ///< one ReLU / Add / pooling unit
  } digital;
  struct Memory {
    double transfer_pj_per_byte = 0;  ///< off-chip input/output
  } memory;
};

/// Scales `value` from `ref` to `bits` by the rule.
double scale_by_bits(double value, int ref, int bits, Scaling rule);

/// Parses a component library from YAML text; errors name `origin`, the key and the bad
/// value (unknown sections or keys, missing figures, negative numbers, fractional bits,
/// duplicate keys).
ComponentLibrary parse_component_library(const std::string& yaml_text, const std::string& origin);

/// The library named by `components.library`: a YAML file, or a built-in by name (isaac_paper,
/// the default, or isaac: configs/components/<name>.yaml compiled in).
ComponentLibrary load_component_library(const ConfigTree& cfg);

}  // namespace xbarsim
