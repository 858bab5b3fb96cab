// The base-protocol checker (platform/ProtocolChecker.h) against crafted payloads: each rule it
// checks fires on a payload that breaks it and on nothing else, a clean transaction passes,
// and in front of a target that breaks the target's rules it records them. The pipeline's
// own traffic is checked in test_platform (Platform.*Protocol*).
#include <gtest/gtest.h>

#include <tlm_utils/simple_initiator_socket.h>
#include <tlm_utils/simple_target_socket.h>

#include "platform/MeshNoc.h"
#include "platform/ProtocolChecker.h"
#include "platform/Transfer.h"

using namespace xbarsim;

namespace {

unsigned char g_data[64];

/// A clean write of 64 bytes.
void clean(tlm::tlm_generic_payload& p) {
  p.set_command(tlm::TLM_WRITE_COMMAND);
  p.set_address(0);
  p.set_data_ptr(g_data);
  p.set_data_length(64);
  p.set_streaming_width(64);
  p.set_byte_enable_ptr(nullptr);
  p.set_dmi_allowed(false);
  p.set_response_status(tlm::TLM_INCOMPLETE_RESPONSE);
}

std::string only(const std::vector<std::string>& v) {
  return v.size() == 1 ? v[0] : std::to_string(v.size()) + " rules";
}

/// A target that breaks what `fault` says, after an annotated 5 ns.
struct FaultyTarget : sc_core::sc_module {
  tlm_utils::simple_target_socket<FaultyTarget> in{"in"};
  int fault = 0;  // 0 none, 1 no response, 2 changes the length, 3 takes the delay back
  explicit FaultyTarget(sc_core::sc_module_name n) : sc_module(n) {
    in.register_b_transport(this, &FaultyTarget::b_transport);
  }
  void b_transport(tlm::tlm_generic_payload& p, sc_core::sc_time& delay) {
    delay += sc_core::sc_time(5, sc_core::SC_NS);
    if (fault != 1) p.set_response_status(tlm::TLM_OK_RESPONSE);
    if (fault == 2) p.set_data_length(p.get_data_length() / 2);
    if (fault == 3) delay = sc_core::SC_ZERO_TIME;
  }
};

struct Bench : sc_core::sc_module {
  tlm_utils::simple_initiator_socket<Bench> out{"out"};
  ProtocolChecker checker{"checker"};
  FaultyTarget target{"target"};
  explicit Bench(sc_core::sc_module_name n) : sc_module(n) {
    out.bind(checker.in);
    checker.out.bind(target.in);
  }
};

}  // namespace

TEST(ProtocolChecker, EachRequestRuleFiresOnThePayloadThatBreaksIt) {
  tlm::tlm_generic_payload p;
  clean(p);
  EXPECT_TRUE(ProtocolChecker::check_request(p).empty());
  struct Case {
    const char* rule;
    void (*breaks)(tlm::tlm_generic_payload&);
  };
  const Case cases[] = {
      {"the data pointer is null", [](tlm::tlm_generic_payload& q) { q.set_data_ptr(nullptr); }},
      {"the data length is 0", [](tlm::tlm_generic_payload& q) { q.set_data_length(0); }},
      {"the streaming width is 0", [](tlm::tlm_generic_payload& q) { q.set_streaming_width(0); }},
      {"a byte enable pointer with byte enable length 0",
       [](tlm::tlm_generic_payload& q) {
         q.set_byte_enable_ptr(g_data);
         q.set_byte_enable_length(0);
       }},
      {"the response status is not TLM_INCOMPLETE_RESPONSE on the call",
       [](tlm::tlm_generic_payload& q) { q.set_response_status(tlm::TLM_OK_RESPONSE); }},
      {"the DMI hint is set on the call", [](tlm::tlm_generic_payload& q) { q.set_dmi_allowed(true); }},
  };
  for (const Case& c : cases) {
    tlm::tlm_generic_payload q;
    clean(q);
    c.breaks(q);
    EXPECT_EQ(only(ProtocolChecker::check_request(q)), c.rule);
    q.set_byte_enable_ptr(nullptr);
  }
}

TEST(ProtocolChecker, RecordsWhatATargetBreaksAndPassesACleanTransaction) {
  auto* bench = new Bench("bench");  // lives as long as the simulation context
  sc_core::sc_start(sc_core::SC_ZERO_TIME);
  const char* expected[] = {nullptr, "the target returned with TLM_INCOMPLETE_RESPONSE",
                            "the target changed the data length",
                            "the transaction completes before it started (time + delay went back)"};
  for (int fault = 0; fault < 4; ++fault) {
    bench->target.fault = fault;
    tlm::tlm_generic_payload p;
    clean(p);
    sc_core::sc_time delay(2, sc_core::SC_NS);
    const size_t before = bench->checker.violations().size();
    bench->out->b_transport(p, delay);
    const std::vector<std::string>& v = bench->checker.violations();
    if (!expected[fault]) {
      EXPECT_EQ(v.size(), before);
      EXPECT_EQ(delay, sc_core::sc_time(7, sc_core::SC_NS));  // the checker adds no time
      continue;
    }
    ASSERT_EQ(v.size(), before + 1) << fault;
    EXPECT_EQ(v.back(), std::string("bench.checker: ") + expected[fault]);
  }
  EXPECT_EQ(bench->checker.transactions(), 4);
}
