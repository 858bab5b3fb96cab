#pragma once
/// A tile: the datapath of one layer's crossbars, ShiftRegisterBuffer -> Dac ->
/// CrossbarArray -> Adc -> DigitalAccumulator, behind one target socket. The modules
/// annotate the latency of the first iteration (pipeline fill); the tile adds the
/// steady state: sum over later iterations of the slowest stage rounded up to clock
/// cycles (detailed), or one clock cycle per iteration (ideal, the paper's estimate).
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

/// Timing of a layer's iterations from the stage latencies its modules recorded (detailed):
/// each iteration's initiation interval is its slowest stage in whole clock cycles, and the
/// first iteration's full datapath latency (the pipeline fill) is rounded up to whole cycles
/// too. Ideal timing: one cycle per read (an iteration's input slices), no fill beyond it.
/// Bit-serial reads: each stage records an iteration's reads back to back (slices x its
/// per-read latency), so the interval is slices x the slowest stage's read.
struct IterationTiming {
  std::vector<double> ii_ns;  ///< per iteration
  double fill_ns = 0;         ///< latency of the first iteration (>= ii_ns[0])
};
inline IterationTiming iteration_timing(const LayerJob& job, double clock_ns, bool detailed) {
  const int n = job.iterations();
  IterationTiming t;
  t.ii_ns.assign(n, clock_ns * job.read_times());  // ideal: one read per cycle
  t.fill_ns = t.ii_ns.empty() ? clock_ns : t.ii_ns[0];
  if (!detailed || n == 0) return t;
  auto whole_cycles = [&](double ns) { return std::ceil(ns / clock_ns - 1e-9) * clock_ns; };
  double first = 0;
  for (int s = 0; s < kStages; ++s) first += job.stage_ns[s][0];
  for (int k = 0; k < n; ++k) {
    double worst = 0;
    for (int s = 0; s < kStages; ++s) worst = std::max(worst, job.stage_ns[s][k]);
    t.ii_ns[k] = whole_cycles(worst);
  }
  t.fill_ns = whole_cycles(first);
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
  long long cycles() const { return cycles_; }
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
    if (!job) {
      p.set_response_status(tlm::TLM_COMMAND_ERROR_RESPONSE);
      return;
    }
    const sc_core::sc_time start = delay;
    tile2sr->b_transport(p, delay);
    if (p.get_response_status() != tlm::TLM_OK_RESPONSE) return;
    const double clk = cfg_.clock_ns();
    const int n = job->iterations();
    const int r = std::max(1, job->replication);
    double steady_ns;
    if (job->detailed) {
      // The fill, then the later iterations' initiation intervals shared over the copies.
      const IterationTiming t = iteration_timing(*job, clk, true);
      double sum = 0;
      for (int k = 1; k < n; ++k) sum += t.ii_ns[k];
      steady_ns = sum / r;
      delay = start + sim_delay(t.fill_ns, start);
    } else {
      steady_ns = static_cast<double>((n + r - 1) / r) * job->read_times() * clk;  // a read per cycle
    }
    delay += sim_delay(steady_ns, delay);
    iterations_ += n;
    outputs_written_ += static_cast<long long>(n) * job->analog->outputs();
    cycles_ += std::llround((delay - start).to_seconds() * 1e9 / clk);
  }

  PlatformConfig cfg_;
  ShiftRegisterBuffer sr_;
  Dac dac_;
  CrossbarArray xbar_;
  Adc adc_;
  DigitalAccumulator acc_;
  long long iterations_ = 0, cycles_ = 0, outputs_written_ = 0;
};

}  // namespace xbarsim
