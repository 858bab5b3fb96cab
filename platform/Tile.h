#pragma once
/// A tile: the datapath of one layer's crossbars, ShiftRegisterBuffer -> Dac ->
/// CrossbarArray -> Adc -> DigitalAccumulator, behind one target socket. A transaction is an
/// image's pass or (timing only) a row group of it; the modules record each iteration's
/// latency, and the tile annotates the transaction's delay from them (transaction_ns): the
/// one source of a tile's time in the platform.
#include <algorithm>
#include <cmath>
#include <memory>
#include <vector>
#include <systemc>
#include <tlm>
#include <tlm_utils/simple_initiator_socket.h>
#include <tlm_utils/simple_target_socket.h>

#include "modules/Adc.h"
#include "modules/CrossbarArray.h"
#include "modules/Dac.h"
#include "modules/DigitalAccumulator.h"
#include "modules/ShiftRegisterBuffer.h"
#include "sw/hw/cost.h"
#include "sw/hw/platform_spec.h"
#include "modules/sim_time.h"

namespace xbarsim {

/// The time of a transaction's iterations from the latencies its modules recorded, on `copies`
/// copies of the tile that take contiguous shares of them side by side (a part of fewer
/// iterations than copies leaves the rest idle): the slowest copy's share. Detailed: each
/// iteration's initiation interval is its slowest stage in whole clock cycles, and the image's
/// first iteration takes the datapath's full latency (the pipeline fill, the sum of its stages,
/// rounded up to whole cycles). Ideal: one cycle per read time (an iteration's input slices),
/// no fill beyond it. Bit-serial reads: each stage records an iteration's reads back to back
/// (slices x its per-read latency), so the interval is slices x the slowest stage's read.
inline double transaction_ns(const LayerJob& job, double clock_ns, bool detailed, int copies) {
  const int n = job.group_iterations();
  if (n == 0) return 0;
  const double ideal_ns = clock_ns * job.read_times();  // ideal: one read per cycle
  auto whole_cycles = [&](double ns) { return std::ceil(ns / clock_ns - 1e-9) * clock_ns; };
  auto interval = [&](int k) {
    if (!detailed) return ideal_ns;
    double worst = 0;
    for (int s = 0; s < kStages; ++s) worst = std::max(worst, job.stage_ns[s][static_cast<size_t>(k)]);
    return whole_cycles(worst);
  };
  double fill = 0;  // beyond the first iteration's interval
  if (detailed && job.starts_pass()) {
    double first = 0;
    for (int s = 0; s < kStages; ++s) first += job.stage_ns[s][0];
    fill = whole_cycles(first) - interval(0);
  }
  const int nrep = std::max(1, std::min(copies, n));
  double t = 0;
  for (int q = 0; q < nrep; ++q) {
    double share = q == 0 ? fill : 0.0;
    for (int k = q * n / nrep; k < (q + 1) * n / nrep; ++k) share += interval(k);
    t = std::max(t, share);
  }
  return t;
}

class Tile : public sc_core::sc_module {
 public:
  tlm_utils::simple_target_socket<Tile> noc2tile{"noc2tile"};

  Tile(sc_core::sc_module_name name, const PlatformConfig& c)
      : sc_module(name),
        cfg_(c),
        sr_("sr", c.clock_ns(), c.shift_entries_per_cycle),
        dac_("dac", c.dac_latency_ns),
        xbar_("xbar", c.crossbar_settle_ns),
        adc_("adc", c.adc_columns_per_unit, c.adc_rate_gsps, c.crossbars_per_adc),
        acc_("acc", c.accumulator_latency_ns) {
    noc2tile.register_b_transport(this, &Tile::b_transport);
    tile2sr.bind(sr_.ctrl2sr);
    sr_.sr2dac.bind(dac_.sr2dac);
    dac_.dac2xbar.bind(xbar_.dac2xbar);
    xbar_.xbar2adc.bind(adc_.xbar2adc);
    adc_.adc2acc.bind(acc_.adc2acc);
  }

  long long iterations() const { return iterations_; }
  /// Output values written to the next layer's buffer.
  long long outputs_written() const { return outputs_written_; }
  /// Every action the tile's modules counted, for pricing by the component library.
  ActionCounts actions() const {
    ActionCounts a;
    a.dac_conversions = static_cast<double>(dac_.conversions());
    a.adc_conversions = static_cast<double>(adc_.conversions());
    a.samples = a.adc_conversions;  // every conversion is of a sampled column
    a.shift_adds = static_cast<double>(adc_.shift_adds());
    a.cell_reads = static_cast<double>(xbar_.cell_reads());
    a.accumulates = static_cast<double>(acc_.accumulations());
    a.scale_multiplies = static_cast<double>(acc_.scale_multiplies());
    a.shifts = static_cast<double>(sr_.shifted_entries());
    a.buffer_read_bytes = a.shifts;  // the shift register loads its entries from the layer's buffer
    a.buffer_write_bytes = static_cast<double>(outputs_written_);
    return a;
  }
  /// The values of one pass through the datapath, by the modules' own functions in datapath
  /// order (shift register, DACs, crossbars, ADCs, accumulator) into job.y (without bias): the
  /// functional half of a transaction, which the platform runs on its worker threads while the
  /// transaction itself (timing_only) times and counts. Touches only the job: safe on any thread.
  /// Bit-serial reads go through crossbars, ADCs and accumulator a few iterations at a time
  /// (as AnalogLayer::forward does), so that their currents stay in cache: every read's
  /// result is independent of the block it is computed in.
  static void compute_values(LayerJob& job) {
    job.timing_only = false;
    // The DAC's quantization applied to the layer's input once instead of to every window
    // (the values are the same, as in CrossbarBackend::multiply_activation).
    job.input_quantized = job.analog->quantizes_inputs();
    if (job.input_quantized) {
      job.quantized_input.assign(job.activation, job.activation + job.layer->in.size());
      job.analog->dac_values<float>(job.quantized_input.data(), static_cast<Eigen::Index>(job.quantized_input.size()));
      job.activation = job.quantized_input.data();
    }
    ShiftRegisterBuffer::fill(job);
    Dac::convert(job);
    if (!job.serial()) {
      CrossbarArray::read(job);
      Adc::convert(job);
      DigitalAccumulator::recover(job);
      return;
    }
    constexpr Eigen::Index kBlock = 16;
    const Eigen::Index n = job.iterations();
    const bool linear = job.analog->config().xbar.is_linear();
    const Eigen::Index block = linear ? kBlock : std::max<Eigen::Index>(n, 1);  // nonlinear: one batched solve
    job.y.setZero(n, job.analog->outputs());
    for (int b = 0; b < job.analog->crossbars(); ++b)
      for (Eigen::Index first = 0; first < n; first += block) {
        CrossbarArray::read(job, b, first, std::min(block, n - first));
        Adc::convert(job, b);
        DigitalAccumulator::recover(job, b);
      }
  }
  const ShiftRegisterBuffer& shift_register() const { return sr_; }
  const Dac& dac() const { return dac_; }
  const Adc& adc() const { return adc_; }
  const CrossbarArray& crossbars() const { return xbar_; }
  const DigitalAccumulator& accumulator() const { return acc_; }

 private:
  tlm_utils::simple_initiator_socket<Tile> tile2sr{"tile2sr"};

  void b_transport(tlm::tlm_generic_payload& p, sc_core::sc_time& delay) {
    LayerJob* job = job_of(p);
    const bool part_ok = job && job->first_iteration >= 0 &&
                         job->first_iteration + job->group_iterations() <= job->iterations() &&
                         (job->timing_only || job->whole_pass());  // values: the whole pass
    if (!part_ok) {
      p.set_response_status(tlm::TLM_COMMAND_ERROR_RESPONSE);
      return;
    }
    const sc_core::sc_time start = delay;
    tile2sr->b_transport(p, delay);
    if (p.get_response_status() != tlm::TLM_OK_RESPONSE) return;
    const double ns = transaction_ns(*job, cfg_.clock_ns(), job->detailed, job->replication);
    delay = start + sim_delay(ns, start);
    const int n = job->group_iterations();
    iterations_ += n;
    outputs_written_ += static_cast<long long>(n) * job->analog->outputs();
  }

  PlatformConfig cfg_;
  ShiftRegisterBuffer sr_;
  Dac dac_;
  CrossbarArray xbar_;
  Adc adc_;
  DigitalAccumulator acc_;
  long long iterations_ = 0, outputs_written_ = 0;
};

}  // namespace xbarsim
