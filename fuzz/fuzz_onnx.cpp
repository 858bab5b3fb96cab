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
    if (m.output < 0 || m.output >= nv) __builtin_trap();
    // Every value has a positive C x H x W (what the executor sizes its buffers from).
    for (const auto& s : m.values)
      if (s.c < 1 || s.h < 1 || s.w < 1) __builtin_trap();
    for (const auto& op : m.ops) {
      if (op.out < 0 || op.out >= nv) __builtin_trap();
      for (int v : op.in)
        if (v < 0 || v >= nv) __builtin_trap();
    }
  } catch (const xbarsim::InputError&) {
  }
  return 0;
}
