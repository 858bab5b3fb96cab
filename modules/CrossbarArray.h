#pragma once
/// The crossbar arrays of a tile (all partitions of one layer, operated in parallel):
/// programmed conductances G' and their column currents for each iteration's input
/// voltages, from the circuit solver (exact effective matrix for linear devices, a Newton
/// solve per vector for nonlinear ones), for every read (input slice) of every iteration.
/// `settle_ns` per read.
#include <systemc>
#include <tlm>
#include <tlm_utils/simple_initiator_socket.h>
#include <tlm_utils/simple_target_socket.h>

#include "modules/LayerJob.h"
#include "modules/TileUnit.h"
#include "modules/sim_time.h"

namespace xbarsim {

class CrossbarArray : public TileUnit {
 public:
  tlm_utils::simple_target_socket<CrossbarArray> dac2xbar{"dac2xbar"};
  tlm_utils::simple_initiator_socket<CrossbarArray> xbar2adc{"xbar2adc"};

  CrossbarArray(sc_core::sc_module_name name, double settle_ns) : TileUnit(name, kCrossbar), settle_ns_(settle_ns) {
    dac2xbar.register_b_transport(this, &CrossbarArray::b_transport);
  }
  long long evaluations() const { return evaluations_; }
  long long cell_reads() const { return cell_reads_; }

  /// Bit-serial reads of vectors [first, first + count) on crossbar b only, into
  /// job.read_currents[b] (a block of a pass, see Tile::compute_values; no timing, no
  /// counters: safe on any thread).
  static void read(LayerJob& job, int b, Eigen::Index first, Eigen::Index count) {
    job.read_currents.resize(static_cast<size_t>(job.analog->crossbars()));
    job.analog->analog<float>(b, job.codes, first, count, job.read_currents[static_cast<size_t>(b)], job.image);
  }
  /// The values of a pass: every crossbar's column currents for every read, from the circuit
  /// solver (no timing, no counters: safe on any thread).
  static void read(LayerJob& job) {
    const int nb = job.analog->crossbars();
    if (!job.serial()) job.currents.resize(nb);
    for (int b = 0; b < nb; ++b) {
      if (job.serial())
        read(job, b, 0, job.iterations());
      else
        job.analog->analog<float>(b, job.xq, job.currents[b], job.image);
    }
  }

 private:
  void b_transport(tlm::tlm_generic_payload& p, sc_core::sc_time& delay) {
    LayerJob* job = job_of(p);
    if (!job) {
      p.set_response_status(tlm::TLM_COMMAND_ERROR_RESPONSE);
      return;
    }
    const int nb = job->analog->crossbars();
    const long long reads = job->reads();
    if (!job->timing_only) read(*job);
    for (int b = 0; b < nb; ++b) {
      cell_reads_ += reads * job->analog->block(b).rows * job->physical_columns(b);
    }
    evaluations_ += reads * nb;
    job->stage_ns[kCrossbar].assign(static_cast<size_t>(job->group_iterations()), settle_ns_ * job->read_times());
    xbar2adc->b_transport(p, delay);
  }
  double settle_ns_;
  long long evaluations_ = 0, cell_reads_ = 0;
};

}  // namespace xbarsim
