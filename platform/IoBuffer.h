#pragma once
/// Input/output buffer: the image comes in and the logits go out through it; a transfer
/// of W 32-bit words takes ceil(W / words_per_cycle) clock cycles.
#include <cmath>
#include <cstring>
#include <systemc>
#include <tlm>
#include <tlm_utils/simple_target_socket.h>
#include <vector>

namespace xbarsim {

class IoBuffer : public sc_core::sc_module {
 public:
  tlm_utils::simple_target_socket<IoBuffer> noc2io{"noc2io"};

  IoBuffer(sc_core::sc_module_name name, size_t bytes, double clock_ns, int words_per_cycle)
      : sc_module(name), mem_(bytes), clock_ns_(clock_ns), words_per_cycle_(words_per_cycle) {
    noc2io.register_b_transport(this, &IoBuffer::b_transport);
  }
  long long words() const { return words_; }

 private:
  void b_transport(tlm::tlm_generic_payload& p, sc_core::sc_time& delay) {
    const sc_dt::uint64 a = p.get_address() & 0xffffffffu;
    const unsigned len = p.get_data_length();
    if (a + len > mem_.size() || p.get_byte_enable_ptr()) {
      p.set_response_status(tlm::TLM_ADDRESS_ERROR_RESPONSE);
      return;
    }
    if (p.is_write())
      std::memcpy(mem_.data() + a, p.get_data_ptr(), len);
    else if (p.is_read())
      std::memcpy(p.get_data_ptr(), mem_.data() + a, len);
    else {
      p.set_response_status(tlm::TLM_COMMAND_ERROR_RESPONSE);
      return;
    }
    const long long w = (len + 3) / 4;
    words_ += w;
    delay += sc_core::sc_time(std::ceil(static_cast<double>(w) / words_per_cycle_) * clock_ns_, sc_core::SC_NS);
    p.set_response_status(tlm::TLM_OK_RESPONSE);
  }
  std::vector<unsigned char> mem_;
  double clock_ns_;
  int words_per_cycle_;
  long long words_ = 0;
};

}  // namespace xbarsim
