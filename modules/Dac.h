#pragma once
/// Row DACs of a tile: input codes -> voltages. Functionally the AnalogLayer's DAC stage
/// (quantization of the activations over the layer's input range, then, with bit-serial
/// inputs, their slices of dac_bits); every crossbar has its own row DACs, so each read
/// (input slices per iteration) converts every row of every crossbar; `latency_ns` per read.
#include <systemc>
#include <tlm>
#include <tlm_utils/simple_initiator_socket.h>
#include <tlm_utils/simple_target_socket.h>

#include "modules/LayerJob.h"
#include "modules/TileUnit.h"
#include "modules/sim_time.h"

namespace xbarsim {

class Dac : public TileUnit {
 public:
  tlm_utils::simple_target_socket<Dac> sr2dac{"sr2dac"};
  tlm_utils::simple_initiator_socket<Dac> dac2xbar{"dac2xbar"};

  Dac(sc_core::sc_module_name name, double latency_ns) : TileUnit(name, kDac), latency_ns_(latency_ns) {
    sr2dac.register_b_transport(this, &Dac::b_transport);
  }
  long long conversions() const { return conversions_; }

  /// The values of a pass: job.xq quantized to DAC levels in place, in the crossbars' row
  /// order (a grouped layer's groups) and, with bit-serial inputs, sliced into the reads'
  /// codes (no timing, no counters: safe on any thread).
  static void convert(LayerJob& job) {
    if (!job.input_quantized) job.analog->dac_inplace<float>(job.xq);
    job.analog->arrange_inputs<float>(job.xq);
    if (job.serial()) job.analog->slice_inputs<float>(job.xq, job.codes);
  }

 private:
  void b_transport(tlm::tlm_generic_payload& p, sc_core::sc_time& delay) {
    LayerJob* job = job_of(p);
    if (!job || (!job->timing_only && job->xq.rows() != job->iterations())) {
      p.set_response_status(tlm::TLM_COMMAND_ERROR_RESPONSE);
      return;
    }
    if (!job->timing_only) convert(*job);
    long long rows = 0;
    for (int b = 0; b < job->analog->crossbars(); ++b) rows += job->analog->block(b).rows;
    const long long n = job->reads() * rows;
    job->dac_conversions += n;
    conversions_ += n;
    // One conversion per read; an iteration's reads follow one another.
    job->stage_ns[kDac].assign(static_cast<size_t>(job->group_iterations()), latency_ns_ * job->read_times());
    dac2xbar->b_transport(p, delay);
  }
  double latency_ns_;
  long long conversions_ = 0;
};

}  // namespace xbarsim
