#pragma once
/// A unit of a tile's datapath as a SystemC process (an SC_METHOD): each of the tile's
/// modules (shift register, DACs, crossbars with their sample-and-holds, ADCs, accumulator)
/// is one. A row group travels through the units as a token in bounded FIFOs
/// (platform.fifo_depth groups each). A unit takes the next token from its input FIFO, works
/// its iterations in order, each once the previous unit has done it and the unit is free
/// (start = max(ready, free), in whole cycles of platform.clock_mhz), the tile's copies as
/// lanes of their own (lane q takes the q-th contiguous share of the group), holds the group
/// until its last iteration is done, and hands it to the next unit's FIFO, waiting while that
/// one is full (the time it holds a finished group is its stall, and it is busy again only
/// from then on). The last unit delivers the group's output rows. A unit's time is what the
/// processes make of it: the iterations of one group overlap from unit to unit (an
/// iteration goes on as soon as it is done), groups follow each other through the FIFOs, and
/// a unit blocked by a full FIFO holds up its predecessors.
#include <algorithm>
#include <functional>
#include <memory>
#include <string>
#include <vector>
#include <systemc>

#include "modules/LayerJob.h"

namespace xbarsim {

/// A row group on its way through a tile's units: its iterations' times in ps (the kernel's
/// time unit, so that every comparison is exact).
struct TileToken {
  int image = 0, row = 0, rows = 0;  ///< the output rows it computes
  int n = 0;                         ///< iterations
  int lanes = 1;                     ///< copies sharing them
  /// Per iteration: when the previous unit had it done (on entry: when the group entered).
  std::vector<sc_dt::uint64> ready;
  std::vector<sc_dt::uint64> latency[kStages];  ///< per iteration, each unit's time (whole cycles)
  sc_dt::uint64 entered = 0;  ///< when the group entered the tile
  sc_core::sc_event shifted;  ///< the first unit has worked every iteration (its inputs are read)
  /// Iterations [first(q), first(q + 1)) are lane q's.
  int first(int q) const { return static_cast<int>(static_cast<long long>(q) * n / lanes); }
};

/// A bounded FIFO of row groups before a unit: sc_fifo's non-blocking interface with immediate
/// notification, so that a hand-over wakes the next unit in the same evaluation phase (no
/// update phase and delta cycle per hop). Depth: platform.fifo_depth.
class TokenFifo {
 public:
  explicit TokenFifo(int depth) : slots_(static_cast<size_t>(std::max(1, depth)), nullptr) {}
  bool nb_write(TileToken* t) {
    if (count_ == slots_.size()) return false;
    slots_[(head_ + count_++) % slots_.size()] = t;
    written_.notify();
    return true;
  }
  bool nb_read(TileToken*& t) {
    if (count_ == 0) return false;
    t = slots_[head_];
    head_ = (head_ + 1) % slots_.size();
    --count_;
    read_.notify();
    return true;
  }
  /// From a thread: waits while it is full.
  void write(TileToken* t) {
    while (!nb_write(t)) sc_core::wait(read_);
  }
  const sc_core::sc_event& data_written_event() const { return written_; }
  const sc_core::sc_event& data_read_event() const { return read_; }

 private:
  std::vector<TileToken*> slots_;
  size_t head_ = 0, count_ = 0;
  sc_core::sc_event written_, read_;
};

class TileUnit : public sc_core::sc_module {
 public:
  /// The next unit's input, or (the last unit) where its groups go: `deliver` returns false
  /// while the receiver is full, and `space` fires when it may have room.
  struct Output {
    TokenFifo* fifo = nullptr;
    std::function<bool(TileToken&)> deliver;
    const sc_core::sc_event* space = nullptr;
  };

  TileUnit(sc_core::sc_module_name name, Stage stage) : sc_module(name), stage_(stage) {
    SC_HAS_PROCESS(TileUnit);
    SC_METHOD(process);
  }
  Stage stage() const { return stage_; }
  /// Before the simulation: its input FIFO, its output, its lanes (the tile's copies), the
  /// clock its starts are aligned to (0: none, ideal timing).
  void connect(TokenFifo* in, Output out, int lanes, sc_dt::uint64 clock) {
    in_ = in;
    out_ = std::move(out);
    free_.assign(static_cast<size_t>(std::max(1, lanes)), 0);
    busy_.assign(free_.size(), 0);
    clock_ = clock;
  }
  int lanes() const { return static_cast<int>(free_.size()); }
  /// The time it worked iterations (ps): summed over its lanes, and its busiest lane's.
  sc_dt::uint64 busy_ps() const {
    sc_dt::uint64 b = 0;
    for (sc_dt::uint64 x : busy_) b += x;
    return b;
  }
  sc_dt::uint64 busiest_lane_ps() const { return busy_.empty() ? 0 : *std::max_element(busy_.begin(), busy_.end()); }
  /// The time it held finished groups that the next unit's FIFO could not take (ps).
  sc_dt::uint64 stall_ps() const { return stall_; }
  /// The time it had no group to work (ps), from the start of the simulation.
  sc_dt::uint64 starved_ps() const { return starved_; }
  /// A group taken and not yet handed on (for the report of a simulation that stopped).
  bool holding() const { return current_ != nullptr; }
  /// Traces its state into `sig` while `*enabled`, for groups of images below `*images`:
  /// 0 idle, 1 working a group, 2 holding a finished group its next FIFO cannot take.
  void trace_to(sc_core::sc_signal<int, sc_core::SC_UNCHECKED_WRITERS>* sig, const bool* enabled, const int* images) {
    sig_ = sig;
    enabled_ = enabled;
    images_ = images;
  }

 private:
  void process() {
    const sc_dt::uint64 now = sc_core::sc_time_stamp().value();
    if (current_) {
      if (now < finish_) {
        next_trigger(sc_core::sc_time::from_value(finish_ - now));
        return;
      }
      const bool handed = out_.fifo ? out_.fifo->nb_write(current_) : out_.deliver(*current_);
      if (!handed) {
        traced(2);
        next_trigger(out_.fifo ? out_.fifo->data_read_event() : *out_.space);
        return;
      }
      traced(0);
      if (now > finish_) {  // held while the next could not take it: every lane free only now
        stall_ += now - finish_;
        for (sc_dt::uint64& f : free_) f = std::max(f, on_edge(now));
      }
      current_ = nullptr;
    }
    if (!in_ || !in_->nb_read(current_)) {
      if (!idle_) idle_since_ = now;
      idle_ = true;
      if (in_) next_trigger(in_->data_written_event());
      return;
    }
    work(*current_, now);
    traced(1);
    if (stage_ == kShift) current_->shifted.notify(sc_core::sc_time::from_value(finish_ - now));
    next_trigger(sc_core::sc_time::from_value(finish_ - now));
  }

  void traced(int state) {
    if (sig_ && *enabled_ && current_ && current_->image < *images_) sig_->write(state);
  }
  /// The first clock edge at or after `t` (ideal timing: t).
  sc_dt::uint64 on_edge(sc_dt::uint64 t) const { return clock_ > 0 && t % clock_ ? t + clock_ - t % clock_ : t; }

 public:
  /// When a group that enters at `t` may start: the first clock edge at or after it.
  sc_dt::uint64 entry(sc_dt::uint64 t) const { return on_edge(t); }

 private:
  /// Every iteration of the group in order on its lane; the group is done with the last.
  void work(TileToken& t, sc_dt::uint64 now) {
    finish_ = now;
    sc_dt::uint64 first_start = now;
    const std::vector<sc_dt::uint64>& lat = t.latency[stage_];
    const int used = std::min<int>(t.lanes, lanes());
    for (int q = 0; q < used; ++q) {
      sc_dt::uint64& free = free_[static_cast<size_t>(q)];
      const int begin = t.first(q), end = t.first(q + 1);
      sc_dt::uint64 worked = 0;
      for (int k = begin; k < end; ++k) {
        // (Entry times and a stalled unit's free time are on clock edges and every latency is
        // whole cycles, so every start is on an edge.)
        const sc_dt::uint64 start = std::max(t.ready[static_cast<size_t>(k)], free);
        if (k == begin) first_start = std::min(first_start, start);
        free = start + lat[static_cast<size_t>(k)];
        t.ready[static_cast<size_t>(k)] = free;
        worked += lat[static_cast<size_t>(k)];
      }
      busy_[static_cast<size_t>(q)] += worked;
      finish_ = std::max(finish_, free);
    }
    // Starved from when it had nothing to do until it began this group (which may have been
    // before the group was handed to it: its iterations were done upstream one by one).
    if (idle_ && first_start > idle_since_) starved_ += first_start - idle_since_;
    idle_ = false;
  }

  Stage stage_;
  TokenFifo* in_ = nullptr;
  Output out_;
  std::vector<sc_dt::uint64> free_;  ///< per lane: when it has done its last iteration
  sc_dt::uint64 clock_ = 0;
  TileToken* current_ = nullptr;
  sc_dt::uint64 finish_ = 0;
  std::vector<sc_dt::uint64> busy_;  ///< per lane
  sc_dt::uint64 stall_ = 0, starved_ = 0;
  sc_core::sc_signal<int, sc_core::SC_UNCHECKED_WRITERS>* sig_ = nullptr;
  const bool* enabled_ = nullptr;
  const int* images_ = nullptr;
  bool idle_ = true;  ///< no group in hand, since idle_since_ (ps)
  sc_dt::uint64 idle_since_ = 0;
};

}  // namespace xbarsim
