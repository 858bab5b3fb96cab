// libFuzzer harness: load_onnx_model on arbitrary file contents (protobuf bytes).
// Expected outcome for bad input: xbarsim::InputError. Anything else is a finding.
#include <cstddef>
#include <cstdint>

#include "fuzz/fuzz_util.h"
#include "sw/common/errors.h"
#include "sw/nn/model.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const std::string path = xbarsim_fuzz::temp_path("onnx");
  xbarsim_fuzz::write_file(path, data, size);
  try {
    const xbarsim::Model m = xbarsim::load_onnx_model(path);
    // A loaded model must be internally consistent: value ids in range, shapes positive.
    const int nv = static_cast<int>(m.values.size());
    XBARSIM_FUZZ_CHECK(m.output >= 0 && m.output < nv);
    // Every value has a positive C x H x W (what the executor sizes its buffers from).
    for (const auto& s : m.values) XBARSIM_FUZZ_CHECK(s.c >= 1 && s.h >= 1 && s.w >= 1);
    for (const auto& op : m.ops) {
      XBARSIM_FUZZ_CHECK(op.out >= 0 && op.out < nv);
      for (int v : op.in) XBARSIM_FUZZ_CHECK(v >= 0 && v < nv);
    }
  } catch (const xbarsim::InputError&) {
  }
  return 0;
}
