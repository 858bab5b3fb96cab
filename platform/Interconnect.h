#pragma once
/// On-chip interconnect: routes the controller's transactions by address, the upper 32
/// bits selecting a tile (1..N) and 0 the input/output buffer.
#include <systemc>
#include <tlm>
#include <tlm_utils/multi_passthrough_initiator_socket.h>
#include <tlm_utils/simple_initiator_socket.h>
#include <tlm_utils/simple_target_socket.h>

namespace xbarsim {

class Interconnect : public sc_core::sc_module {
 public:
  tlm_utils::simple_target_socket<Interconnect> ctrl2noc{"ctrl2noc"};
  tlm_utils::multi_passthrough_initiator_socket<Interconnect> noc2tile{"noc2tile"};
  tlm_utils::simple_initiator_socket<Interconnect> noc2io{"noc2io"};

  explicit Interconnect(sc_core::sc_module_name name) : sc_module(name) {
    ctrl2noc.register_b_transport(this, &Interconnect::b_transport);
  }
  static sc_dt::uint64 tile_address(int tile) { return static_cast<sc_dt::uint64>(tile + 1) << 32; }

 private:
  void b_transport(tlm::tlm_generic_payload& p, sc_core::sc_time& delay) {
    const sc_dt::uint64 tile = p.get_address() >> 32;
    if (tile == 0) {
      noc2io->b_transport(p, delay);
    } else if (tile <= static_cast<sc_dt::uint64>(noc2tile.size())) {
      noc2tile[static_cast<int>(tile - 1)]->b_transport(p, delay);
    } else {
      p.set_response_status(tlm::TLM_ADDRESS_ERROR_RESPONSE);
    }
  }
};

}  // namespace xbarsim
