#pragma once
/// Typed parts of a crossbar core, each a spec with a `kind` read once from the architecture
/// file (sections `input:` and `readout:`): how inputs reach the rows and how columns are read
/// out. They say, for any precision, how many steps of each action one read (one MVM of the
/// whole array) takes and how long it lasts, so one architecture file serves every precision.
///
/// ISAAC's parts are the defaults: bit-serial two's-complement inputs and a current-mode ADC
/// shared over columns through sample-and-holds (timed by ima.read_ns and the ADC's rate,
/// sw/hw/platform_spec.h). NeuRRAM's (Wan et al., Nature 2022): sign-magnitude input pulses,
/// in two phases above `max_bits_per_phase` magnitude bits, and a voltage-mode neuron per
/// column that samples the settled column voltage, integrates it 2^k times for magnitude bit k
/// of a phase and converts by charge decrement, one ADC step per output bit still to resolve.
#include <string>

#include <nlohmann/json.hpp>

namespace xbarsim {

class YamlSection;

/// How an architecture's rows take an input code. The codes themselves, their digits and the
/// reads they take are one description, InputSlicing (sw/analog/input_slicing.h), which the
/// evaluation streams and the inventory counts: bit-serial is its sliced case (dac_bits-wide
/// digits, one read each), sign-magnitude its one-read case (dac_bits = the input's bits, the
/// sign as the pulses' polarity), whose magnitude bits a neuron's read integrates.
enum class InputEncoding {
  BitSerial,     ///< two's complement, one bit (DAC slice) per read (ISAAC)
  SignMagnitude  ///< a sign and magnitude bits as pulses, integrated in one read (NeuRRAM)
};

struct InputSpec {
  InputEncoding kind = InputEncoding::BitSerial;
  int max_bits_per_phase = 0;  ///< sign-magnitude: magnitude bits one phase integrates (more: two phases)
  double v_read_v = 0;         ///< sign-magnitude: the pulse amplitude on a row
  double pulse_ns = 0;         ///< sign-magnitude: one pulse's width
  /// Sign-magnitude: the core's word-line instance (ima.components) and how often each of its
  /// lines switches per magnitude bit.
  std::string wordline;
  double wordline_switches_per_bit = 0;
  /// Sign-magnitude: a weight's two cells on adjacent rows driven with opposite pulses
  /// (NeuRRAM: `pairs: rows`), or in adjacent columns read apart (`pairs: columns`).
  bool pairs_on_rows = false;
  /// The workload the input pulses' energy is solved for (peak figures): the fraction of
  /// magnitude bits that pulse (inputs non-negative), weights Gaussian clipped at this many
  /// sigma, the vectors averaged.
  double bit_density = 0.5, weight_clip_sigma = 3;
  int vectors = 8, seed = 1;
};

enum class ReadoutKind {
  CurrentAdc,  ///< column currents into shared ADCs through sample-and-holds (ISAAC)
  Neuron       ///< a voltage-mode integrate-and-convert neuron per column (NeuRRAM)
};

struct ReadoutSpec {
  ReadoutKind kind = ReadoutKind::CurrentAdc;
  double integrate_ns = 0;  ///< neuron: one integration step
  double adc_step_ns = 0;   ///< neuron: one charge-decrement (ADC) step
  double phase_ns = 0;      ///< neuron: per phase: initialise, sample
  /// Neuron: the core's instances (ima.components) of its ADC, integrator, sampling capacitors
  /// and shift-and-add, which count `step`, `step`, `sample` and `add` actions.
  std::string adc, integrator, sample, shift_add;
};

/// What one read of the array does, per neuron, at (input, output) bits.
struct ReadSteps {
  int magnitude_bits = 0;  ///< the one-read signed InputSlicing's: max(1, input_bits - 1), the sign costs no pulse
  int phases = 0;
  int first_phase_bits = 0, second_phase_bits = 0;
  long long integrate_steps = 0;  ///< sum over phases of 2^bits - 1
  long long adc_steps = 0;        ///< sum over phases of the output bits still to resolve
  long long samples = 0;          ///< one per magnitude bit
  double time_ns = 0;             ///< integrate x t_i + adc x t_a + phases x t_p
  nlohmann::json to_json() const;
};

/// The steps of one read of a neuron core at `input_bits` and `output_bits` (each >= 1).
ReadSteps neuron_read_steps(const InputSpec& in, const ReadoutSpec& out, int input_bits, int output_bits);

/// Reads the optional `input:` / `readout:` sections (kinds and their figures); errors name
/// the file and key.
InputSpec parse_input_spec(YamlSection& s);
ReadoutSpec parse_readout_spec(YamlSection& s);

const char* to_string(InputEncoding e);
const char* to_string(ReadoutKind k);

}  // namespace xbarsim
