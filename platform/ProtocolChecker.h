#pragma once
/// A pass-through module that checks the TLM-2.0 base protocol's rules for blocking transport
/// (IEEE 1666-2011, 14.x: the generic payload's attributes and the initiator's and target's
/// obligations) on every transaction it forwards, and keeps what it found. The Accellera
/// checker is not packaged for Debian; this one covers the rules our b_transport traffic can
/// break. `platform.check_protocol: true` puts one in front of every target the pipeline
/// calls (interconnect, tiles); the tests run it and check it against crafted payloads.
#include <set>
#include <string>
#include <systemc>
#include <tlm>
#include <tlm_utils/simple_initiator_socket.h>
#include <tlm_utils/simple_target_socket.h>
#include <vector>

namespace xbarsim {

class ProtocolChecker : public sc_core::sc_module {
 public:
  tlm_utils::simple_target_socket<ProtocolChecker> in{"in"};
  tlm_utils::simple_initiator_socket<ProtocolChecker> out{"out"};

  explicit ProtocolChecker(sc_core::sc_module_name name) : sc_module(name) {
    in.register_b_transport(this, &ProtocolChecker::b_transport);
  }
  long long transactions() const { return transactions_; }
  /// "<checker name>: <rule>" for every broken rule, in the order found.
  const std::vector<std::string>& violations() const { return violations_; }

  /// The attributes a target must not change (checked on return).
  struct Request {
    tlm::tlm_command command;
    unsigned char* data;
    unsigned length, streaming_width, byte_enable_length;
    unsigned char* byte_enable;
    sc_core::sc_time starts;  ///< simulation time + annotated delay at the call
  };
  /// The initiator's obligations before a call: the broken rules, or none.
  static std::vector<std::string> check_request(const tlm::tlm_generic_payload& p) {
    std::vector<std::string> v;
    const tlm::tlm_command c = p.get_command();
    if (c != tlm::TLM_READ_COMMAND && c != tlm::TLM_WRITE_COMMAND && c != tlm::TLM_IGNORE_COMMAND)
      v.push_back("the command is not read, write or ignore");
    if (!p.get_data_ptr()) v.push_back("the data pointer is null");
    if (p.get_data_length() == 0) v.push_back("the data length is 0");
    if (p.get_streaming_width() == 0) v.push_back("the streaming width is 0");
    if (p.get_byte_enable_ptr() && p.get_byte_enable_length() == 0)
      v.push_back("a byte enable pointer with byte enable length 0");
    if (p.get_response_status() != tlm::TLM_INCOMPLETE_RESPONSE)
      v.push_back("the response status is not TLM_INCOMPLETE_RESPONSE on the call");
    if (p.is_dmi_allowed()) v.push_back("the DMI hint is set on the call");
    if (p.has_mm() && p.get_ref_count() <= 0) v.push_back("a payload with a memory manager and no reference");
    return v;
  }
  /// The target's obligations on return.
  static std::vector<std::string> check_response(const Request& r, const tlm::tlm_generic_payload& p,
                                                 const sc_core::sc_time& delay) {
    std::vector<std::string> v;
    if (p.get_response_status() == tlm::TLM_INCOMPLETE_RESPONSE)
      v.push_back("the target returned with TLM_INCOMPLETE_RESPONSE");
    if (p.get_command() != r.command) v.push_back("the target changed the command");
    if (p.get_data_ptr() != r.data) v.push_back("the target changed the data pointer");
    if (p.get_data_length() != r.length) v.push_back("the target changed the data length");
    if (p.get_streaming_width() != r.streaming_width) v.push_back("the target changed the streaming width");
    if (p.get_byte_enable_ptr() != r.byte_enable || p.get_byte_enable_length() != r.byte_enable_length)
      v.push_back("the target changed the byte enables");
    if (sc_core::sc_time_stamp() + delay < r.starts)
      v.push_back("the transaction completes before it started (time + delay went back)");
    return v;
  }
  static Request request_of(const tlm::tlm_generic_payload& p, const sc_core::sc_time& delay) {
    return {p.get_command(),
            p.get_data_ptr(),
            p.get_data_length(),
            p.get_streaming_width(),
            p.get_byte_enable_length(),
            p.get_byte_enable_ptr(),
            sc_core::sc_time_stamp() + delay};
  }

 private:
  void b_transport(tlm::tlm_generic_payload& p, sc_core::sc_time& delay) {
    ++transactions_;
    note(check_request(p));
    if (!in_flight_.insert(&p).second) note({"a payload sent again while it is in flight"});
    const Request r = request_of(p, delay);
    out->b_transport(p, delay);
    in_flight_.erase(&p);
    note(check_response(r, p, delay));
  }
  void note(const std::vector<std::string>& found) {
    for (const std::string& s : found) violations_.push_back(std::string(name()) + ": " + s);
  }
  long long transactions_ = 0;
  std::vector<std::string> violations_;
  std::set<const tlm::tlm_generic_payload*> in_flight_;
};

}  // namespace xbarsim
