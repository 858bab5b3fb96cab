#pragma once
/// Strict reading of one YAML map of a data file (the component library, an
/// architecture, a device model): every key read is checked, every key present must have been read, and
/// numbers are finite and non-negative. Errors name the file, the section and the key.
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "sw/common/config.h"
#include "sw/common/errors.h"
#include "sw/common/parse.h"

namespace xbarsim {

/// One map of a hardware file: its keys are checked against the ones read from it.
class YamlSection {
 public:
  /// Section `name` of `root` (required).
  YamlSection(const YAML::Node& root, const std::string& name, const std::string& origin)
      : YamlSection(root[name], name, origin, true) {}
  /// The map `node`, named `name` (a dotted path) in messages.
  YamlSection(const YAML::Node& node, std::string name, std::string origin, bool)
      : node_(node), name_(std::move(name)), origin_(std::move(origin)) {
    if (!node_) throw InputError(origin_ + ": missing section '" + name_ + "'");
    if (!node_.IsMap()) throw InputError(origin_ + ": section '" + name_ + "' must be a map of keys");
  }
  bool has(const std::string& key) const { return static_cast<bool>(node_[key]); }
  /// A key's dotted path in messages (the file's top level has no name of its own).
  std::string key_path(const std::string& key) const { return name_.empty() ? key : name_ + "." + key; }
  /// The sub-map at `key` (required).
  YamlSection section(const std::string& key) {
    get(key);
    return YamlSection(node_[key], key_path(key), origin_, true);
  }
  /// A word (a name).
  std::string word(const std::string& key) {
    const YAML::Node n = get(key);
    if (!n.IsScalar() || n.Scalar().empty()) throw InputError(origin_ + ": '" + key_path(key) + "' must be a name");
    return n.Scalar();
  }
  /// A list of words (names); a single word is a list of one.
  std::vector<std::string> words(const std::string& key) {
    const YAML::Node n = get(key);
    std::vector<std::string> out;
    if (n.IsScalar()) out.push_back(n.Scalar());
    if (n.IsSequence())
      for (const auto& item : n)
        if (item.IsScalar()) out.push_back(item.Scalar());
    if (out.empty() || (n.IsSequence() && out.size() != n.size()))
      throw InputError(origin_ + ": '" + key_path(key) + "' must be a name or a list of names");
    return out;
  }
  /// The keys present, in file order.
  std::vector<std::string> keys() const {
    std::vector<std::string> k;
    for (auto it = node_.begin(); it != node_.end(); ++it) k.push_back(it->first.as<std::string>());
    return k;
  }
  /// The largest quantity a hardware file may give, in any unit (mm^2, mW, pJ, ns, GS/s):
  /// far above any physical component, and small enough that counts (at most 2^53) times it
  /// stay finite in every total (1e308 mm^2 printed inf and JSON null).
  static constexpr double kMaxQuantity = 1e12;
  /// A number >= 0 (> 0 when `positive`), at most kMaxQuantity.
  double number(const std::string& key, bool positive = false) {
    const YAML::Node n = get(key);
    double v = 0;
    if (!n.IsScalar() || !parse_finite_double(n.Scalar(), v) || (positive ? !(v > 0) : v < 0) || v > kMaxQuantity)
      throw InputError(origin_ + ": '" + key_path(key) + "' must be a " + (positive ? "positive" : "non-negative") +
                       " number at most 1e12, got '" + (n.IsScalar() ? n.Scalar() : "?") + "'");
    return v;
  }
  /// The node at `key` as it is (required), for a form the getters do not read.
  YAML::Node raw(const std::string& key) { return get(key); }
  /// A finite number of either sign, at most kMaxQuantity in magnitude (a fit's coefficient).
  double real(const std::string& key) { return real_of(get(key), key); }
  /// A list of such numbers, of min_count to max_count entries.
  std::vector<double> reals(const std::string& key, size_t min_count, size_t max_count) {
    const YAML::Node n = get(key);
    if (!n.IsSequence() || n.size() < min_count || n.size() > max_count)
      throw InputError(origin_ + ": '" + key_path(key) + "' must be a list of " + std::to_string(min_count) +
                       (max_count > min_count ? " to " + std::to_string(max_count) : std::string()) + " numbers");
    std::vector<double> out;
    for (const auto& item : n) out.push_back(real_of(item, key));
    return out;
  }
  /// The largest count a hardware file may give (2^30): products of counts are then taken in
  /// 64 bits, and a file states its own limits on them.
  static constexpr int kMaxCount = 1 << 30;
  /// A positive integer (bits, column counts) at most kMaxCount: 8.5 or 0 is an error, not truncated.
  int integer(const std::string& key) {
    const YAML::Node n = get(key);
    double v = 0;
    if (!n.IsScalar() || !parse_finite_double(n.Scalar(), v) || !(v >= 1) || v != std::floor(v) || v > kMaxCount)
      throw InputError(origin_ + ": '" + key_path(key) + "' must be a positive integer at most " +
                       std::to_string(kMaxCount) + ", got '" + (n.IsScalar() ? n.Scalar() : "?") + "'");
    return static_cast<int>(v);
  }
  /// "<origin>: '<section>.<key>'", for a caller's message about a value it read.
  std::string where(const std::string& key) const { return origin_ + ": '" + key_path(key) + "'"; }
  /// The word at `key`, or `fallback` when the key is absent (an optional name).
  std::string word_or(const std::string& key, const std::string& fallback) {
    read_.push_back(key);
    const YAML::Node n = node_[key];
    return n ? n.Scalar() : fallback;
  }
  /// Rejects keys that were not read (a misspelt key would otherwise be ignored).
  void finish() const {
    for (auto it = node_.begin(); it != node_.end(); ++it) {
      const std::string k = it->first.as<std::string>();
      if (std::find(read_.begin(), read_.end(), k) == read_.end()) {
        std::string list;
        for (size_t i = 0; i < read_.size(); ++i)
          if (std::find(read_.begin(), read_.begin() + static_cast<std::ptrdiff_t>(i), read_[i]) == read_.begin() + static_cast<std::ptrdiff_t>(i))
            list += (list.empty() ? "" : ", ") + read_[i];
        throw InputError(origin_ + ": unknown key '" + key_path(k) + "' (" + list + ")");
      }
    }
  }

 private:
  double real_of(const YAML::Node& n, const std::string& key) const {
    double v = 0;
    if (!n.IsScalar() || !parse_finite_double(n.Scalar(), v) || std::abs(v) > kMaxQuantity)
      throw InputError(origin_ + ": '" + key_path(key) + "' must be a finite number, got '" +
                       (n.IsScalar() ? n.Scalar() : "?") + "'");
    return v;
  }
  YAML::Node get(const std::string& key) {
    read_.push_back(key);
    const YAML::Node n = node_[key];
    if (!n) throw InputError(origin_ + ": missing key '" + key_path(key) + "'");
    return n;
  }
  YAML::Node node_;
  std::string name_, origin_;
  std::vector<std::string> read_;
};

/// A hardware file's text as a YAML map (checked for several documents, duplicate or complex
/// keys first); `what` says what the file is ("a component library").
inline YAML::Node load_yaml_map(const std::string& text, const std::string& origin, const std::string& what) {
  check_yaml_structure(text, origin);
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    throw InputError(origin + ": YAML syntax error: " + e.what());
  }
  if (!root.IsMap()) throw InputError(origin + ": " + what + " is a map of sections");
  return root;
}

/// Rejects top-level keys of `root` outside `known`, listing them.
inline void check_yaml_sections(const YAML::Node& root, const std::vector<std::string>& known,
                                const std::string& origin) {
  for (auto it = root.begin(); it != root.end(); ++it) {
    const std::string k = it->first.as<std::string>();
    if (std::find(known.begin(), known.end(), k) != known.end()) continue;
    std::string list;
    for (const auto& n : known) list += (list.empty() ? "" : ", ") + n;
    throw InputError(origin + ": unknown section '" + k + "' (" + list + ")");
  }
}

}  // namespace xbarsim
