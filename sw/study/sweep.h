#pragma once
/// Sweeps: every configuration value given as a list is swept (cartesian product).
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "sw/common/config.h"

namespace xbarsim {

/// One sweep point: (dotted key, value) for every swept key.
using SweepPoint = std::vector<std::pair<std::string, std::string>>;

/// Every point of the sweep (one empty point when nothing sweeps). Refused with its count,
/// before anything is expanded, when there are more than limits.max_sweep_points.
std::vector<SweepPoint> sweep_points(const ConfigTree& cfg);

/// The configuration of one sweep point: `base` with the point's values set.
ConfigTree sweep_config(const ConfigTree& base, const SweepPoint& point);

/// Parses every point's configuration with `parse` before any runs (so a bad value is
/// reported before output starts) and returns the parsed specs in order; `progress(done,
/// total)` is called for long sweeps.
template <typename Spec>
std::vector<Spec> parse_sweep(const ConfigTree& base, const std::vector<SweepPoint>& points,
                              const std::function<Spec(const ConfigTree&)>& parse,
                              const std::function<void(int, int)>& progress = nullptr) {
  std::vector<Spec> specs;
  specs.reserve(points.size());
  for (size_t k = 0; k < points.size(); ++k) {
    specs.push_back(parse(sweep_config(base, points[k])));
    if (progress && points.size() > 100) progress(static_cast<int>(k + 1), static_cast<int>(points.size()));
  }
  return specs;
}

/// Short label "key=value ..." of a point (last key component only), or "default".
std::string sweep_label(const SweepPoint& point);
/// sweep_label of every point, in order (a table's first column, its width fitted to them).
std::vector<std::string> sweep_labels(const std::vector<SweepPoint>& points);

}  // namespace xbarsim
