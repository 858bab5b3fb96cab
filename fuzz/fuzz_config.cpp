// libFuzzer harness: the configuration tree (YAML merge, --set overrides, typed getters, sweeps).
// Expected outcome for bad input: xbarsim::InputError. Anything else (yaml-cpp exceptions,
// std::out_of_range, crashes, sanitizer reports) is a finding.
#include <cstddef>
#include <cstdint>
#include <string>

#include "sw/common/config.h"
#include "sw/common/errors.h"

namespace {

template <class F>
void expect_input_error_only(F&& f) {
  try {
    f();
  } catch (const xbarsim::InputError&) {
  }
}

void read_some(const xbarsim::ConfigTree& cfg) {
  using xbarsim::ConfigTree;
  expect_input_error_only([&] { (void)cfg.get_int("study.vectors"); });
  expect_input_error_only([&] { (void)cfg.get_int("solver.max_iterations"); });
  expect_input_error_only([&] { (void)cfg.get_double("solver.tolerance"); });
  expect_input_error_only([&] { (void)cfg.get_double("crossbar.r_wire"); });
  expect_input_error_only([&] { (void)cfg.get_string("mapping.max_rows"); });
  expect_input_error_only([&] { (void)cfg.get_string("mitigation.method"); });
  expect_input_error_only([&] { (void)cfg.get_bool("conversion.column_scaling"); });
  expect_input_error_only([&] { (void)xbarsim::require_size_or_unbounded(cfg, "mapping.max_rows"); });
  expect_input_error_only([&] { (void)cfg.get_double("crossbar.g_max"); });
  expect_input_error_only([&] {
    for (const auto& key : cfg.sweep_keys()) {
      (void)cfg.is_list(key);
      (void)cfg.list_items(key);
    }
  });
  expect_input_error_only([&] { (void)cfg.dump(); });
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  // Whole input as a YAML document merged over the defaults.
  {
    xbarsim::ConfigTree cfg;
    expect_input_error_only([&] { cfg.merge_yaml_text(text, "fuzz"); });
    read_some(cfg);
  }
  // First line as a `--set key=value` override, then the rest as a YAML document (so an input
  // "key=value\n<yaml>" exercises both paths).
  {
    xbarsim::ConfigTree cfg;
    const size_t nl = text.find('\n');
    const std::string line = text.substr(0, nl);
    expect_input_error_only([&] { cfg.apply_override(line); });
    if (nl != std::string::npos)
      expect_input_error_only([&] { cfg.merge_yaml_text(text.substr(nl + 1), "fuzz rest"); });
    read_some(cfg);
  }
  return 0;
}
