#pragma once
/// The on-chip interconnect as a shared TLM-2.0 bus of `lanes` parallel links: every
/// activation row crosses it. One transfer occupies a link for ceil(bytes / link width) cycles
/// plus the hop latency; transfers take the link that frees first, in the order they arrive
/// (contention), which the target books and returns as the annotated delay (loosely timed:
/// it never waits itself).
#include <algorithm>
#include <cmath>
#include <vector>
#include <systemc>
#include <tlm>
#include <tlm_utils/multi_passthrough_target_socket.h>
#include "modules/sim_time.h"
#include "platform/Transfer.h"

namespace xbarsim {

class Bus : public sc_core::sc_module {
 public:
  tlm_utils::multi_passthrough_target_socket<Bus> stage2bus{"stage2bus"};

  Bus(sc_core::sc_module_name name, double clock_ns, int bytes_per_cycle, int hop_cycles, int lanes = 1)
      : sc_module(name),
        clock_ns_(clock_ns),
        width_(bytes_per_cycle),
        hop_cycles_(hop_cycles),
        free_at_(std::max(lanes, 1), sc_core::SC_ZERO_TIME) {
    stage2bus.register_b_transport(this, &Bus::b_transport);
  }
  long long bytes() const { return bytes_; }
  long long transfers() const { return transfers_; }
  double busy_ns() const { return busy_.to_seconds() * 1e9; }
  /// Time of one transfer of `bytes` on an idle link.
  double transfer_ns(long long bytes) const {
    return (std::ceil(static_cast<double>(bytes) / width_) + hop_cycles_) * clock_ns_;
  }

 private:
  void b_transport(int, tlm::tlm_generic_payload& p, sc_core::sc_time& delay) {
    const sc_core::sc_time now = sc_core::sc_time_stamp() + delay;
    sc_core::sc_time& lane = *std::min_element(free_at_.begin(), free_at_.end());
    const sc_core::sc_time start = std::max(now, lane);
    const sc_core::sc_time dur = sim_delay(transfer_ns(wire_bytes(p)), start - sc_core::sc_time_stamp());
    lane = start + dur;
    busy_ += dur;
    bytes_ += wire_bytes(p);
    ++transfers_;
    delay = lane - sc_core::sc_time_stamp();
    p.set_response_status(tlm::TLM_OK_RESPONSE);
  }
  double clock_ns_;
  int width_, hop_cycles_;
  std::vector<sc_core::sc_time> free_at_;  ///< per lane: when it is free again
  sc_core::sc_time busy_ = sc_core::SC_ZERO_TIME;
  long long bytes_ = 0, transfers_ = 0;
};

}  // namespace xbarsim
