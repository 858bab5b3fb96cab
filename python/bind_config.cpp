// xbarsim._core: the configuration (Config) and the conversion of Python values to the YAML
// text --set takes.
#include <cstdlib>
#include <sstream>

#include "python/bind.h"
#include "sw/common/errors.h"

namespace xbarsim::bindings {

namespace {

/// A Python value as the YAML text --set takes: lists as [a, b], booleans as true/false. Any
/// int (NumPy's too) is written whole and floats with 17 digits, so the configuration's range
/// checks see the value itself (2**63 is out of range there, not an overflow here).
std::string yaml_text(const py::handle& v) {
  if (py::isinstance<py::bool_>(v)) return v.cast<bool>() ? "true" : "false";
  if (py::isinstance<py::int_>(v)) return py::str(v).cast<std::string>();
  if (py::isinstance<py::float_>(v)) {
    std::ostringstream s;
    s.precision(17);
    s << v.cast<double>();
    return s.str();
  }
  if (py::isinstance<py::str>(v)) return v.cast<std::string>();
  if (py::isinstance<py::list>(v) || py::isinstance<py::tuple>(v)) {
    std::string out = "[";
    for (const py::handle& x : v) out += (out.size() > 1 ? ", " : "") + yaml_text(x);
    return out + "]";
  }
  if (v.is_none()) return "none";
  // NumPy scalars and arrays: as the Python numbers and lists tolist() gives.
  if (py::hasattr(v, "dtype") && py::hasattr(v, "tolist")) return yaml_text(v.attr("tolist")());
  throw InputError("a configuration value must be a number, string, bool, None or a list of those (got " +
                   py::str(v.get_type().attr("__name__")).cast<std::string>() + ")");
}

/// A configuration key given from Python: a str.
std::string key_text(const py::handle& k) {
  if (!py::isinstance<py::str>(k))
    throw InputError("configuration keys are dotted names (strings), got " + py::repr(k).cast<std::string>());
  return k.cast<std::string>();
}

}  // namespace

/// yaml_text for the value of `key`; a value it cannot write is an InputError naming the key.
std::string value_text(const std::string& key, const py::handle& v) {
  try {
    return yaml_text(v);
  } catch (const InputError& e) {
    throw InputError("configuration key '" + key + "': " + e.what());
  }
}

/// The override `key=value` as --set takes it.
std::string assignment(const py::handle& k, const py::handle& v) {
  const std::string key = key_text(k);
  return key + "=" + value_text(key, v);
}

namespace {

/// The value at `key`, typed: a list, an int, a float, a bool or a string.
py::object typed_value(const ConfigTree& cfg, const std::string& key) {
  if (cfg.is_list(key)) {
    py::list out;
    for (const std::string& item : cfg.list_items(key)) out.append(item);
    return std::move(out);
  }
  const std::string text = cfg.get_string(key);
  if (text == "true" || text == "false") return py::bool_(text == "true");
  if (ConfigTree::is_integer(key)) {
    try {
      return py::int_(cfg.get_int(key));
    } catch (const InputError&) {  // a word such as `none` or `unbounded`
      return py::str(text);
    }
  }
  if (ConfigTree::is_numeric(key)) {
    try {
      return py::float_(cfg.get_double(key));
    } catch (const InputError&) {
      return py::str(text);
    }
  }
  return py::str(text);
}

/// Checks a numeric key's value `text` against its documented range, as the commands do when
/// they read it (words such as `none` are checked by the command that reads the key).
void check_range(const ConfigTree& cfg, const std::string& key, const std::string& text) {
  char* end = nullptr;
  std::strtod(text.c_str(), &end);
  if (text.empty() || end != text.c_str() + text.size()) return;
  if (ConfigTree::is_integer(key))
    cfg.get_int(key);
  else
    cfg.get_double(key);
}

}  // namespace

/// check_range for every numeric value, each value of a sweep list too.
void check_ranges(const ConfigTree& cfg) {
  for (const std::string& key : cfg.leaf_keys()) {
    if (!ConfigTree::is_numeric(key)) continue;
    if (!cfg.is_list(key)) {
      check_range(cfg, key, cfg.get_string(key));
      continue;
    }
    ConfigTree point = cfg;
    for (const std::string& item : cfg.list_items(key)) {
      point.set_scalar(key, item);
      check_range(point, key, item);
    }
  }
}

/// The configuration at `path` (a str or os.PathLike; None or "" for the defaults) with `overrides`.
ConfigTree load_config(const py::handle& path, const py::handle& overrides) {
  std::string file;
  if (!path.is_none()) {
    if (!py::isinstance<py::str>(path) && !py::hasattr(path, "__fspath__"))
      throw InputError("Config: path must be the path of a YAML file (a str or os.PathLike), got " +
                       py::repr(path).cast<std::string>());
    const py::object fs = py::module_::import("os").attr("fspath")(path);
    if (!py::isinstance<py::str>(fs))
      throw InputError("Config: path must be the path of a YAML file (a str), got " + py::repr(fs).cast<std::string>());
    file = fs.cast<std::string>();
  }
  std::vector<std::string> sets;
  if (!overrides.is_none()) {
    if (!py::hasattr(overrides, "items"))
      throw InputError("Config: overrides must be a dict of {'dotted.key': value}, got " +
                       py::repr(overrides).cast<std::string>());
    for (const auto& [k, v] : py::dict(py::reinterpret_borrow<py::object>(overrides))) sets.push_back(assignment(k, v));
  }
  ConfigTree cfg = ConfigTree::load(file, sets);
  check_ranges(cfg);
  return cfg;
}

/// The configuration a call was given: a Config, a dict of {'dotted.key': value} overrides of
/// the defaults, or None (the defaults).
ConfigTree config_of(const py::handle& config) {
  if (config.is_none()) return ConfigTree();
  if (py::isinstance<ConfigTree>(config)) return config.cast<ConfigTree>();
  if (py::isinstance<py::dict>(config)) return load_config(py::none(), config);
  throw InputError("config must be an xbarsim.Config, a dict of {'dotted.key': value} or None, got " +
                   py::repr(config).cast<std::string>());
}

void bind_config(py::module_& m) {
  m.def("_assignment", &assignment, py::arg("key"), py::arg("value"),
        "The override key=value as --set takes it (the package's one conversion; ValueError naming the key)");

  py::class_<ConfigTree>(m, "Config",
                         "Configuration: the documented defaults (configs/default.yaml), then a YAML file, then "
                         "overrides; validated as the CLI validates it.")
      .def(py::init(&load_config),
           py::arg("path") = py::none(), py::arg("overrides") = py::none(),
           "Config(path=None, overrides=None): defaults, the YAML file at `path` (str or os.PathLike), then "
           "{'dotted.key': value}; a bad value raises ValueError naming its key")
      .def(
          "set",
          [](ConfigTree& c, const py::handle& k, const py::handle& v) {
            const std::string key = key_text(k);
            ConfigTree next = c;
            next.set(key, value_text(key, v));
            check_ranges(next);
            c = next;
          },
          py::arg("key"), py::arg("value"), "Set a dotted key (a list value is a sweep)")
      .def("get", &typed_value, py::arg("key"), "The value at a dotted key, typed")
      .def(
          "to_dict",
          [](const ConfigTree& c) {
            py::dict root;
            for (const std::string& key : c.leaf_keys()) {
              py::dict node = root;
              size_t at = 0, dot;
              while ((dot = key.find('.', at)) != std::string::npos) {
                const py::str part(key.substr(at, dot - at));
                if (!node.contains(part)) node[part] = py::dict();
                node = node[part].cast<py::dict>();
                at = dot + 1;
              }
              node[py::str(key.substr(at))] = typed_value(c, key);
            }
            return root;
          },
          "Every key as nested dicts")
      .def("dump", &ConfigTree::dump, "The effective configuration as YAML text")
      .def("sweep_points", &ConfigTree::sweep_points, "Points of the sweep its list values span")
      .def("__repr__", [](const ConfigTree& c) {
        return "<xbarsim.Config: " + std::to_string(c.sweep_points()) + " point(s)>";
      });
}

}  // namespace xbarsim::bindings
