#pragma once
/// Configuration tree: compiled-in defaults (configs/default.yaml) merged with a user
/// YAML file and `--set key=value` overrides. This is the only place that sees yaml-cpp;
/// subsystems read typed values through it and validate them into plain structs.
#include <memory>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "sw/common/errors.h"

namespace YAML {
class Node;
}

namespace xbarsim {

/// 2^53: every integer below it is exact in a double (get_int, canonical_value).
constexpr double kExactIntegerLimit = 9007199254740992.0;

/// Text of configs/default.yaml (generated at build time).
const char* default_config_yaml();

class ConfigTree {
 public:
  /// Defaults only.
  ConfigTree();
  ~ConfigTree();
  ConfigTree(const ConfigTree&);
  ConfigTree& operator=(const ConfigTree&);

  /// Defaults, then the YAML file at `path` (skipped when empty), then each override
  /// "dotted.key=value" in order. Unknown keys and type mismatches throw InputError.
  static ConfigTree load(const std::string& path, const std::vector<std::string>& overrides);

  /// Merge a YAML document (text) on top; `origin` names it in error messages. Several
  /// documents, duplicate keys and complex (non-scalar) keys are rejected with the line.
  void merge_yaml_text(const std::string& text, const std::string& origin);
  /// Apply one "dotted.key=value" override (value parsed as a YAML scalar or list).
  void apply_override(const std::string& assignment);
  /// Set one key to a YAML text (a scalar or a list), as --set does.
  void set(const std::string& key, const std::string& yaml_value);
  /// Set one key to the scalar `value` as it is, not parsed as YAML again (a sweep point's
  /// value: a list item such as '"a' is that text, not a broken quote).
  void set_scalar(const std::string& key, const std::string& value);

  bool has(const std::string& key) const;
  double get_double(const std::string& key) const;
  /// Numbers are checked against the key's range documented in configs/default.yaml
  /// (InputError naming the key, the range and the value); a numeric key without a
  /// documented range is a programming error (std::logic_error). A whole number written as a
  /// decimal (8.0, 8e0, 1e6) is accepted below kExactIntegerLimit.
  long long get_int(const std::string& key) const;
  /// get_int for keys whose documented range fits in int.
  int get_int32(const std::string& key) const;
  bool get_bool(const std::string& key) const;
  std::string get_string(const std::string& key) const;
  /// True if `key` is a number (it documents its range in configs/default.yaml), though it may
  /// also take a word (e.g. converters.dac_bits: none).
  static bool is_numeric(const std::string& key);
  /// True if `key` is an integer (its default in configs/default.yaml is an integer, or a word
  /// such as `all` with whole bounds).
  static bool is_integer(const std::string& key);
  /// True if the value at `key` is a YAML sequence (a sweep over values).
  bool is_list(const std::string& key) const;
  /// Elements of a sequence value as YAML scalar texts (for sweeps).
  std::vector<std::string> list_items(const std::string& key) const;
  /// All leaf keys whose value is a list where the default is a scalar (sweeps).
  std::vector<std::string> sweep_keys() const;
  /// Number of sweep points (product of the list lengths), saturating; counted without
  /// expanding the product.
  unsigned long long sweep_points() const;

  /// Keys read so far through the typed getters (by this tree or any copy of it).
  std::set<std::string> read_keys() const;
  /// Every leaf key of configs/default.yaml, in file order.
  std::vector<std::string> leaf_keys() const;

  /// The effective configuration as YAML text (for reports).
  std::string dump() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  void set_node(const std::string& key, const YAML::Node& value, const std::string& origin);
};

/// Rejects a YAML text with several documents, duplicate keys or complex keys, naming
/// `origin` and the line (yaml-cpp itself keeps the last duplicate and ignores documents).
void check_yaml_structure(const std::string& text, const std::string& origin);

/// Validation helpers: throw InputError naming the key and the bad value. (Numeric bounds
/// are the documented ranges every get_* checks.)
std::string require_one_of(const ConfigTree& cfg, const std::string& key, const std::vector<std::string>& allowed);
/// The enumerator named by the value at `key`; InputError listing the names otherwise.
template <typename E>
E require_enum(const ConfigTree& cfg, const std::string& key, const std::vector<std::pair<std::string, E>>& names) {
  const std::string v = cfg.get_string(key);
  std::string list;
  for (const auto& n : names) {
    if (v == n.first) return n.second;
    list += (list.empty() ? "" : ", ") + n.first;
  }
  throw InputError("configuration key '" + key + "': '" + excerpt(v) + "' is not one of: " + list);
}
/// A size that may be the word `unbounded` (returned as 0); otherwise an integer >= 1.
int require_size_or_unbounded(const ConfigTree& cfg, const std::string& key);

}  // namespace xbarsim
