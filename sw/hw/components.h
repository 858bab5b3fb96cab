#pragma once
/// Components as data, priced by name (Accelergy's model): a component is a name, its
/// parameters, an area, a leakage and an energy per named action, each a figure that may
/// depend on the parameters (bits, steps, width, the cells on a line). Parts of a machine
/// instantiate components (`Instance`: which component, how many, with which parameters, in
/// which reported part) and count named actions into a `Ledger`; one function, `price`, turns
/// instances and counts into area, leakage and energy by part. A new component is an entry of
/// a library file plus the part that counts its actions (docs/extending.md).
///
/// Figures (YAML): a number, or {value: v, per: [p, ...]} = v x the product of parameters p,
/// or {value: v, per: ..., exponential: p, reference: r} = the same x 2^(p - r). A component
/// of `kind: capacitor` is physics, not a table: its `switch` action (one charge and discharge
/// of the line between v_low_v and v_high_v) dissipates C dV^2 with
/// C = c_per_cell_ff x cells + c_fixed_ff.
#include <map>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "sw/common/config.h"

namespace xbarsim {

/// Parameters of a component instance by name (bits, steps, width, cells).
using Params = std::map<std::string, double>;

struct Figure {
  double value = 0;
  std::vector<std::string> per;  ///< multiplied by each of these parameters
  std::string exponential;       ///< and by 2^(param - reference) when set
  double reference = 0;
  /// The figure at `params` (the component's defaults overridden by the instance's); throws
  /// InputError naming `where` when a parameter it depends on is given by neither.
  double at(const Params& params, const std::string& where) const;
};

enum class ComponentKind {
  Table,     ///< figures per action from the library (published circuits)
  Capacitor  ///< a line switched between two voltages: energy C dV^2 per switch (physics)
};

struct Component {
  std::string name;
  ComponentKind kind = ComponentKind::Table;
  Params params;  ///< defaults (an instance may override them)
  /// Area and leakage of one instance, in the units its keys name (area_um2 or area_mm2,
  /// leakage_nw or leakage_mw): mm^2 and mW per unit of the figures.
  Figure area, leakage;
  double area_unit_mm2 = 1e-6, leakage_unit_mw = 1e-6;
  std::map<std::string, Figure> actions_pj;  ///< energy of one action, by action name
  /// Capacitor: fF per cell on the line, fF of the line's driver, the swing.
  double c_per_cell_ff = 0, c_fixed_ff = 0, v_low_v = 0, v_high_v = 0;
  /// The energy (pJ) of one `action` with `params`; InputError naming the library otherwise.
  double action_pj(const std::string& action, const Params& params, const std::string& library) const;
  /// Capacitor: the line's capacitance (fF) with `params` (cells).
  double capacitance_ff(const Params& params, const std::string& library) const;
};

/// A component library: a top-level `components:` map of name -> area, leakage and energy per
/// action (every library, ISAAC's and NeuRRAM's alike).
struct NamedLibrary {
  std::string source;
  double technology_nm = 0, voltage_v = 0;  ///< what the figures are for (documentation)
  std::map<std::string, Component> components;
  bool has(const std::string& name) const { return components.count(name) > 0; }
  /// The component named `name`; InputError naming the library and what it has otherwise.
  const Component& at(const std::string& name) const;
};

/// `count` instances of `component` with `params`, reported under `part` (e.g. "neuron").
struct Instance {
  std::string name;  ///< how actions address it (unique in a machine)
  std::string component;
  std::string part;
  double count = 1;
  Params params;
};

/// Named actions counted by the parts of a machine, and energies the parts computed from
/// physics themselves (the input pulses' V x I x t from the solved circuit).
struct Ledger {
  struct Count {
    std::string instance, action;
    double n = 0;  ///< actions of all the instance's copies together
  };
  std::vector<Count> counts;
  std::map<std::string, double> energy_pj;  ///< by part
  void add(const std::string& instance, const std::string& action, double n) { counts.push_back({instance, action, n}); }
};

/// Area (mm^2), leakage (mW) and energy (pJ) by part, and the totals.
struct Bill {
  std::map<std::string, double> area_mm2, leakage_mw, energy_pj;
  double total_area_mm2() const;
  double total_leakage_mw() const;
  double total_energy_pj() const;
  nlohmann::json to_json() const;
};

/// The one pricing function: instances' area and leakage, the ledger's counts x energy per
/// action plus its physics energies, and the leakage over `time_ns`, by part.
Bill price(const NamedLibrary& lib, const std::vector<Instance>& instances, const Ledger& ledger, double time_ns);

/// Whether `yaml_text` is a library in the named form (a top-level `components:` section).
bool is_named_library(const std::string& yaml_text);

/// Parses a named library; errors name `origin`, the component and the key.
NamedLibrary parse_named_library(const std::string& yaml_text, const std::string& origin);

}  // namespace xbarsim
