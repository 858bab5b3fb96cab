#pragma once
/// The peak figures of a machine of neuron cores (NeuRRAM, Wan et al., Nature 2022) at the
/// configured precision (converters.input_bits, converters.adc_bits = the output bits), from
/// counts x named components and physics, every core reading back to back:
/// - time: the readout's steps at these bits (sw/hw/core_parts.h);
/// - the neurons: their parts' actions per read x the library's energy per action;
/// - word lines: C dV^2 per switch (the library's capacitor) x switches per magnitude bit;
/// - input pulses: the power the cells dissipate in the solved voltage-mode core (the column
///   settled onto its neuron's sampling capacitor), x the pulse width, per magnitude bit, for
///   the architecture's stated workload (input.pulse_workload);
/// - leakage over the read.
/// Nothing is fitted to the published figures (tests/study/test_neurram.cpp checks them).
#include <map>
#include <string>

#include <nlohmann/json.hpp>

#include "sw/analog/analog_layer.h"
#include "sw/hw/components.h"
#include "sw/study/hardware.h"

namespace xbarsim {

struct ChipPeak {
  std::string architecture;
  int input_bits = 0, output_bits = 0;
  ReadSteps steps;
  long long cores = 0;
  double ops_per_read = 0;      ///< one core: 2 x rows x weight columns
  double pulse_pj_per_bit = 0;  ///< one core, one magnitude bit, solved
  Bill per_read;                ///< one core, one read: energy (pJ) and area (um^2) by part
  double tops = 0, tops_per_w = 0;
  std::map<std::string, double> fj_per_op;  ///< by part
  double core_area_mm2 = 0;
  std::map<std::string, double> area_share;  ///< by part, of the core
  nlohmann::json to_json() const;
};

/// The machine's peak figures at the configured precision; InputError when the machine has
/// no neuron cores.
ChipPeak chip_peak(const HardwareContext& hw);

}  // namespace xbarsim
