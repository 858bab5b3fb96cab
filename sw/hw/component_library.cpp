#include "sw/hw/component_library.h"

#include "sw/common/input_file.h"
#include "sw/common/yaml_section.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>
#include <vector>

namespace xbarsim {

const char* builtin_component_library_yaml(const char* name);  // configs/components/<name>.yaml, compiled in

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

double ConverterModel::conversion_pj_at(int bits) const {
  return scale_by_bits(conversion_pj, reference_bits, bits, energy_scaling);
}
double ConverterModel::area_at(int bits) const { return scale_by_bits(area_mm2, reference_bits, bits, area_scaling); }

namespace {

/// energy_scaling / area_scaling: exponential (default), linear or constant in the bits.
Scaling scaling(YamlSection& s, const std::string& key) {
  const std::string v = s.word_or(key, "exponential");
  if (v == "exponential") return Scaling::Exponential;
  if (v == "linear") return Scaling::Linear;
  if (v == "constant") return Scaling::Constant;
  throw InputError(s.where(key) + " must be exponential, linear or constant, got '" + v + "'");
}

ConverterModel converter(YamlSection& s) {
  ConverterModel c;
  c.area_mm2 = s.number("area_mm2", true);
  c.leakage_mw = s.number("leakage_mw");
  c.conversion_pj = s.number("conversion_pj");
  c.reference_bits = s.integer("reference_bits");
  c.energy_scaling = scaling(s, "energy_scaling");
  c.area_scaling = scaling(s, "area_scaling");
  return c;
}

}  // namespace

ComponentLibrary parse_component_library(const std::string& text, const std::string& origin) {
  const YAML::Node root = load_yaml_map(text, origin, "a component library");
  check_yaml_sections(root,
                      {"adc", "dac", "dac_lut", "cell", "accumulator", "shift_register", "sample_hold", "shift_add",
                       "output_register", "buffer", "interconnect", "digital", "memory", "units"},
                      origin);
  ComponentLibrary lib;
  lib.source = origin;
  lib.named.source = origin;
  lib.named.area_unit_mm2 = lib.named.leakage_unit_mw = 1;  // mm^2, mW
  YamlSection adc(root, "adc", origin), dac(root, "dac", origin), lut(root, "dac_lut", origin),
      cell(root, "cell", origin), acc(root, "accumulator", origin), sr(root, "shift_register", origin),
      sh(root, "sample_hold", origin), sa(root, "shift_add", origin), outr(root, "output_register", origin),
      buf(root, "buffer", origin), noc(root, "interconnect", origin), dig(root, "digital", origin),
      mem(root, "memory", origin);
  lib.adc = converter(adc);
  lib.adc_columns_per_unit = adc.integer("columns_per_unit");
  lib.adc_sample_rate_gsps = adc.number("sample_rate_gsps", true);
  lib.dac = converter(dac);
  lib.dac_lut = {lut.number("area_mm2"), lut.number("leakage_mw"), lut.number("read_pj")};
  lib.cell = {cell.number("area_mm2", true), cell.number("leakage_mw"), cell.number("read_pj")};
  lib.accumulator = {acc.number("area_mm2"), acc.number("leakage_mw"), acc.number("accumulate_pj")};
  lib.shift_register = {sr.number("area_mm2_per_entry"), sr.number("leakage_mw_per_entry"), sr.number("shift_pj"),
                        sr.number("read_pj")};
  lib.sample_hold = {sh.number("area_mm2"), sh.number("leakage_mw"), sh.number("sample_pj")};
  lib.shift_add.adcs_per_unit = sa.integer("adcs_per_unit");
  lib.shift_add.area_mm2 = sa.number("area_mm2");
  lib.shift_add.leakage_mw = sa.number("leakage_mw");
  lib.shift_add.op_pj = sa.number("op_pj");
  lib.output_register = {outr.number("area_mm2_per_byte"), outr.number("leakage_mw_per_byte"), outr.number("write_pj")};
  lib.buffer = {buf.number("area_mm2_per_kib"), buf.number("leakage_mw_per_kib"), buf.number("read_pj_per_byte"),
                buf.number("write_pj_per_byte")};
  lib.interconnect = {noc.number("area_mm2"), noc.number("leakage_mw"), noc.number("transfer_pj_per_byte")};
  lib.digital = {dig.number("area_mm2"), dig.number("leakage_mw"), dig.number("op_pj")};
  lib.memory = {mem.number("transfer_pj_per_byte")};
  for (const YamlSection* s : {&adc, &dac, &lut, &cell, &acc, &sr, &sh, &sa, &outr, &buf, &noc, &dig, &mem})
    s->finish();
  // Named units an architecture instantiates (optional: libraries for layer-sized designs
  // need none).
  if (root["units"]) {
    YamlSection units(root, "units", origin);
    for (const std::string& name : units.keys()) {
      YamlSection u = units.section(name);
      Component c;  // priced by name (price()): one action is what the architecture says it does
      c.name = name;
      c.area.value = u.number("area_mm2");
      c.leakage.value = u.number("leakage_mw");
      c.actions_pj["action"].value = u.number("action_pj");
      u.finish();
      lib.named.components[name] = c;
    }
    units.finish();
  }
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
  if (is_named_library(text)) {
    ComponentLibrary lib;
    lib.source = origin;
    lib.named = parse_named_library(text, origin);
    lib.named_form = true;
    return lib;
  }
  return parse_component_library(text, origin);
}

}  // namespace xbarsim
