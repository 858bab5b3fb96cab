#pragma once
/// A tile: the datapath of one layer's crossbars, ShiftRegisterBuffer -> Dac ->
/// CrossbarArray -> Adc -> DigitalAccumulator, behind one target socket, each a unit with its
/// own process (modules/TileUnit.h) and a bounded FIFO before it. A transaction is an image's
/// pass or (timing only) a row group of it: through the modules' sockets it is counted and
/// every iteration's latency at each unit recorded (and, unless timing only, its values
/// computed); then it enters the units as a token, and b_transport returns once the shift
/// register has read the group's inputs. The group's output rows leave the accumulator when
/// the units' processes have done it (set_output): the tile's time is theirs.
#include <algorithm>
#include <cmath>
#include <functional>
#include <memory>
#include <stdexcept>
#include <string>
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
#include "modules/TileUnit.h"
#include "sw/hw/cost.h"
#include "sw/hw/platform_spec.h"
#include "modules/sim_time.h"

namespace xbarsim {

class Tile : public sc_core::sc_module {
 public:
  tlm_utils::simple_target_socket<Tile> noc2tile{"noc2tile"};

  /// `copies`: the tile's copies, lanes of every unit that share a group's iterations.
  Tile(sc_core::sc_module_name name, const PlatformConfig& c, int copies = 1)
      : sc_module(name),
        cfg_(c),
        copies_(std::max(1, copies)),
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
    for (int s = 0; s < kStages; ++s) fifo_[s] = std::make_unique<TokenFifo>(c.fifo_depth);
    // Ideal timing: a read per cycle, no unit aligned to the clock.
    cycle_ps_ = sc_core::sc_time(c.clock_ns(), sc_core::SC_NS).value();
    clock_ = c.detailed ? cycle_ps_ : 0;
    for (int s = 0; s + 1 < kStages; ++s)
      unit(static_cast<Stage>(s)).connect(fifo_[s].get(), {fifo_[s + 1].get(), {}, nullptr}, copies_, clock_);
    set_output(nullptr, nullptr);
  }

  /// Where a finished group goes: `out(token)` returns false while it cannot take it, and
  /// `space` fires when it may. Without one, every group is taken when done (completions()).
  void set_output(std::function<bool(const TileToken&)> out, const sc_core::sc_event* space) {
    out_ = std::move(out);
    acc_.connect(fifo_[kAccumulate].get(), {nullptr, [this](TileToken& t) { return deliver(t); }, space ? space : &never_},
                 copies_, clock_);
  }
  /// Traces every unit's state (TileUnit::trace_to) into `vcd` as scope.<unit>_state.
  void trace(sc_core::sc_trace_file* vcd, const std::string& scope, const bool* enabled, const int* images) {
    for (int s = 0; s < kStages; ++s) {
      unit_sigs_.push_back(std::make_unique<sc_core::sc_signal<int, sc_core::SC_UNCHECKED_WRITERS>>());
      unit(static_cast<Stage>(s)).trace_to(unit_sigs_.back().get(), enabled, images);
      sc_core::sc_trace(vcd, *unit_sigs_.back(), scope + "." + unit_name(static_cast<Stage>(s)) + "_state");
    }
  }
  /// Without an output: when each group left the accumulator.
  const std::vector<sc_core::sc_time>& completions() const { return completions_; }
  /// The tile computing (ps): its busiest unit's busiest lane (the unit that bounds its
  /// throughput, without the pipeline's fill or any waiting).
  sc_dt::uint64 busy_ps() const { return units()[bottleneck()]->busiest_lane_ps(); }
  /// Its busiest unit (the first in datapath order of those that tie).
  Stage bottleneck() const {
    const std::vector<const TileUnit*> u = units();
    int b = 0;
    for (int s = 1; s < kStages; ++s)
      if (u[s]->busiest_lane_ps() > u[b]->busiest_lane_ps()) b = s;
    return static_cast<Stage>(b);
  }
  /// Every unit as busy as the busiest, joined by '+' (a tie: "crossbar+adc").
  std::string bound_by() const {
    std::string names;
    const sc_dt::uint64 busiest = busy_ps();
    for (const TileUnit* u : units())
      if (u->busiest_lane_ps() == busiest) names += (names.empty() ? "" : "+") + std::string(unit_name(u->stage()));
    return names;
  }
  /// Its busiest unit's time holding finished groups (the output's backpressure reaching it)
  /// and its time without a group (ps): with busy_ps, three disjoint parts of its time.
  sc_dt::uint64 stall_ps() const { return units()[bottleneck()]->stall_ps(); }
  sc_dt::uint64 starved_ps() const { return units()[bottleneck()]->starved_ps(); }
  /// The units in datapath order (their busy and stall times, what they hold).
  std::vector<const TileUnit*> units() const { return {&sr_, &dac_, &xbar_, &adc_, &acc_}; }

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

  TileUnit& unit(Stage s) {
    switch (s) {
      case kShift: return sr_;
      case kDac: return dac_;
      case kCrossbar: return xbar_;
      case kAdc: return adc_;
      case kAccumulate: return acc_;
      case kStages: break;
    }
    throw std::logic_error("Tile::unit: no such unit");
  }

  void b_transport(tlm::tlm_generic_payload& p, sc_core::sc_time& delay) {
    LayerJob* job = job_of(p);
    const bool part_ok = job && job->first_iteration >= 0 &&
                         job->first_iteration + job->group_iterations() <= job->iterations() &&
                         (job->timing_only || job->whole_pass()) &&  // values: the whole pass
                         job->replication >= 1 && job->replication <= copies_ &&
                         (!job->sparse || (job->timing_only && job->replication == 1 && given_latencies(*job)));
    if (!part_ok) {
      p.set_response_status(tlm::TLM_COMMAND_ERROR_RESPONSE);
      return;
    }
    // The units run on the kernel's time: the initiator's local time is waited first.
    if (delay > sc_core::SC_ZERO_TIME) {
      sc_core::wait(delay);
      delay = sc_core::SC_ZERO_TIME;
    }
    if (job->sparse) {  // its single iteration, on the group of its first row
      if (job->first_iteration == 0) ++iterations_;
      p.set_response_status(tlm::TLM_OK_RESPONSE);
    } else {
      tile2sr->b_transport(p, delay);
      if (p.get_response_status() != tlm::TLM_OK_RESPONSE) return;
      iterations_ += job->group_iterations();
      outputs_written_ += static_cast<long long>(job->group_iterations()) * job->analog->outputs();
    }
    TileToken* t = token(*job);
    fifo_[kShift]->write(t);  // waits while the shift register's FIFO is full
    sc_core::wait(t->shifted);
  }

  /// A sparse job gives one latency per unit.
  static bool given_latencies(const LayerJob& job) {
    for (const std::vector<double>& ns : job.stage_ns)
      if (ns.size() != 1 || !(ns[0] >= 0)) return false;
    return true;
  }

  /// A token of the job's group: its iterations' latency at each unit, in whole cycles
  /// (detailed timing; ideal: a cycle per read at the crossbars, nothing elsewhere). A sparse
  /// job's group is one iteration of the latencies it gives.
  TileToken* token(const LayerJob& job) {
    TileToken* t;
    if (pool_.empty()) {
      tokens_.push_back(std::make_unique<TileToken>());
      t = tokens_.back().get();
    } else {
      t = pool_.back();
      pool_.pop_back();
    }
    const int g = job.group_iterations(), n = job.sparse ? 1 : g, w = std::max(1, job.layer->out.w);
    t->image = static_cast<int>(job.image);
    t->row = job.first_iteration / w;
    t->rows = (job.first_iteration + g + w - 1) / w - t->row;
    t->n = n;
    t->lanes = std::max(1, std::min(job.replication, n));
    t->entered = sr_.entry(sc_core::sc_time_stamp().value());
    t->ready.assign(static_cast<size_t>(n), t->entered);
    const double clk = cfg_.clock_ns();
    for (int s = 0; s < kStages; ++s) {
      std::vector<sc_dt::uint64>& lat = t->latency[s];
      lat.resize(static_cast<size_t>(n));
      if (!job.detailed && !job.sparse) {
        std::fill(lat.begin(), lat.end(), s == kCrossbar ? cycle_ps_ * static_cast<sc_dt::uint64>(job.read_times()) : 0);
        continue;
      }
      const std::vector<double>& ns = job.stage_ns[s];
      for (int k = 0; k < n; ++k) {  // whole cycles (a latency repeats: converted once)
        const double v = ns[static_cast<size_t>(k)];
        if (k > 0 && v == ns[static_cast<size_t>(k - 1)]) {
          lat[static_cast<size_t>(k)] = lat[static_cast<size_t>(k - 1)];
          continue;
        }
        lat[static_cast<size_t>(k)] = static_cast<sc_dt::uint64>(std::ceil(v / clk - 1e-9)) * cycle_ps_;
      }
    }
    return t;
  }

  /// The accumulator's hand-over of a finished group.
  bool deliver(TileToken& t) {
    if (out_ && !out_(t)) return false;
    if (!out_) completions_.push_back(sc_core::sc_time_stamp());
    pool_.push_back(&t);
    return true;
  }

  PlatformConfig cfg_;
  int copies_;
  ShiftRegisterBuffer sr_;
  Dac dac_;
  CrossbarArray xbar_;
  Adc adc_;
  DigitalAccumulator acc_;
  long long iterations_ = 0, outputs_written_ = 0;
  std::unique_ptr<TokenFifo> fifo_[kStages];  ///< each unit's input
  std::vector<std::unique_ptr<TileToken>> tokens_;
  std::vector<TileToken*> pool_;  ///< tokens not in flight
  std::function<bool(const TileToken&)> out_;
  sc_core::sc_event never_;  ///< without an output every group is taken: nothing waits for space
  sc_dt::uint64 clock_ = 0;     ///< ps the units align to; 0: ideal timing
  sc_dt::uint64 cycle_ps_ = 0;  ///< a clock cycle
  std::vector<sc_core::sc_time> completions_;
  std::vector<std::unique_ptr<sc_core::sc_signal<int, sc_core::SC_UNCHECKED_WRITERS>>> unit_sigs_;
};

}  // namespace xbarsim
