#include "sw/study/sweep.h"

#include <climits>

namespace xbarsim {

std::vector<SweepPoint> sweep_points(const ConfigTree& cfg) {
  const unsigned long long points = cfg.sweep_points();
  const long long limit = cfg.get_int("limits.max_sweep_points");
  if (points > static_cast<unsigned long long>(limit)) {
    std::string keys;
    for (const auto& k : cfg.sweep_keys()) keys += (keys.empty() ? "" : ", ") + k;
    throw InputError("the sweep over " + keys + " has " +
                     (points == ULLONG_MAX ? std::string("more than 1.8e19") : std::to_string(points)) +
                     " points, more than limits.max_sweep_points = " + std::to_string(limit) +
                     " (raise it to run this sweep)");
  }
  std::vector<SweepPoint> out(1);
  for (const auto& key : cfg.sweep_keys()) {
    std::vector<SweepPoint> next;
    for (const auto& point : out)
      for (const auto& v : cfg.list_items(key)) {
        SweepPoint p = point;
        p.emplace_back(key, v);
        next.push_back(std::move(p));
      }
    out.swap(next);
  }
  return out;
}

ConfigTree sweep_config(const ConfigTree& base, const SweepPoint& point) {
  ConfigTree cfg = base;
  for (const auto& kv : point) cfg.set_scalar(kv.first, kv.second);
  return cfg;
}

std::string sweep_label(const SweepPoint& point) {
  std::string label;
  for (const auto& kv : point)
    label += (label.empty() ? "" : " ") + kv.first.substr(kv.first.rfind('.') + 1) + "=" + kv.second;
  return label.empty() ? "default" : label;
}

std::vector<std::string> sweep_labels(const std::vector<SweepPoint>& points) {
  std::vector<std::string> labels;
  labels.reserve(points.size());
  for (const SweepPoint& p : points) labels.push_back(sweep_label(p));
  return labels;
}

}  // namespace xbarsim
