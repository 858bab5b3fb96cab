#include "sw/hw/component_library.h"

#include "sw/common/input_file.h"

namespace xbarsim {

const char* builtin_component_library_yaml(const char* name);  // configs/components/<name>.yaml, compiled in

const char* const kCrossbarCoreComponents[12] = {"cell",          "adc",          "dac",       "accumulator",
                                                 "shift_register", "sample_hold", "shift_add", "output_register",
                                                 "buffer",        "interconnect", "digital",   "memory"};

double ComponentLibrary::param(const std::string& component, const std::string& key, double fallback) const {
  const auto c = named.components.find(component);
  if (c == named.components.end()) return fallback;
  const auto p = c->second.params.find(key);
  if (p == c->second.params.end())
    throw InputError(source + ": component '" + component + "' needs params." + key);
  return p->second;
}

ComponentLibrary parse_component_library(const std::string& text, const std::string& origin) {
  if (!is_named_library(text))
    throw InputError(origin + ": a component library is a top-level 'components:' map of name -> area_mm2 (or "
                     "area_um2), leakage_mw (or leakage_nw) and actions (pJ each); the fixed sections of earlier "
                     "versions (adc:, dac:, cell:, ...) are written as components of those names, as "
                     "configs/components/isaac.yaml is (docs/architecture.md)");
  ComponentLibrary lib;
  lib.source = origin;
  lib.named = parse_named_library(text, origin);
  return lib;
}

ComponentLibrary load_component_library(const ConfigTree& cfg) {
  const std::string path = cfg.get_string("components.library");
  // A built-in library by name (a file of that name must be written as ./isaac etc.).
  const std::string name = path.empty() ? "isaac_paper" : path;
  const char* builtin = builtin_component_library_yaml(name.c_str());
  const std::string origin = builtin ? "built-in configs/components/" + name + ".yaml" : path;
  const std::string text =
      builtin ? builtin : read_input_file(path, "the component library (components.library)", kMaxYamlBytes);
  return parse_component_library(text, origin);
}

}  // namespace xbarsim
