#include "sw/study/explore.h"
#include "sw/device/device.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <limits>
#include <map>
#include <sstream>

#include "sw/analog/analog_spec.h"
#include "sw/common/errors.h"
#include "sw/common/input_file.h"
#include "sw/nn/dataset.h"

namespace xbarsim {

std::string to_string(Objective o) {
  switch (o) {
    case Objective::Accuracy:
      return "accuracy";
    case Objective::Energy:
      return "energy";
    case Objective::Area:
      return "area";
    case Objective::Latency:
      return "latency";
    case Objective::Power:
      return "power";
  }
  return "?";
}

namespace {

bool starts_with(const std::string& s, const char* prefix) { return s.rfind(prefix, 0) == 0; }

std::string trim(const std::string& s) {
  const size_t a = s.find_first_not_of(" \t"), b = s.find_last_not_of(" \t");
  return a == std::string::npos ? "" : s.substr(a, b - a + 1);
}

}  // namespace

ExploreSpec parse_explore_spec(const ConfigTree& cfg) {
  ExploreSpec s;
  for (const auto& key : cfg.sweep_keys())
    for (const char* fixed : {"explore.", "eval.", "data.", "preprocessing."})
      if (starts_with(key, fixed))
        throw InputError("configuration key '" + key +
                         "' cannot be a list in an exploration: the model, the images, the data and the "
                         "preprocessing are the same for every point (run one exploration per setting)");
  s.model = cfg.get_string("explore.model");
  if (!s.model.empty()) {
    try {
      find_model_file(s.model, cfg);  // as --model: a path, or a name in the models directory
    } catch (const InputError& e) {
      throw InputError("configuration key 'explore.model': " + std::string(e.what()));
    }
  }
  s.dataset = cfg.get_string("explore.dataset");
  if (!s.dataset.empty() && !is_npz_dataset(s.dataset))
    require_one_of(cfg, "explore.dataset", {"cifar10", "mnist"});
  s.combine = require_enum<ExploreSpec::Combine>(
      cfg, "explore.combine", {{"product", ExploreSpec::Combine::Product}, {"zip", ExploreSpec::Combine::Zip}});
  const std::string list = cfg.get_string("explore.objectives");
  std::stringstream ss(list);
  std::string name;
  const std::vector<std::pair<std::string, Objective>> names{{"accuracy", Objective::Accuracy},
                                                             {"energy", Objective::Energy},
                                                             {"area", Objective::Area},
                                                             {"latency", Objective::Latency},
                                                             {"power", Objective::Power}};
  while (std::getline(ss, name, ',')) {
    name = trim(name);
    bool found = false;
    for (const auto& n : names)
      if (n.first == name) {
        for (Objective o : s.objectives)
          if (o == n.second) throw InputError("configuration key 'explore.objectives': '" + name + "' appears twice");
        s.objectives.push_back(n.second);
        found = true;
      }
    if (!found)
      throw InputError("configuration key 'explore.objectives': '" + name +
                       "' is not one of: accuracy, energy, area, latency, power (comma-separated)");
  }
  s.accuracy = cfg.get_bool("explore.accuracy");
  s.min_accuracy = cfg.get_string("explore.min_accuracy") == "auto" ? -1 : cfg.get_double("explore.min_accuracy");
  const auto acc = std::find(s.objectives.begin(), s.objectives.end(), Objective::Accuracy);
  if (!s.accuracy && acc != s.objectives.end()) {
    s.objectives.erase(acc);
    s.note = "explore.accuracy is false: accuracy is left out of the objectives";
  }
  if (s.objectives.size() < 2)
    throw InputError("configuration key 'explore.objectives': '" + list +
                     "' names fewer than two objectives (a front needs two or more)");
  s.color_by = cfg.get_string("explore.color_by");
  if (!s.color_by.empty()) {
    bool swept = false;
    for (const auto& k : cfg.sweep_keys()) swept = swept || k == s.color_by;
    if (!swept)
      throw InputError("configuration key 'explore.color_by': '" + s.color_by +
                       "' is not a key given as a list in this space");
  }
  return s;
}

std::vector<SweepPoint> explore_points(const ConfigTree& cfg, ExploreSpec::Combine combine) {
  if (combine == ExploreSpec::Combine::Product) return sweep_points(cfg);
  const std::vector<std::string> keys = cfg.sweep_keys();
  if (keys.empty()) return {SweepPoint{}};
  const size_t n = cfg.list_items(keys[0]).size();
  for (const auto& k : keys)
    if (cfg.list_items(k).size() != n)
      throw InputError("explore.combine = zip pairs the lists value by value, but '" + keys[0] + "' has " +
                       std::to_string(n) + " values and '" + k + "' has " + std::to_string(cfg.list_items(k).size()));
  if (n > static_cast<size_t>(cfg.get_int("limits.max_sweep_points")))
    throw InputError("the space has " + std::to_string(n) + " points, more than limits.max_sweep_points = " +
                     std::to_string(cfg.get_int("limits.max_sweep_points")));
  std::vector<SweepPoint> out(n);
  for (const auto& k : keys) {
    const auto items = cfg.list_items(k);
    for (size_t i = 0; i < n; ++i) out[i].emplace_back(k, items[i]);
  }
  return out;
}

std::string Fnv1a::hex() const {
  char buf[17];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(h_));
  return buf;
}

std::string file_id(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  Fnv1a h;
  char buf[1 << 16];
  while (in.read(buf, sizeof buf) || in.gcount() > 0) h.add(buf, static_cast<size_t>(in.gcount()));
  return h.hex();
}

std::string canonical_value(const std::string& text, bool integer) {
  // A finite decimal number (not hex) as the shortest text that reads back as the same double.
  if (text.empty() || text.find_first_of("xX") != std::string::npos) return text;
  char* end = nullptr;
  if (integer) {
    // An integer exactly, whatever its size: seeds up to 9e18 are not all doubles (2^53).
    errno = 0;
    const long long n = std::strtoll(text.c_str(), &end, 10);
    if (end == text.c_str() + text.size() && errno == 0) return std::to_string(n);
  }
  const double v = std::strtod(text.c_str(), &end);
  if (end != text.c_str() + text.size() || !std::isfinite(v)) return text;
  // A whole number written as a decimal is the integer it is for an integer key (1e6 is
  // 1000000, as ConfigTree::get_int reads it); a real key's value is the shortest form of its
  // double however it is written (1000, 1000.0 and 1e3 are 1e+03, the defaults' form).
  if (integer && v == std::floor(v) && std::fabs(v) < kExactIntegerLimit)
    return std::to_string(static_cast<long long>(v));
  char buf[32];
  for (int digits = 1; digits <= 17; ++digits) {
    std::snprintf(buf, sizeof buf, "%.*g", digits, v == 0 ? 0.0 : v);  // -0 is 0
    if (std::strtod(buf, nullptr) == v) break;
  }
  return buf;
}

namespace {

/// Whether `key` is one of `keys` (an entry ending in '.' is a whole section).
bool listed(const std::string& key, const std::vector<std::string>& keys) {
  for (const std::string& a : keys)
    if (a.back() == '.' ? starts_with(key, a.c_str()) : key == a) return true;
  return false;
}

}  // namespace

bool point_key_ignores(const std::string& key) {
  static const std::vector<std::string> never = {"solver.threads",   "explore.objectives", "explore.color_by",
                                                 "explore.combine",  "explore.min_accuracy", "limits."};
  return listed(key, never);
}

std::string point_key(const ConfigTree& cfg, const std::vector<std::string>& also_ignored) {
  // Over "key=value\n" of every effective key that can change a result, the numeric keys'
  // values canonical (3, 3.0 and 3e0 are one value; a path such as data.dir stays as written).
  const auto ignored = [&](const std::string& key) { return point_key_ignores(key) || listed(key, also_ignored); };
  Fnv1a h;
  for (const auto& key : cfg.leaf_keys()) {
    if (ignored(key)) continue;
    const std::string value = cfg.get_string(key);
    h.add(key + "=" + (ConfigTree::is_numeric(key) ? canonical_value(value, ConfigTree::is_integer(key)) : value) +
          "\n");
    // A device model by what it states (an edited model file is another design).
    if (key == "device.model")
      if (const std::string text = device_model_text(value); !text.empty()) h.add(text + "\n");
  }
  return h.hex();
}

std::string explore_point_key(const ConfigTree& point_cfg, const std::string& model_id, const std::string& dataset) {
  return point_key(point_cfg, {"explore.model", "explore.dataset"}) + " model " + model_id + " " + dataset;
}

const std::vector<std::string>& readout_keys() {
  static const std::vector<std::string> keys = {"converters.adc_bits",
                                                "converters.adc_range",
                                                "converters.adc_margin",
                                                "converters.adc_offset_subtraction",
                                                "converters.adc_columns_per_adc",
                                                "device.time_s",
                                                "device.compensation",
                                                "components.",
                                                "architecture.",
                                                "platform.",
                                                "study."};
  return keys;
}

std::string programming_key(const ConfigTree& point_cfg, const std::string& model_id, const std::string& dataset) {
  // The method by its conversion: whether it calibrates is read out (AnalogLayer::set_readout).
  ConfigTree cfg = point_cfg;
  const char* conversion = "none";
  switch (mitigation_from_name(cfg.get_string("mitigation.method")).conversion()) {
    case ConversionKind::None:
      conversion = "none";
      break;
    case ConversionKind::Signal:
      conversion = "conversion";
      break;
    case ConversionKind::Matrix:
      conversion = "matrix-conversion";
      break;
  }
  cfg.set_scalar("mitigation.method", conversion);
  std::vector<std::string> ignored = readout_keys();
  ignored.insert(ignored.end(), {"explore.model", "explore.dataset"});
  return point_key(cfg, ignored) + " model " + model_id + " " + dataset;
}

std::vector<size_t> explore_share(const std::vector<size_t>& pending, const std::vector<std::string>& group_of,
                                  int rank, int ranks) {
  // Group by group, each group where its first point is.
  std::map<std::string, std::vector<size_t>> members;
  std::vector<const std::string*> groups;  // in the order of their first point
  for (size_t k : pending) {
    auto it = members.find(group_of.at(k));
    if (it == members.end()) {
      it = members.emplace(group_of.at(k), std::vector<size_t>()).first;
      groups.push_back(&it->first);
    }
    it->second.push_back(k);
  }
  std::vector<size_t> ordered;
  ordered.reserve(pending.size());
  for (const std::string* g : groups) ordered.insert(ordered.end(), members[*g].begin(), members[*g].end());
  // Contiguous shares: the first (n mod ranks) ranks take one point more.
  const size_t n = ordered.size(), r = static_cast<size_t>(rank), size = static_cast<size_t>(ranks);
  const size_t first = r * (n / size) + std::min(r, n % size);
  const size_t count = n / size + (r < n % size ? 1 : 0);
  return std::vector<size_t>(ordered.begin() + static_cast<std::ptrdiff_t>(first),
                             ordered.begin() + static_cast<std::ptrdiff_t>(first + count));
}

double objective_cost(const nlohmann::json& row, Objective o) {
  const char* field = nullptr;
  switch (o) {
    case Objective::Accuracy:
      field = "accuracy";
      break;
    case Objective::Energy:
      field = "energy_uj_per_image";
      break;
    case Objective::Area:
      field = "area_mm2";
      break;
    case Objective::Latency:
      field = "latency_us";
      break;
    case Objective::Power:
      field = "avg_power_mw";
      break;
  }
  const auto it = row.find(field);
  if (it == row.end() || !it->is_number()) return std::numeric_limits<double>::quiet_NaN();
  const double v = it->get<double>();
  return o == Objective::Accuracy ? -v : v;
}

std::vector<bool> pareto_front(const std::vector<std::vector<double>>& costs) {
  const size_t n = costs.size();
  auto valid = [&](size_t i) {
    for (double c : costs[i])
      if (std::isnan(c)) return false;
    return true;
  };
  std::vector<bool> front(n, false);
  for (size_t i = 0; i < n; ++i) {
    if (!valid(i)) continue;
    bool dominated = false;
    for (size_t j = 0; j < n && !dominated; ++j) {
      if (j == i || !valid(j)) continue;
      bool no_worse = true, better = false;
      for (size_t o = 0; o < costs[i].size(); ++o) {
        no_worse = no_worse && costs[j][o] <= costs[i][o];
        better = better || costs[j][o] < costs[i][o];
      }
      dominated = no_worse && better;
    }
    front[i] = !dominated;
  }
  return front;
}

double accuracy_floor(const ExploreSpec& spec, const nlohmann::json& rows) {
  if (spec.min_accuracy >= 0) return spec.min_accuracy;
  double software = 0;
  for (const auto& r : rows)
    if (r.is_object() && r.contains("software_accuracy") && r["software_accuracy"].is_number())
      software = std::max(software, r["software_accuracy"].get<double>());
  return 0.5 * software;
}

JournalKind explore_journal_kind() {
  return {"explore results file", "--out", [](const nlohmann::json& row) {
            return row.contains("key") && row["key"].is_string() && row.contains("status") && row["status"].is_string();
          }};
}

std::string explore_row_problem(const nlohmann::json& row) {
  const auto text = [&](const char* k) { return row.contains(k) && row[k].is_string(); };
  const auto number = [&](const char* k, double lo, double hi) {
    return row.contains(k) && row[k].is_number() && row[k].get<double>() >= lo && row[k].get<double>() <= hi;
  };
  constexpr double kHuge = std::numeric_limits<double>::max();
  if (!text("label")) return "'label' is not a text";
  const std::string status = row["status"];
  if (status == "failed") return text("reason") ? "" : "a failed point's 'reason' is not a text";
  if (status != "ok") return "'status' is '" + excerpt(status) + "', not ok or failed";
  for (const char* k : {"energy_uj_per_image", "area_mm2", "latency_us", "avg_power_mw"})
    if (!number(k, 0, kHuge)) return "'" + std::string(k) + "' is not a finite number >= 0";
  if (row.value("mode", "") == "timing-only") return "";  // explore.accuracy false: no evaluation
  for (const char* k : {"accuracy", "software_accuracy"})
    if (!number(k, 0, 1)) return "'" + std::string(k) + "' is not an accuracy in [0, 1]";
  if (!number("accuracy_drop", -1, 1)) return "'accuracy_drop' is not in [-1, 1]";
  const auto& ci = row.value("accuracy_drop_ci95", nlohmann::json());
  if (!ci.is_array() || ci.size() != 2 || !ci[0].is_number() || !ci[1].is_number() ||
      !(ci[0].get<double>() >= -1 && ci[0].get<double>() <= ci[1].get<double>() && ci[1].get<double>() <= 1))
    return "'accuracy_drop_ci95' is not an interval in [-1, 1]";
  for (const char* k :
       {"energy_uj_per_image", "area_mm2", "latency_us", "avg_power_mw", "mean_relative_error", "worst_relative_error"})
    if (!number(k, 0, kHuge)) return "'" + std::string(k) + "' is not a finite number >= 0";
  const auto& w = row.value("warnings", nlohmann::json::array());
  if (!w.is_array() || std::any_of(w.begin(), w.end(), [](const nlohmann::json& x) { return !x.is_string(); }))
    return "'warnings' is not a list of texts";
  const auto& layers = row.value("layers", nlohmann::json());
  if (!layers.is_array()) return "'layers' is not a list";
  for (const auto& l : layers)
    if (!l.is_object() || !l.contains("name") || !l["name"].is_string()) return "a layer has no name";
  return "";
}

}  // namespace xbarsim
