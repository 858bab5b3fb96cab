#include "sw/hw/component_library.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>
#include <vector>

namespace xbarsim {

const char* builtin_component_library_yaml();  // generated from configs/components/isaac_paper.yaml

double scale_by_bits(double value, int ref, int bits, Scaling rule) {
  switch (rule) {
    case Scaling::Exponential:
      return value * std::ldexp(1.0, bits - ref);
    case Scaling::Linear:
      return value * bits / ref;
    case Scaling::Constant:
      return value;
  }
  return value;
}

double ConverterSpec::power_at(int bits) const { return scale_by_bits(power_mw, reference_bits, bits, power_scaling); }
double ConverterSpec::area_at(int bits) const { return scale_by_bits(area_mm2, reference_bits, bits, area_scaling); }

namespace {

double number(const YAML::Node& root, const std::string& sec, const std::string& key, const std::string& origin,
              bool positive = true) {
  const YAML::Node n = root[sec] ? root[sec][key] : YAML::Node();
  if (!n) throw InputError(origin + ": missing key '" + sec + "." + key + "'");
  try {
    const double v = n.as<double>();
    if (!std::isfinite(v) || (positive ? !(v > 0) : v < 0)) throw YAML::Exception(YAML::Mark(), "range");
    return v;
  } catch (const YAML::Exception&) {
    throw InputError(origin + ": '" + sec + "." + key + "' must be a " + (positive ? "positive" : "non-negative") +
                     " number, got '" + (n.IsScalar() ? n.Scalar() : "?") + "'");
  }
}

/// A positive integer (bits, column counts): 8.5 or 0 is an error, not truncated.
int integer(const YAML::Node& root, const std::string& sec, const std::string& key, const std::string& origin) {
  const double v = number(root, sec, key, origin);
  if (v != std::floor(v) || v > (1 << 30))
    throw InputError(origin + ": '" + sec + "." + key + "' must be a positive integer, got '" +
                     root[sec][key].Scalar() + "'");
  return static_cast<int>(v);
}

/// Rejects keys of section `sec` outside `allowed` (a misspelt scaling rule would
/// otherwise fall back to the default silently).
void only_keys(const YAML::Node& root, const std::string& sec, const std::vector<std::string>& allowed,
               const std::string& origin) {
  const YAML::Node n = root[sec];
  if (!n) throw InputError(origin + ": missing section '" + sec + "'");
  if (!n.IsMap()) throw InputError(origin + ": section '" + sec + "' must be a map of keys");
  for (auto it = n.begin(); it != n.end(); ++it) {
    const std::string k = it->first.as<std::string>();
    if (std::find(allowed.begin(), allowed.end(), k) == allowed.end()) {
      std::string list;
      for (const auto& a : allowed) list += (list.empty() ? "" : ", ") + a;
      throw InputError(origin + ": unknown key '" + sec + "." + k + "' (" + list + ")");
    }
  }
}

Scaling scaling(const YAML::Node& root, const std::string& sec, const std::string& key, const std::string& origin) {
  const YAML::Node n = root[sec] ? root[sec][key] : YAML::Node();
  if (!n) return Scaling::Exponential;
  const std::string s = n.Scalar();
  if (s == "exponential") return Scaling::Exponential;
  if (s == "linear") return Scaling::Linear;
  if (s == "constant") return Scaling::Constant;
  throw InputError(origin + ": '" + sec + "." + key + "' must be exponential, linear or constant, got '" + s + "'");
}

ConverterSpec converter(const YAML::Node& root, const std::string& sec, const std::string& origin) {
  ConverterSpec c;
  c.power_mw = number(root, sec, "power_mw", origin);
  c.area_mm2 = number(root, sec, "area_mm2", origin);
  c.reference_bits = integer(root, sec, "reference_bits", origin);
  c.power_scaling = scaling(root, sec, "power_scaling", origin);
  c.area_scaling = scaling(root, sec, "area_scaling", origin);
  return c;
}

}  // namespace

ComponentLibrary parse_component_library(const std::string& text, const std::string& origin) {
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    throw InputError(origin + ": YAML syntax error: " + e.what());
  }
  for (auto it = root.begin(); it != root.end(); ++it) {
    const std::string k = it->first.as<std::string>();
    if (k != "adc" && k != "dac" && k != "cell" && k != "accumulator")
      throw InputError(origin + ": unknown section '" + k + "' (adc, dac, cell, accumulator)");
  }
  const std::vector<std::string> converter_keys{"power_mw", "area_mm2", "reference_bits", "power_scaling",
                                                "area_scaling"};
  std::vector<std::string> adc_keys = converter_keys;
  adc_keys.insert(adc_keys.end(), {"columns_per_unit", "sample_rate_gsps"});
  only_keys(root, "adc", adc_keys, origin);
  only_keys(root, "dac", converter_keys, origin);
  only_keys(root, "cell", {"power_mw", "area_mm2"}, origin);
  only_keys(root, "accumulator", {"power_mw", "area_mm2"}, origin);
  ComponentLibrary lib;
  lib.source = origin;
  lib.adc = converter(root, "adc", origin);
  lib.dac = converter(root, "dac", origin);
  lib.adc_columns_per_unit = integer(root, "adc", "columns_per_unit", origin);
  lib.adc_sample_rate_gsps = number(root, "adc", "sample_rate_gsps", origin);
  lib.cell_power_mw = number(root, "cell", "power_mw", origin);
  lib.cell_area_mm2 = number(root, "cell", "area_mm2", origin);
  lib.accumulator_power_mw = number(root, "accumulator", "power_mw", origin, false);
  lib.accumulator_area_mm2 = number(root, "accumulator", "area_mm2", origin, false);
  return lib;
}

ComponentLibrary load_component_library(const ConfigTree& cfg) {
  const std::string path = cfg.get_string("components.library");
  ComponentLibrary lib;
  if (path.empty()) {
    lib = parse_component_library(builtin_component_library_yaml(), "built-in configs/components/isaac_paper.yaml");
  } else {
    std::ifstream in(path);
    if (!in) throw InputError("cannot open component library '" + path + "' (components.library)");
    std::stringstream ss;
    ss << in.rdbuf();
    lib = parse_component_library(ss.str(), path);
  }
  const int share = cfg.get_int32("components.adc_columns_per_adc");
  if (share > 0) lib.adc_columns_per_unit = share;
  return lib;
}

}  // namespace xbarsim
