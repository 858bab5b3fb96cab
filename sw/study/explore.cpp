#include "sw/study/explore.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <limits>
#include <sstream>

#include "sw/common/errors.h"
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
  if (!s.dataset.empty()) require_one_of(cfg, "explore.dataset", {"cifar10", "mnist"});
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

std::string canonical_value(const std::string& text) {
  // A finite decimal number (not hex) as the shortest text that reads back as the same double.
  if (text.empty() || text.find_first_of("xX") != std::string::npos) return text;
  char* end = nullptr;
  // An integer exactly, whatever its size: seeds up to 9e18 are not all doubles (2^53).
  errno = 0;
  const long long n = std::strtoll(text.c_str(), &end, 10);
  if (end == text.c_str() + text.size() && errno == 0) return std::to_string(n);
  const double v = std::strtod(text.c_str(), &end);
  if (end != text.c_str() + text.size() || !std::isfinite(v)) return text;
  char buf[32];
  for (int digits = 1; digits <= 17; ++digits) {
    std::snprintf(buf, sizeof buf, "%.*g", digits, v == 0 ? 0.0 : v);  // -0 is 0
    if (std::strtod(buf, nullptr) == v) break;
  }
  return buf;
}

std::string point_key(const ConfigTree& cfg, const std::vector<std::string>& also_ignored) {
  // Over "key=value\n" of every effective key that can change a result, the numeric keys'
  // values canonical (3, 3.0 and 3e0 are one value; a path such as data.dir stays as written).
  // An ignored entry ending in '.' is a whole section.
  static const std::vector<std::string> never = {"solver.threads", "explore.objectives", "explore.color_by",
                                                 "explore.combine", "limits."};
  const auto ignored = [&](const std::string& key) {
    for (const auto* list : {&never, &also_ignored})
      for (const std::string& a : *list)
        if (a.back() == '.' ? starts_with(key, a.c_str()) : key == a) return true;
    return false;
  };
  Fnv1a h;
  for (const auto& key : cfg.leaf_keys()) {
    if (ignored(key)) continue;
    const std::string value = cfg.get_string(key);
    h.add(key + "=" + (ConfigTree::is_numeric(key) ? canonical_value(value) : value) + "\n");
  }
  return h.hex();
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

ResultJournal::ResultJournal(std::string path) : path_(std::move(path)) {
  struct stat st;
  if (stat(path_.c_str(), &st) == 0 && !S_ISREG(st.st_mode))
    throw InputError("the journal '" + path_ + "' is not a regular file; a journal is read back and appended to");
  // Created now, so that a place that refuses files (e.g. /sys) fails before the work, not after.
  const int fd = open(path_.c_str(), O_WRONLY | O_CREAT | O_APPEND, 0644);
  if (fd < 0) throw InputError("cannot write the journal '" + path_ + "': " + std::strerror(errno));
  close(fd);
}

void ResultJournal::repair() const {
  std::ifstream in(path_, std::ios::binary);
  if (!in) return;
  const std::string text((std::istreambuf_iterator<char>(in)), {});
  if (text.empty() || text.back() == '\n') return;
  const size_t keep = text.rfind('\n') == std::string::npos ? 0 : text.rfind('\n') + 1;
  if (truncate(path_.c_str(), static_cast<off_t>(keep)) != 0)
    throw InputError("cannot repair the results file '" + path_ + "': " + std::strerror(errno));
  std::fprintf(stderr, "xbarsim: dropped an incomplete last line of %s (cut short by a kill)\n", path_.c_str());
}

std::vector<nlohmann::json> ResultJournal::read(int* skipped) const {
  std::vector<nlohmann::json> rows;
  int bad = 0;
  std::ifstream in(path_);
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty()) continue;
    nlohmann::json j = nlohmann::json::parse(line, nullptr, false);
    if (j.is_discarded() || !j.is_object() || !j.contains("key") || !j["key"].is_string()) {
      ++bad;
      continue;
    }
    rows.push_back(std::move(j));
  }
  if (skipped) *skipped = bad;
  return rows;
}

void ResultJournal::append_lines(const std::string& line) const {
  if (line.empty()) return;
  const int fd = open(path_.c_str(), O_WRONLY | O_CREAT | O_APPEND, 0644);
  if (fd < 0) throw InputError("cannot open the results file '" + path_ + "': " + std::strerror(errno));
  struct flock lock {};
  lock.l_type = F_WRLCK;
  lock.l_whence = SEEK_SET;
  while (fcntl(fd, F_SETLKW, &lock) < 0 && errno == EINTR) {
  }
  size_t done = 0;
  bool ok = true;
  while (done < line.size()) {
    const ssize_t w = write(fd, line.data() + done, line.size() - done);
    if (w < 0 && errno == EINTR) continue;
    if (w <= 0) {
      ok = false;
      break;
    }
    done += static_cast<size_t>(w);
  }
  const int err = errno;
  ok = ok && fsync(fd) == 0;
  close(fd);  // releases the lock
  if (!ok) throw InputError("cannot write the results file '" + path_ + "': " + std::strerror(err));
}

}  // namespace xbarsim
