#pragma once
/// Column ADCs of a tile: currents -> codes (converters.adc_bits over ranges set at
/// calibration). One ADC serves up to `columns_per_adc` columns of a crossbar (the
/// inventory's rule, adcs_for_columns) through a sample-and-hold per column, so one read takes
/// ceil(columns / adcs) conversions at `rate_gsps` each (an iteration: its input slices'
/// reads); partitions convert in parallel. Sliced reads: every conversion is shifted and added.
#include <algorithm>
#include <cmath>
#include <systemc>
#include <tlm>
#include <tlm_utils/simple_initiator_socket.h>
#include <tlm_utils/simple_target_socket.h>

#include "modules/LayerJob.h"
#include "modules/TileUnit.h"
#include "sw/hw/inventory.h"
#include "sw/hw/platform_spec.h"
#include "modules/sim_time.h"

namespace xbarsim {

class Adc : public TileUnit {
 public:
  tlm_utils::simple_target_socket<Adc> xbar2adc{"xbar2adc"};
  tlm_utils::simple_initiator_socket<Adc> adc2acc{"adc2acc"};

  /// `crossbars_per_adc` > 1: each ADC converts that many crossbars' columns per read (a
  /// machine's IMA with fewer ADCs than crossbars), which multiplies its time per read.
  Adc(sc_core::sc_module_name name, int columns_per_adc, double rate_gsps, int crossbars_per_adc = 1)
      : TileUnit(name, kAdc),
        columns_per_adc_(columns_per_adc),
        rate_gsps_(rate_gsps),
        crossbars_per_adc_(crossbars_per_adc) {
    xbar2adc.register_b_transport(this, &Adc::b_transport);
  }
  long long conversions() const { return conversions_; }
  long long shift_adds() const { return shift_adds_; }

  /// Bit-serial reads of crossbar b only (the block job.read_currents[b] holds), converted to
  /// codes in place (no timing, no counters: safe on any thread).
  static void convert(LayerJob& job, int b) {
    job.analog->adc_inplace<float>(b, job.read_currents[static_cast<size_t>(b)]);
  }
  /// The values of a pass: every read's currents converted to codes in place (no timing, no
  /// counters: safe on any thread).
  static void convert(LayerJob& job) {
    for (int b = 0; b < job.analog->crossbars(); ++b) {
      if (job.serial())
        convert(job, b);
      else
        job.analog->adc_inplace<float>(b, job.currents[b], job.xq);
    }
  }

  /// ADCs serving a crossbar of `columns` columns.
  int adcs_for(int columns) const { return static_cast<int>(adcs_for_columns(columns, columns_per_adc_)); }
  /// Time of one iteration's conversions on a crossbar of `columns` columns (ns).
  double iteration_ns(int columns) const {
    return adc_read_ns(columns, columns_per_adc_, crossbars_per_adc_, rate_gsps_);
  }

 private:
  void b_transport(tlm::tlm_generic_payload& p, sc_core::sc_time& delay) {
    LayerJob* job = job_of(p);
    if (!job || !job->has_currents()) {
      p.set_response_status(tlm::TLM_COMMAND_ERROR_RESPONSE);
      return;
    }
    double slowest = 0;
    const long long reads = job->reads();
    if (!job->timing_only) convert(*job);
    for (int b = 0; b < job->analog->crossbars(); ++b) {
      const int cols = job->physical_columns(b);
      slowest = std::max(slowest, iteration_ns(cols));
      job->adc_conversions += reads * cols;
      conversions_ += reads * cols;
      if (job->sliced()) {
        job->shift_adds += reads * cols;
        shift_adds_ += reads * cols;
      }
    }
    job->stage_ns[kAdc].assign(static_cast<size_t>(job->group_iterations()), slowest * job->read_times());
    adc2acc->b_transport(p, delay);
  }
  int columns_per_adc_;
  double rate_gsps_;
  int crossbars_per_adc_;
  long long conversions_ = 0, shift_adds_ = 0;
};

}  // namespace xbarsim
