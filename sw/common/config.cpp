#include "sw/common/config.h"

#include <yaml-cpp/eventhandler.h>
#include <yaml-cpp/yaml.h>

#include <climits>
#include <cmath>
#include <fstream>
#include <functional>
#include <map>
#include <set>
#include <sstream>

#include "sw/common/input_file.h"
#include "sw/common/parse.h"

namespace xbarsim {

struct ConfigTree::Impl {
  YAML::Node defaults;
  YAML::Node root;
  /// Keys read through the typed getters, shared by copies (sweep points) of one tree.
  std::shared_ptr<std::set<std::string>> read = std::make_shared<std::set<std::string>>();
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

/// Walks the YAML events of one text before it is loaded: rejects a second document,
/// duplicate keys and keys that are not plain scalars (complex keys), naming the line.
/// yaml-cpp itself keeps the last of duplicate keys and ignores later documents.
class StructureCheck : public YAML::EventHandler {
 public:
  explicit StructureCheck(std::string origin) : origin_(std::move(origin)) {}
  void OnDocumentStart(const YAML::Mark& m) override {
    if (++documents_ > 1) fail(m, "a second YAML document ('---') is not allowed; put every setting in one document");
  }
  void OnDocumentEnd() override {}
  void OnNull(const YAML::Mark& m, YAML::anchor_t) override { item(m, false, ""); }
  void OnAlias(const YAML::Mark& m, YAML::anchor_t) override { item(m, false, "an alias (*name)"); }
  void OnScalar(const YAML::Mark& m, const std::string&, YAML::anchor_t, const std::string& v) override {
    item(m, true, v);
  }
  void OnSequenceStart(const YAML::Mark& m, const std::string&, YAML::anchor_t, YAML::EmitterStyle::value) override {
    item(m, false, "a list or mapping");
    stack_.push_back({false, true, {}});
  }
  void OnSequenceEnd() override { stack_.pop_back(); }
  void OnMapStart(const YAML::Mark& m, const std::string&, YAML::anchor_t, YAML::EmitterStyle::value) override {
    item(m, false, "a list or mapping");
    stack_.push_back({true, true, {}});
  }
  void OnMapEnd() override { stack_.pop_back(); }

 private:
  struct Frame {
    bool is_map, expect_key;
    std::set<std::string> keys;
  };
  [[noreturn]] void fail(const YAML::Mark& m, const std::string& what) const {
    throw InputError(origin_ + ":" + std::to_string(m.line + 1) + ": " + what);
  }
  void item(const YAML::Mark& m, bool scalar, const std::string& text) {
    if (stack_.empty() || !stack_.back().is_map) return;
    Frame& f = stack_.back();
    if (f.expect_key) {
      if (!scalar) fail(m, text.empty() ? "a key is empty" : "a key must be a plain name, not " + text);
      if (!f.keys.insert(text).second) fail(m, "duplicate key '" + text + "' (each key may appear once)");
    }
    f.expect_key = !f.expect_key;
  }
  std::string origin_;
  int documents_ = 0;
  std::vector<Frame> stack_;
};

YAML::Node load_checked(const std::string& text, const std::string& origin) {
  try {
    std::istringstream in(text);
    YAML::Parser parser(in);
    StructureCheck check(origin);
    while (parser.HandleNextDocument(check)) {
    }
    return YAML::Load(text);
  } catch (const YAML::Exception& e) {
    throw InputError(origin + ": YAML syntax error: " + e.what());
  }
}

/// An interval documented in configs/default.yaml as the first thing of a key's comment,
/// e.g. `vectors: 1000  # [1, 10000000] test input vectors`; ( ) are open ends.
struct NumericRange {
  double lo = 0, hi = 0;
  bool lo_open = false, hi_open = false;
  bool integer = false;  ///< an integer key: its default is an integer, or a word with whole bounds
  std::string text;
  bool contains(double v) const { return (lo_open ? v > lo : v >= lo) && (hi_open ? v < hi : v <= hi); }
};

bool parse_range(const std::string& comment, NumericRange& r) {
  const auto b = comment.find_first_not_of(" \t");
  if (b == std::string::npos || (comment[b] != '[' && comment[b] != '(')) return false;
  const auto e = comment.find_first_of("])", b);
  const auto comma = comment.find(',', b);
  if (e == std::string::npos || comma == std::string::npos || comma > e) return false;
  r.lo_open = comment[b] == '(';
  r.hi_open = comment[e] == ')';
  r.text = comment.substr(b, e - b + 1);
  return parse_finite_double(comment.substr(b + 1, comma - b - 1), r.lo) &&
         parse_finite_double(comment.substr(comma + 1, e - comma - 1), r.hi) && r.lo <= r.hi;
}

/// Dotted key -> documented range, read from the text of configs/default.yaml (indentation
/// gives the nesting; the file is ours and uses two spaces per level).
std::map<std::string, NumericRange> parse_documented_ranges(const std::string& text) {
  std::map<std::string, NumericRange> out;
  std::vector<std::pair<size_t, std::string>> path;  // (indent, name)
  std::istringstream in(text);
  std::string line;
  while (std::getline(in, line)) {
    const auto indent = line.find_first_not_of(' ');
    if (indent == std::string::npos || line[indent] == '#') continue;
    const auto colon = line.find(':', indent);
    if (colon == std::string::npos) continue;
    const std::string name = line.substr(indent, colon - indent);
    while (!path.empty() && path.back().first >= indent) path.pop_back();
    std::string key;
    for (const auto& p : path) key += p.second + ".";
    key += name;
    const auto hash = line.find('#', colon);
    const std::string value = line.substr(colon + 1, hash == std::string::npos ? std::string::npos : hash - colon - 1);
    if (value.find_first_not_of(" \t") == std::string::npos) path.emplace_back(indent, name);
    NumericRange r;
    if (hash != std::string::npos && parse_range(line.substr(hash + 1), r)) {
      // The default's text tells an integer key (max_rows: 144, eval.images: all) from a real one
      // (r_on: 1000.0); a real key whose default is written as an integer (clock_mhz: 100)
      // counts as one, which only makes its whole values canonical as integers.
      const auto b = value.find_first_not_of(" \t"), e = value.find_last_not_of(" \t");
      const std::string text = b == std::string::npos ? "" : value.substr(b, e - b + 1);
      long long n = 0;
      double d = 0;
      // A word default (none, all, auto) with whole bounds is an integer key, unless its bounds
      // are those of a fraction ([0, 1), [0, 1]: mapping.g_headroom, explore.min_accuracy).
      r.integer = parse_int64(text, n) || (!parse_finite_double(text, d) && r.lo == std::floor(r.lo) &&
                                           r.hi == std::floor(r.hi) && r.hi - r.lo > 1);
      out[key] = r;
    }
  }
  return out;
}

const std::map<std::string, NumericRange>& documented_ranges() {
  static const std::map<std::string, NumericRange> ranges = parse_documented_ranges(default_config_yaml());
  return ranges;
}

const NumericRange& documented_range(const std::string& key) {
  const auto& ranges = documented_ranges();
  const auto it = ranges.find(key);
  // Every numeric key documents its range; a key read as a number without one is a bug here.
  if (it == ranges.end()) throw std::logic_error("configs/default.yaml documents no range for '" + key + "'");
  return it->second;
}

std::string out_of_range_message(const std::string& key, const NumericRange& r, const std::string& value) {
  return "configuration key '" + key + "' must be in " + r.text + ", got '" + excerpt(value) + "'";
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
    throw InputError(origin + ": '" + (prefix.empty() ? std::string("<top>") : prefix) + "' must be a mapping of keys");
  }
  for (auto it = src.begin(); it != src.end(); ++it) {
    const std::string name = it->first.as<std::string>();
    const std::string key = prefix.empty() ? name : prefix + "." + name;
    const YAML::Node d = def[name];
    if (!d && (key == "noise" || key.rfind("noise.", 0) == 0))
      throw InputError(origin + ": configuration key '" + key +
                       "' is gone: the device is a model of its own (section device.): a constant programming "
                       "error is device.model: constant with device.program_sigma_us (was noise.sigma_us), seeded by "
                       "device.seed (was noise.seed)");
    if (!d) {
      throw InputError(origin + ": unknown configuration key '" + key + "'" +
                       (def.IsMap() && def.size() ? " (known keys here: " + known_children(def) + ")" : ""));
    }
    const YAML::Node v = it->second;
    if (d.IsMap()) {
      if (!v.IsMap())
        throw InputError(origin + ": '" + key + "' must be a section with keys (" + known_children(d) + "), got '" +
                         scalar_text(v) + "'");
      merge_node(dst[name], d, v, key, origin);
    } else {
      if (v.IsMap()) throw InputError(origin + ": '" + key + "' takes a value, not a section");
      if (v.IsSequence() && !d.IsSequence()) {
        for (const auto& item : v)
          if (!item.IsScalar()) throw InputError(origin + ": '" + key + "' sweep values must be scalars");
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

namespace {
/// The built-in defaults, parsed and checked once; every tree shares them read-only.
const YAML::Node& builtin_defaults() {
  static const YAML::Node defaults = load_checked(default_config_yaml(), "built-in configs/default.yaml");
  return defaults;
}
}  // namespace

ConfigTree::ConfigTree() : impl_(std::make_unique<Impl>()) {
  impl_->defaults = builtin_defaults();
  impl_->root = YAML::Clone(impl_->defaults);
}

ConfigTree::~ConfigTree() = default;
ConfigTree::ConfigTree(const ConfigTree& o) : impl_(std::make_unique<Impl>()) {
  impl_->defaults = o.impl_->defaults;  // the shared, read-only built-in defaults
  impl_->root = YAML::Clone(o.impl_->root);
  impl_->read = o.impl_->read;
}
ConfigTree& ConfigTree::operator=(const ConfigTree& o) {
  if (this != &o) {
    impl_->defaults = o.impl_->defaults;
    impl_->root = YAML::Clone(o.impl_->root);
    impl_->read = o.impl_->read;
  }
  return *this;
}

ConfigTree ConfigTree::load(const std::string& path, const std::vector<std::string>& overrides) {
  ConfigTree cfg;
  if (!path.empty()) {
    cfg.merge_yaml_text(read_input_file(path, "the configuration file", kMaxYamlBytes), path);
  }
  for (const auto& o : overrides) cfg.apply_override(o);
  return cfg;
}

void ConfigTree::merge_yaml_text(const std::string& text, const std::string& origin) {
  const YAML::Node doc = load_checked(text, origin);
  if (!doc || doc.IsNull()) return;  // empty file: defaults
  merge_node(impl_->root, impl_->defaults, doc, "", origin);
}

void ConfigTree::apply_override(const std::string& assignment) {
  const auto eq = assignment.find('=');
  if (eq == std::string::npos || eq == 0) throw InputError("--set expects key=value, got '" + assignment + "'");
  set(assignment.substr(0, eq), assignment.substr(eq + 1));
}

void ConfigTree::set(const std::string& key, const std::string& yaml_value) {
  YAML::Node value;
  try {
    value = load_checked(yaml_value, "--set " + key);
  } catch (const InputError&) {
    throw InputError("--set " + key + ": cannot parse value '" + excerpt(yaml_value) + "'");
  }
  if (!value || value.IsNull()) value = YAML::Node(yaml_value);
  set_node(key, value, "--set " + key);
}

void ConfigTree::set_scalar(const std::string& key, const std::string& value) {
  set_node(key, YAML::Node(value), "configuration key '" + key + "'");
}

void ConfigTree::set_node(const std::string& key, const YAML::Node& value, const std::string& origin) {
  const auto parts = split_key(key);
  // Build a nested document {a: {b: {c: value}}} and merge it, so the same checks apply.
  YAML::Node doc(YAML::NodeType::Map);
  YAML::Node cur = doc;
  for (size_t i = 0; i + 1 < parts.size(); ++i) {
    cur[parts[i]] = YAML::Node(YAML::NodeType::Map);
    cur.reset(cur[parts[i]]);
  }
  cur[parts.back()] = value;
  merge_node(impl_->root, impl_->defaults, doc, "", origin);
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
  impl_->read->insert(key);
  const std::string s = scalar_at(impl_->root, key).Scalar();
  double v = 0;
  if (!parse_finite_double(s, v))
    throw InputError("configuration key '" + key + "': expected a finite number, got '" + excerpt(s) + "'");
  const NumericRange& r = documented_range(key);
  if (!r.contains(v)) throw InputError(out_of_range_message(key, r, s));
  return v;
}

long long ConfigTree::get_int(const std::string& key) const {
  impl_->read->insert(key);
  const std::string s = scalar_at(impl_->root, key).Scalar();
  long long v = 0;
  const NumericRange& r = documented_range(key);
  if (!parse_int64(s, v)) {
    // A whole number written as a decimal (8.0, 8e0, 1e6) is that integer, as the journals'
    // keys count it (canonical_value), while every integer is exact in a double (below 2^53).
    double d = 0;
    if (!parse_finite_double(s, d) || d != std::floor(d))
      throw InputError("configuration key '" + key + "': expected an integer, got '" + excerpt(s) + "'");
    if (!r.contains(d)) throw InputError(out_of_range_message(key, r, s));
    if (std::fabs(d) >= kExactIntegerLimit)
      throw InputError("configuration key '" + key + "': '" + excerpt(s) +
                       "' is beyond 2^53, where a decimal number is not exact: write the integer's digits");
    v = static_cast<long long>(d);
  }
  if (!r.contains(static_cast<double>(v))) throw InputError(out_of_range_message(key, r, s));
  return v;
}

int ConfigTree::get_int32(const std::string& key) const {
  const long long v = get_int(key);
  if (v < INT_MIN || v > INT_MAX)  // the documented range of such a key lies within int
    throw std::logic_error("configs/default.yaml: the range of '" + key + "' exceeds a 32-bit integer");
  return static_cast<int>(v);
}

bool ConfigTree::get_bool(const std::string& key) const {
  impl_->read->insert(key);
  const std::string s = scalar_at(impl_->root, key).Scalar();
  if (s == "true" || s == "yes" || s == "on" || s == "1") return true;
  if (s == "false" || s == "no" || s == "off" || s == "0") return false;
  throw InputError("configuration key '" + key + "': expected true or false, got '" + excerpt(s) + "'");
}

std::string ConfigTree::get_string(const std::string& key) const {
  impl_->read->insert(key);
  return scalar_at(impl_->root, key).Scalar();
}

bool ConfigTree::is_numeric(const std::string& key) { return documented_ranges().count(key) > 0; }

bool ConfigTree::is_integer(const std::string& key) {
  const auto it = documented_ranges().find(key);
  return it != documented_ranges().end() && it->second.integer;
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

std::set<std::string> ConfigTree::read_keys() const { return *impl_->read; }

std::vector<std::string> ConfigTree::leaf_keys() const {
  std::vector<std::string> out;
  std::function<void(const YAML::Node&, const std::string&)> walk = [&](const YAML::Node& n,
                                                                        const std::string& prefix) {
    for (auto it = n.begin(); it != n.end(); ++it) {
      const std::string key = (prefix.empty() ? "" : prefix + ".") + it->first.as<std::string>();
      if (it->second.IsMap())
        walk(it->second, key);
      else
        out.push_back(key);
    }
  };
  walk(impl_->defaults, "");
  return out;
}

unsigned long long ConfigTree::sweep_points() const {
  unsigned long long n = 1;
  for (const auto& key : sweep_keys()) {
    const unsigned long long k = find(impl_->root, key).size();
    n = (k != 0 && n > ULLONG_MAX / k) ? ULLONG_MAX : n * k;
  }
  return n;
}

std::string ConfigTree::dump() const {
  YAML::Emitter e;
  e << impl_->root;
  return e.c_str();
}

void check_yaml_structure(const std::string& text, const std::string& origin) { load_checked(text, origin); }

std::string require_one_of(const ConfigTree& cfg, const std::string& key, const std::vector<std::string>& allowed) {
  const std::string v = cfg.get_string(key);
  for (const auto& a : allowed)
    if (v == a) return v;
  std::string list;
  for (const auto& a : allowed) list += (list.empty() ? "" : ", ") + a;
  throw InputError("configuration key '" + key + "': '" + excerpt(v) + "' is not one of: " + list);
}

int require_size_or_unbounded(const ConfigTree& cfg, const std::string& key) {
  const std::string s = cfg.get_string(key);
  if (s == "unbounded") return 0;
  return cfg.get_int32(key);
}

}  // namespace xbarsim
