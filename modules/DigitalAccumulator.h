#pragma once
/// Digital back end of a tile: sum(X) for the shift correction, the calibration gain and
/// offset of every column (with per-column weight scales, a multiply per output), and the sum of partial results of row-partitioned crossbars.
/// Ends the datapath: answers the transaction.
#include <systemc>
#include <tlm>
#include <tlm_utils/simple_target_socket.h>

#include "modules/LayerJob.h"
#include "modules/TileUnit.h"
#include "modules/sim_time.h"

namespace xbarsim {

class DigitalAccumulator : public TileUnit {
 public:
  tlm_utils::simple_target_socket<DigitalAccumulator> adc2acc{"adc2acc"};

  DigitalAccumulator(sc_core::sc_module_name name, double latency_ns) : TileUnit(name, kAccumulate), latency_ns_(latency_ns) {
    adc2acc.register_b_transport(this, &DigitalAccumulator::b_transport);
  }
  long long accumulations() const { return accumulations_; }
  /// Outputs multiplied by their column's digital gain (ranging.weight_scale: column).
  long long scale_multiplies() const { return scale_multiplies_; }

  /// Bit-serial reads of crossbar b only: the block job.read_currents[b] holds added into its
  /// rows of job.y, which the caller has zeroed (no timing, no counters: safe on any thread).
  static void recover(LayerJob& job, int b) {
    job.analog->recover_add<float>(b, job.read_currents[static_cast<size_t>(b)], job.y);
  }
  /// The values of a pass: job.y, the layer's outputs (without bias) recovered from every
  /// crossbar's codes (no timing, no counters: safe on any thread).
  static void recover(LayerJob& job) {
    job.y.setZero(job.iterations(), job.analog->outputs());
    for (int b = 0; b < job.analog->crossbars(); ++b)
      if (job.serial())
        recover(job, b);
      else
        job.analog->recover_add<float>(b, job.currents[b], job.xq, job.y);
  }

 private:
  void b_transport(tlm::tlm_generic_payload& p, sc_core::sc_time& /*delay: the units time it*/) {
    LayerJob* job = job_of(p);
    if (!job || !job->has_currents()) {
      p.set_response_status(tlm::TLM_COMMAND_ERROR_RESPONSE);
      return;
    }
    if (!job->timing_only) recover(*job);
    // Every crossbar's partial outputs (its weight columns) are accumulated each iteration.
    long long per_iteration = 0;
    for (int b = 0; b < job->analog->crossbars(); ++b) per_iteration += job->analog->block(b).cols;
    const long long n = per_iteration * job->group_iterations();
    job->accumulations += n;
    accumulations_ += n;
    if (job->analog->config().ranging.weight_scale == WeightScale::Column) scale_multiplies_ += n;
    job->stage_ns[kAccumulate].assign(static_cast<size_t>(job->group_iterations()), latency_ns_);
    p.set_response_status(tlm::TLM_OK_RESPONSE);
  }
  double latency_ns_;
  long long accumulations_ = 0, scale_multiplies_ = 0;
};

}  // namespace xbarsim
