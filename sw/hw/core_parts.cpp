#include "sw/hw/core_parts.h"

#include <algorithm>

#include "sw/analog/input_slicing.h"
#include "sw/common/yaml_section.h"

namespace xbarsim {

const char* to_string(InputEncoding e) {
  switch (e) {
    case InputEncoding::BitSerial:
      return "bit_serial";
    case InputEncoding::SignMagnitude:
      return "sign_magnitude";
  }
  return "?";
}

const char* to_string(ReadoutKind k) {
  switch (k) {
    case ReadoutKind::CurrentAdc:
      return "current_adc";
    case ReadoutKind::Neuron:
      return "neuron";
  }
  return "?";
}

nlohmann::json ReadSteps::to_json() const {
  return {{"magnitude_bits", magnitude_bits}, {"phases", phases},   {"integrate_steps", integrate_steps},
          {"adc_steps", adc_steps},           {"samples", samples}, {"time_ns", time_ns}};
}

ReadSteps neuron_read_steps(const InputSpec& in, const ReadoutSpec& out, int input_bits, int output_bits) {
  ReadSteps r;
  // The read applies a signed code in one multi-bit read: InputSlicing's one-read case, whose
  // magnitude bits it keeps (every layer's input is read as signed: the sign costs no pulse).
  r.magnitude_bits = make_input_slicing(input_bits, input_bits, /*signed_inputs=*/true, 1.0).magnitude_bits;
  const int m = r.magnitude_bits;
  const int per_phase = std::max(1, in.max_bits_per_phase);
  if (m <= per_phase) {
    r.phases = 1;
    r.first_phase_bits = m;
  } else {  // two phases, the larger half first
    r.phases = 2;
    r.first_phase_bits = (m + 1) / 2;
    r.second_phase_bits = m / 2;
  }
  const int bits[2] = {r.first_phase_bits, r.second_phase_bits};
  int resolved = 0;  // output bits the earlier phases resolved
  for (int p = 0; p < r.phases; ++p) {
    r.integrate_steps += (1LL << bits[p]) - 1;
    r.adc_steps += std::max(output_bits - resolved, 0);
    resolved += bits[p];
  }
  r.samples = m;
  r.time_ns = static_cast<double>(r.integrate_steps) * out.integrate_ns + static_cast<double>(r.adc_steps) * out.adc_step_ns +
              r.phases * out.phase_ns;
  return r;
}

InputSpec parse_input_spec(YamlSection& s) {
  InputSpec in;
  const std::string kind = s.word("kind");
  if (kind == "bit_serial") {
    in.kind = InputEncoding::BitSerial;
  } else if (kind == "sign_magnitude") {
    in.kind = InputEncoding::SignMagnitude;
    in.max_bits_per_phase = s.integer("max_bits_per_phase");
    in.v_read_v = s.number("v_read_v", true);
    in.pulse_ns = s.number("pulse_ns", true);
    const std::string pairs = s.word("pairs");
    if (pairs != "rows" && pairs != "columns")
      throw InputError(s.where("pairs") + " must be rows or columns, got '" + pairs + "'");
    in.pairs_on_rows = pairs == "rows";
    in.wordline = s.word("wordline");
    in.wordline_switches_per_bit = s.number("wordline_switches_per_bit", true);
    YamlSection w = s.section("pulse_workload");
    in.bit_density = w.number("bit_density");
    if (in.bit_density > 1) throw InputError(w.where("bit_density") + " must be at most 1");
    in.weight_clip_sigma = w.number("weight_clip_sigma", true);
    in.vectors = w.integer("vectors");
    in.seed = w.integer("seed");
    w.finish();
  } else {
    throw InputError(s.where("kind") + " must be bit_serial or sign_magnitude, got '" + kind + "'");
  }
  s.finish();
  return in;
}

ReadoutSpec parse_readout_spec(YamlSection& s) {
  ReadoutSpec r;
  const std::string kind = s.word("kind");
  if (kind == "current_adc") {
    r.kind = ReadoutKind::CurrentAdc;
  } else if (kind == "neuron") {
    r.kind = ReadoutKind::Neuron;
    r.integrate_ns = s.number("integrate_ns", true);
    r.adc_step_ns = s.number("adc_step_ns", true);
    r.phase_ns = s.number("phase_ns");
    r.adc = s.word("adc");
    r.integrator = s.word("integrator");
    r.sample = s.word("sample");
    r.shift_add = s.word("shift_add");
  } else {
    throw InputError(s.where("kind") + " must be current_adc or neuron, got '" + kind + "'");
  }
  s.finish();
  return r;
}

}  // namespace xbarsim
