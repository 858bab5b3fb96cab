#pragma once
/// The work item carried by the tile datapath's TLM transactions: one image's pass through
/// one linear layer (or, timing only, a row group of it), as an extension of the generic
/// payload (a write of the layer's input activation: its data, its length in bytes, address 0
/// of the tile's input buffer). Each module reads what the previous one produced and adds its
/// own results, counters and per-iteration latency; the tile's units (modules/TileUnit.h)
/// then take the time those latencies say. The job belongs to its initiator: the payload
/// never frees it.
#include <tlm>
#include <vector>

#include "sw/analog/analog_layer.h"
#include "sw/nn/model.h"

namespace xbarsim {

/// Pipeline stages of a tile (its units), in datapath order.
enum Stage { kShift = 0, kDac, kCrossbar, kAdc, kAccumulate, kStages };

/// A unit's name in reports.
inline const char* unit_name(Stage s) {
  switch (s) {
    case kShift: return "shift_register";
    case kDac: return "dac";
    case kCrossbar: return "crossbar";
    case kAdc: return "adc";
    case kAccumulate: return "accumulator";
    case kStages: break;
  }
  return "";
}

struct LayerJob : tlm::tlm_extension<LayerJob> {
  tlm::tlm_extension_base* clone() const override { return new LayerJob(*this); }
  void copy_from(const tlm::tlm_extension_base& other) override { *this = static_cast<const LayerJob&>(other); }
  void free() override {}  // owned by the initiator, not by the payload

  const LinearLayer* layer = nullptr;
  const AnalogLayer* analog = nullptr;
  const float* activation = nullptr;  ///< C x H x W input of the layer
  uint64_t image = 0;                 ///< the image's index in the dataset (keys the read noise)
  bool detailed = true;               ///< timing mode
  /// Timing only (platform.timing_only): the modules count actions and record stage latencies
  /// from the layer's geometry and compute no values (xq, currents and y stay empty).
  bool timing_only = false;
  /// Copies of the layer's tile that share the transaction's iterations side by side
  /// (platform.replication), each a contiguous part of them.
  int replication = 1;
  /// The transaction's part of the image's pass (timing only: a row group of the stage's
  /// output, platform.grain_rows): iterations [first_iteration, first_iteration + count).
  /// count < 0: the whole pass, as a transaction that computes values always is.
  int first_iteration = 0, count = -1;
  /// The activation already holds DAC values (quantized once before the shift register copied
  /// them into the windows: each value is converted on its own and zero is a level, so this
  /// gives the DAC's values at a fraction of the work); the DAC stage then only slices them.
  bool input_quantized = false;
  /// A sparse (Toeplitz) layer's transaction (timing only): its single iteration computes every
  /// output row, so the initiator gives stage_ns[s][0] (sparse_iteration_ns: the iteration on
  /// the group of its first row, nothing on the later groups) and the modules do not count it
  /// (its actions are its inventory's, one iteration per image).
  bool sparse = false;
  std::vector<float> quantized_input;  ///< storage for such an activation (Tile::compute_values)

  AnalogLayer::RowMat<float> xq;          ///< iterations x K: shift-register contents, then DAC values
  std::vector<Eigen::MatrixXf> currents;  ///< per crossbar: iterations x physical columns (one read each)
  /// Bit-serial reads (serial()): the DAC codes (AnalogLayer::slice_inputs) and per crossbar
  /// the currents of every read of every iteration.
  AnalogLayer::Codes codes;
  std::vector<AnalogLayer::ReadCurrents<float>> read_currents;
  Eigen::MatrixXf y;  ///< iterations x c_out (without bias)

  /// Per iteration of the transaction's part (index 0: first_iteration): each stage's latency.
  std::vector<double> stage_ns[kStages];
  long long shifted_entries = 0, refills = 0, dac_conversions = 0, adc_conversions = 0, accumulations = 0;
  long long shift_adds = 0;

  /// Zeroes the action counters for the next pass (the buffers keep their capacity).
  void reset_counters() {
    shifted_entries = refills = dac_conversions = adc_conversions = accumulations = shift_adds = 0;
  }
  int iterations() const { return layer->out.h * layer->out.w; }
  /// Iterations of the transaction's part of the pass.
  int group_iterations() const { return count < 0 ? iterations() : count; }
  /// The transaction covers the whole pass.
  bool whole_pass() const { return first_iteration == 0 && group_iterations() == iterations(); }
  /// Datapath cycles one read takes: 1, or on neuron cores a read of the image at
  /// converters.image_bits (PlatformConfig::image_read_cycles).
  int read_cycles = 1;
  /// Crossbar reads per iteration (input slices).
  int slices() const { return analog->input_slicing().slices; }
  /// The reads' time per iteration in read times: slices x read_cycles.
  int read_times() const { return slices() * read_cycles; }
  /// Inputs are streamed bit-serially, several reads per iteration.
  bool serial() const { return analog->input_slicing().serial(); }
  /// Crossbar reads of the transaction: input slices x its iterations.
  long long reads() const { return static_cast<long long>(slices()) * group_iterations(); }
  /// Whether the previous stages produced what a stage reads, for every crossbar.
  bool has_currents() const {
    if (timing_only) return true;
    const size_t nb = static_cast<size_t>(analog->crossbars());
    return serial() ? read_currents.size() == nb : currents.size() == nb;
  }
  /// Physical columns of crossbar b.
  int physical_columns(int b) const {
    if (timing_only) return analog->config().mapping.physical_columns(analog->block(b).cols);
    return static_cast<int>(serial() ? read_currents[b].i.cols() : currents[b].cols());
  }
  /// Reads are combined by shift-and-add (input or weight slices).
  bool sliced() const { return slices() > 1 || analog->config().mapping.weight_slices() > 1; }
};

/// Makes `p` the write of a job's input activation (job.layer->in, floats) to the tile's input
/// buffer, with the job as its extension.
inline void attach(tlm::tlm_generic_payload& p, LayerJob& job, sc_dt::uint64 address) {
  p.set_command(tlm::TLM_WRITE_COMMAND);
  p.set_address(address);
  p.set_data_ptr(reinterpret_cast<unsigned char*>(const_cast<float*>(job.activation)));
  p.set_data_length(static_cast<unsigned>(job.layer->in.size() * sizeof(float)));
  p.set_streaming_width(p.get_data_length());
  p.set_byte_enable_ptr(nullptr);
  p.set_dmi_allowed(false);
  p.set_response_status(tlm::TLM_INCOMPLETE_RESPONSE);
  p.set_extension(&job);
}

/// The job a payload carries, or nullptr when it is malformed (no job, not a write, or data
/// that is not the job's input activation).
inline LayerJob* job_of(tlm::tlm_generic_payload& p) {
  LayerJob* job = p.get_extension<LayerJob>();
  if (!job || !job->layer || p.get_command() != tlm::TLM_WRITE_COMMAND ||
      p.get_data_length() != job->layer->in.size() * sizeof(float))
    return nullptr;
  return job;
}

}  // namespace xbarsim
