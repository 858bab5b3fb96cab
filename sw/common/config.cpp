#include "sw/common/config.h"

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <fstream>
#include <sstream>

namespace xbarsim {

struct ConfigTree::Impl {
  YAML::Node defaults;
  YAML::Node root;
};

namespace {

std::vector<std::string> split_key(const std::string& key) {
  std::vector<std::string> parts;
  std::string cur;
  for (char c : key) {
    if (c == '.') {
      parts.push_back(cur);
      cur.clear();
    } else {
      cur += c;
    }
  }
  parts.push_back(cur);
  for (const auto& p : parts)
    if (p.empty()) throw InputError("invalid configuration key '" + key + "'");
  return parts;
}

std::string known_children(const YAML::Node& map) {
  std::string s;
  for (auto it = map.begin(); it != map.end(); ++it) {
    if (!s.empty()) s += ", ";
    s += it->first.as<std::string>();
  }
  return s;
}

std::string scalar_text(const YAML::Node& n) {
  if (n.IsScalar()) return n.Scalar();
  YAML::Emitter e;
  e << YAML::Flow << n;
  return e.c_str();
}

/// Merge `src` into `dst` where `def` is the defaults node at the same place.
void merge_node(YAML::Node dst, const YAML::Node& def, const YAML::Node& src, const std::string& prefix,
                const std::string& origin) {
  if (!src.IsMap()) {
    throw InputError(origin + ": '" + (prefix.empty() ? std::string("<top>") : prefix) +
                     "' must be a mapping of keys");
  }
  for (auto it = src.begin(); it != src.end(); ++it) {
    const std::string name = it->first.as<std::string>();
    const std::string key = prefix.empty() ? name : prefix + "." + name;
    const YAML::Node d = def[name];
    if (!d) {
      throw InputError(origin + ": unknown configuration key '" + key + "'" +
                       (def.IsMap() && def.size() ? " (known keys here: " + known_children(def) + ")" : ""));
    }
    const YAML::Node v = it->second;
    if (d.IsMap()) {
      if (!v.IsMap())
        throw InputError(origin + ": '" + key + "' must be a section with keys (" + known_children(d) +
                         "), got '" + scalar_text(v) + "'");
      merge_node(dst[name], d, v, key, origin);
    } else {
      if (v.IsMap()) throw InputError(origin + ": '" + key + "' takes a value, not a section");
      if (v.IsSequence() && !d.IsSequence()) {
        for (const auto& item : v)
          if (!item.IsScalar())
            throw InputError(origin + ": '" + key + "' sweep values must be scalars");
        if (v.size() == 0) throw InputError(origin + ": '" + key + "' sweep list is empty");
      }
      dst[name] = YAML::Clone(v);
    }
  }
}

YAML::Node find(const YAML::Node& root, const std::string& key) {
  YAML::Node cur = root;
  for (const auto& p : split_key(key)) {
    if (!cur.IsMap()) return YAML::Node(YAML::NodeType::Undefined);
    YAML::Node next = cur[p];
    if (!next) return YAML::Node(YAML::NodeType::Undefined);
    cur.reset(next);
  }
  return cur;
}

void collect_sweeps(const YAML::Node& node, const YAML::Node& def, const std::string& prefix,
                    std::vector<std::string>& out) {
  for (auto it = node.begin(); it != node.end(); ++it) {
    const std::string name = it->first.as<std::string>();
    const std::string key = prefix.empty() ? name : prefix + "." + name;
    const YAML::Node d = def[name];
    if (it->second.IsMap())
      collect_sweeps(it->second, d, key, out);
    else if (it->second.IsSequence() && !(d && d.IsSequence()))
      out.push_back(key);
  }
}

}  // namespace

ConfigTree::ConfigTree() : impl_(std::make_unique<Impl>()) {
  try {
    impl_->defaults = YAML::Load(default_config_yaml());
  } catch (const YAML::Exception& e) {
    throw InputError(std::string("built-in configs/default.yaml is invalid: ") + e.what());
  }
  impl_->root = YAML::Clone(impl_->defaults);
}

ConfigTree::~ConfigTree() = default;
ConfigTree::ConfigTree(const ConfigTree& o) : impl_(std::make_unique<Impl>()) {
  impl_->defaults = YAML::Clone(o.impl_->defaults);
  impl_->root = YAML::Clone(o.impl_->root);
}
ConfigTree& ConfigTree::operator=(const ConfigTree& o) {
  if (this != &o) {
    impl_->defaults = YAML::Clone(o.impl_->defaults);
    impl_->root = YAML::Clone(o.impl_->root);
  }
  return *this;
}

ConfigTree ConfigTree::load(const std::string& path, const std::vector<std::string>& overrides) {
  ConfigTree cfg;
  if (!path.empty()) {
    std::ifstream in(path);
    if (!in) throw InputError("cannot open configuration file '" + path + "'");
    std::stringstream ss;
    ss << in.rdbuf();
    cfg.merge_yaml_text(ss.str(), path);
  }
  for (const auto& o : overrides) cfg.apply_override(o);
  return cfg;
}

void ConfigTree::merge_yaml_text(const std::string& text, const std::string& origin) {
  YAML::Node doc;
  try {
    doc = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    throw InputError(origin + ": YAML syntax error: " + e.what());
  }
  if (!doc || doc.IsNull()) return;  // empty file: defaults
  merge_node(impl_->root, impl_->defaults, doc, "", origin);
}

void ConfigTree::apply_override(const std::string& assignment) {
  const auto eq = assignment.find('=');
  if (eq == std::string::npos || eq == 0)
    throw InputError("--set expects key=value, got '" + assignment + "'");
  set(assignment.substr(0, eq), assignment.substr(eq + 1));
}

void ConfigTree::set(const std::string& key, const std::string& yaml_value) {
  const auto parts = split_key(key);
  // Build a nested document {a: {b: {c: value}}} and merge it, so the same checks apply.
  YAML::Node value;
  try {
    value = YAML::Load(yaml_value);
  } catch (const YAML::Exception& e) {
    throw InputError("--set " + key + ": cannot parse value '" + yaml_value + "'");
  }
  if (!value || value.IsNull()) value = YAML::Node(yaml_value);
  YAML::Node doc(YAML::NodeType::Map);
  YAML::Node cur = doc;
  for (size_t i = 0; i + 1 < parts.size(); ++i) {
    cur[parts[i]] = YAML::Node(YAML::NodeType::Map);
    cur.reset(cur[parts[i]]);
  }
  cur[parts.back()] = value;
  merge_node(impl_->root, impl_->defaults, doc, "", "--set " + key);
}

bool ConfigTree::has(const std::string& key) const { return static_cast<bool>(find(impl_->root, key)); }

namespace {
YAML::Node scalar_at(const YAML::Node& root, const std::string& key) {
  YAML::Node n = find(root, key);
  if (!n) throw InputError("missing configuration key '" + key + "'");
  if (n.IsSequence())
    throw InputError("configuration key '" + key + "' holds a list of values (a sweep), which this command " +
                     "does not sweep over; give a single value");
  if (!n.IsScalar()) throw InputError("configuration key '" + key + "' must be a single value");
  return n;
}
}  // namespace

double ConfigTree::get_double(const std::string& key) const {
  const YAML::Node n = scalar_at(impl_->root, key);
  const std::string s = n.Scalar();
  try {
    size_t pos = 0;
    const double v = std::stod(s, &pos);
    if (pos != s.size()) throw std::invalid_argument("trailing");
    if (!std::isfinite(v)) throw std::invalid_argument("nonfinite");
    return v;
  } catch (const std::exception&) {
    throw InputError("configuration key '" + key + "': expected a number, got '" + s + "'");
  }
}

long long ConfigTree::get_int(const std::string& key) const {
  const YAML::Node n = scalar_at(impl_->root, key);
  const std::string s = n.Scalar();
  try {
    size_t pos = 0;
    const long long v = std::stoll(s, &pos);
    if (pos != s.size()) throw std::invalid_argument("trailing");
    return v;
  } catch (const std::exception&) {
    throw InputError("configuration key '" + key + "': expected an integer, got '" + s + "'");
  }
}

bool ConfigTree::get_bool(const std::string& key) const {
  const std::string s = scalar_at(impl_->root, key).Scalar();
  if (s == "true" || s == "yes" || s == "on" || s == "1") return true;
  if (s == "false" || s == "no" || s == "off" || s == "0") return false;
  throw InputError("configuration key '" + key + "': expected true or false, got '" + s + "'");
}

std::string ConfigTree::get_string(const std::string& key) const {
  return scalar_at(impl_->root, key).Scalar();
}

bool ConfigTree::is_list(const std::string& key) const {
  const YAML::Node n = find(impl_->root, key);
  return n && n.IsSequence();
}

std::vector<std::string> ConfigTree::list_items(const std::string& key) const {
  const YAML::Node n = find(impl_->root, key);
  std::vector<std::string> out;
  if (!n) throw InputError("missing configuration key '" + key + "'");
  if (!n.IsSequence()) {
    out.push_back(scalar_text(n));
    return out;
  }
  for (const auto& item : n) out.push_back(scalar_text(item));
  return out;
}

std::vector<std::string> ConfigTree::sweep_keys() const {
  std::vector<std::string> out;
  collect_sweeps(impl_->root, impl_->defaults, "", out);
  return out;
}

std::string ConfigTree::dump() const {
  YAML::Emitter e;
  e << impl_->root;
  return e.c_str();
}

double require_positive(const ConfigTree& cfg, const std::string& key) {
  const double v = cfg.get_double(key);
  if (!(v > 0)) {
    std::ostringstream os;
    os << "configuration key '" << key << "' must be > 0, got " << v;
    throw InputError(os.str());
  }
  return v;
}

double require_nonnegative(const ConfigTree& cfg, const std::string& key) {
  const double v = cfg.get_double(key);
  if (!(v >= 0)) {
    std::ostringstream os;
    os << "configuration key '" << key << "' must be >= 0, got " << v;
    throw InputError(os.str());
  }
  return v;
}

std::string require_one_of(const ConfigTree& cfg, const std::string& key, const std::vector<std::string>& allowed) {
  const std::string v = cfg.get_string(key);
  for (const auto& a : allowed)
    if (v == a) return v;
  std::string list;
  for (const auto& a : allowed) list += (list.empty() ? "" : ", ") + a;
  throw InputError("configuration key '" + key + "': '" + v + "' is not one of: " + list);
}

int require_size_or_unbounded(const ConfigTree& cfg, const std::string& key) {
  const std::string s = cfg.get_string(key);
  if (s == "unbounded") return 0;
  const long long v = cfg.get_int(key);
  if (v < 1 || v > (1 << 30))
    throw InputError("configuration key '" + key + "' must be >= 1 or 'unbounded', got '" + s + "'");
  return static_cast<int>(v);
}

}  // namespace xbarsim
