#include "sw/hw/components.h"

#include <yaml-cpp/yaml.h>

#include <cmath>

#include "sw/common/yaml_section.h"

namespace xbarsim {

double Figure::at(const Params& params, const std::string& where) const {
  auto param = [&](const std::string& p) {
    const auto it = params.find(p);
    if (it == params.end()) throw InputError(where + " depends on parameter '" + p + "', which is not given");
    return it->second;
  };
  double v = value;
  for (const std::string& p : per) v *= param(p);
  if (!exponential.empty()) v *= std::exp2(param(exponential) - reference);
  return v;
}

double Component::capacitance_ff(const Params& params, const std::string& library) const {
  const auto it = params.find("cells");
  if (it == params.end())
    throw InputError(library + ": capacitor '" + name + "' needs the parameter 'cells' (the cells on its line)");
  return c_per_cell_ff * it->second + c_fixed_ff;
}

double Component::action_pj(const std::string& action, const Params& params, const std::string& library) const {
  switch (kind) {
    case ComponentKind::Capacitor: {
      if (action != "switch")
        throw InputError(library + ": capacitor '" + name + "' has one action, 'switch', not '" + action + "'");
      const double dv = v_high_v - v_low_v;
      return capacitance_ff(params, library) * 1e-3 * dv * dv;  // fF x V^2 = fJ; pJ
    }
    case ComponentKind::Table: {
      const auto it = actions_pj.find(action);
      if (it == actions_pj.end()) {
        std::string list;
        for (const auto& [a, f] : actions_pj) list += (list.empty() ? "" : ", ") + a;
        throw InputError(library + ": component '" + name + "' has no action '" + action + "' (" + list + ")");
      }
      return it->second.at(params, library + ": '" + name + ".actions." + action + "'");
    }
  }
  return 0;
}

const Component& NamedLibrary::at(const std::string& name) const {
  const auto it = components.find(name);
  if (it != components.end()) return it->second;
  std::string list;
  for (const auto& [n, c] : components) list += (list.empty() ? "" : ", ") + n;
  throw InputError(source + ": no component or unit '" + name + "' (" + (list.empty() ? "none" : list) + ")");
}

namespace {

double total(const std::map<std::string, double>& m) {
  double t = 0;
  for (const auto& [k, v] : m) t += v;
  return t;
}

Params merged(const Params& defaults, const Params& given) {
  Params p = defaults;
  for (const auto& [k, v] : given) p[k] = v;
  return p;
}

Figure figure(YamlSection& s, const std::string& key) {
  Figure f;
  if (s.raw(key).IsScalar()) {
    f.value = s.number(key);
    return f;
  }
  YamlSection m = s.section(key);
  f.value = m.number("value");
  if (m.has("per")) f.per = m.words("per");
  if (m.has("exponential")) {
    f.exponential = m.word("exponential");
    f.reference = m.real("reference");
  }
  m.finish();
  return f;
}

}  // namespace

double Bill::total_area_mm2() const { return total(area_mm2); }
double Bill::total_leakage_mw() const { return total(leakage_mw); }
double Bill::total_energy_pj() const { return total(energy_pj); }

nlohmann::json Bill::to_json() const {
  return {{"area_mm2", area_mm2},           {"leakage_mw", leakage_mw},           {"energy_pj", energy_pj},
          {"total_area_mm2", total_area_mm2()}, {"total_leakage_mw", total_leakage_mw()},
          {"total_energy_pj", total_energy_pj()}};
}

Bill price(const NamedLibrary& lib, const std::vector<Instance>& instances, const Ledger& ledger, double time_ns) {
  Bill b;
  std::map<std::string, const Instance*> by_name;
  for (const Instance& i : instances) {
    if (!by_name.emplace(i.name, &i).second) throw std::logic_error("price: instance '" + i.name + "' twice");
    const Component& c = lib.at(i.component);
    const Params p = merged(c.params, i.params);
    const std::string where = lib.source + ": '" + c.name;
    b.area_mm2[i.part] += i.count * c.area.at(p, where + ".area'") * c.area_unit_mm2;
    const double leak = i.count * c.leakage.at(p, where + ".leakage'") * c.leakage_unit_mw;
    b.leakage_mw[i.part] += leak;
    b.energy_pj[i.part] += leak * time_ns;  // mW x ns = pJ
  }
  for (const Ledger::Count& n : ledger.counts) {
    const auto it = by_name.find(n.instance);
    if (it == by_name.end()) throw std::logic_error("price: actions of unknown instance '" + n.instance + "'");
    const Instance& i = *it->second;
    const Component& c = lib.at(i.component);
    b.energy_pj[i.part] += n.n * c.action_pj(n.action, merged(c.params, i.params), lib.source);
  }
  for (const auto& [part, pj] : ledger.energy_pj) b.energy_pj[part] += pj;
  return b;
}

bool is_named_library(const std::string& yaml_text) {
  try {
    const YAML::Node root = YAML::Load(yaml_text);
    return root.IsMap() && root["components"];
  } catch (const YAML::Exception&) {
    return false;
  }
}

NamedLibrary parse_named_library(const std::string& text, const std::string& origin) {
  const YAML::Node root = load_yaml_map(text, origin, "a component library");
  check_yaml_sections(root, {"technology_nm", "voltage_v", "components"}, origin);
  YamlSection top(root, "", origin, true);
  NamedLibrary lib;
  lib.source = origin;
  if (top.has("technology_nm")) lib.technology_nm = top.number("technology_nm", true);  // documentation
  if (top.has("voltage_v")) lib.voltage_v = top.number("voltage_v", true);
  YamlSection comps = top.section("components");
  for (const std::string& name : comps.keys()) {
    YamlSection s = comps.section(name);
    Component c;
    c.name = name;
    const std::string kind = s.word_or("kind", "table");
    if (kind == "capacitor") {
      c.kind = ComponentKind::Capacitor;
      c.c_per_cell_ff = s.number("c_per_cell_ff");
      c.c_fixed_ff = s.number("c_fixed_ff");
      c.v_low_v = s.number("v_low_v");
      c.v_high_v = s.number("v_high_v");
      if (!(c.v_high_v > c.v_low_v))
        throw InputError(origin + ": '" + name + "': v_high_v must be above v_low_v");
    } else if (kind != "table") {
      throw InputError(s.where("kind") + " must be table or capacitor, got '" + kind + "'");
    }
    if (s.has("params")) {
      YamlSection p = s.section("params");
      for (const std::string& k : p.keys()) c.params[k] = p.number(k);
      p.finish();
    }
    // Each figure in the unit its key names (ISAAC's tables are in mm^2 and mW, circuits' in
    // um^2 and nW): the value is kept as written.
    auto unit_figure = [&](const char* small, const char* large, Figure& f, double& unit) {
      if (s.has(small) && s.has(large))
        throw InputError(s.where(large) + ": give " + small + " or " + large + ", not both");
      if (s.has(small)) f = figure(s, small);
      if (s.has(large)) {
        f = figure(s, large);
        unit = 1;
      }
    };
    unit_figure("area_um2", "area_mm2", c.area, c.area_unit_mm2);
    unit_figure("leakage_nw", "leakage_mw", c.leakage, c.leakage_unit_mw);
    if (s.has("actions")) {
      if (c.kind == ComponentKind::Capacitor)
        throw InputError(s.where("actions") + ": a capacitor's energy is its physics (C dV^2 per switch), not a table");
      YamlSection a = s.section("actions");
      for (const std::string& k : a.keys()) c.actions_pj[k] = figure(a, k);
      a.finish();
    }
    s.finish();
    lib.components[name] = c;
  }
  comps.finish();
  top.finish();
  return lib;
}

}  // namespace xbarsim
