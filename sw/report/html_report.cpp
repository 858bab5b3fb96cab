#include "sw/report/html_report.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <cctype>
#include <cstring>
#include <functional>
#include <iterator>
#include <map>
#include <sstream>
#include <tuple>

#include "sw/common/output_file.h"
#include "sw/common/quantity_text.h"
#include "sw/report/svg_plot.h"

namespace xbarsim {

namespace {

using json = nlohmann::json;
const double kNaN = std::numeric_limits<double>::quiet_NaN();

double num(const json& row, const char* key) {
  const auto it = row.find(key);
  return it != row.end() && it->is_number() ? it->get<double>() : kNaN;
}
/// Whether a row is usable: an object without a status other than "ok" (odd types are skipped).
bool ok(const json& row) {
  if (!row.is_object()) return false;
  const auto it = row.find("status");
  return it == row.end() || (it->is_string() && *it == "ok");
}
bool on_front(const json& row) {
  const auto it = row.find("front");
  return it != row.end() && it->is_boolean() && it->get<bool>();
}
std::string text(const json& row, const char* key) {
  const auto it = row.find(key);
  if (it == row.end()) return "";
  return it->is_string() ? it->get<std::string>() : it->dump();
}
std::string short_label(const std::string& s, size_t n = 34) { return s.size() <= n ? s : s.substr(0, n - 1) + "~"; }
/// The parts of a layer's name between '/', without a linear layer's trailing op type
/// ("/layer1/layer1.0/conv1/Conv" -> layer1, layer1.0, conv1).
std::vector<std::string> name_parts(const std::string& name) {
  std::vector<std::string> parts;
  std::string part;
  std::istringstream in(name);
  while (std::getline(in, part, '/'))
    if (!part.empty()) parts.push_back(part);
  if (parts.size() > 1 && (parts.back() == "Conv" || parts.back() == "Gemm" || parts.back() == "MatMul"))
    parts.pop_back();
  return parts;
}

/// Layer names as an axis shows them: the last two parts ("layer1.0/conv1"), more of them
/// where two layers would read alike ("inception3a/branch2/branch2.1/conv" beside
/// "inception3b/branch2/branch2.1/conv"), the whole name where even that is not enough; every
/// label distinct (a number is added to names that are equal).
std::vector<std::string> layer_labels(const std::vector<std::string>& names) {
  const size_t n = names.size();
  std::vector<std::vector<std::string>> parts;
  for (const auto& s : names) parts.push_back(name_parts(s));
  std::vector<size_t> k(n);
  for (size_t i = 0; i < n; ++i) k[i] = std::min<size_t>(2, parts[i].size());
  auto label = [&](size_t i) {
    if (k[i] > parts[i].size()) return names[i];  // every part was not enough
    std::string s;
    for (size_t p = parts[i].size() - k[i]; p < parts[i].size(); ++p) s += (s.empty() ? "" : "/") + parts[i][p];
    return s.empty() ? names[i] : s;
  };
  for (bool changed = true; changed;) {
    changed = false;
    std::map<std::string, std::vector<size_t>> by_label;
    for (size_t i = 0; i < n; ++i) by_label[label(i)].push_back(i);
    for (const auto& g : by_label)
      if (g.second.size() > 1)
        for (size_t i : g.second)
          if (k[i] <= parts[i].size()) ++k[i], changed = true;
  }
  std::vector<std::string> out(n);
  std::map<std::string, int> seen;
  for (size_t i = 0; i < n; ++i) {
    out[i] = label(i);
    const int m = seen[out[i]]++;
    if (m) out[i] += " (" + std::to_string(m + 1) + ")";
  }
  return out;
}

/// The y metric of the bits plots: accuracy (%) when any row has it, else the mean relative
/// error (%).
struct Metric {
  const char* key;
  std::string name;
};
Metric y_metric(const json& rows) {
  for (const auto& r : rows)
    if (ok(r) && !std::isnan(num(r, "accuracy"))) return {"accuracy", "accuracy (%)"};
  return {"mean_relative_error", "mean relative error (%)"};
}

/// The two average powers, named apart: simulate's (energy over the simulated time per image)
/// and eval's (energy over the ideal time: the crossbar reads back to back), which is higher.
constexpr const char* kSimulatedPower = "average power (simulated time)";
constexpr const char* kIdealPower = "average power (ideal time, eval)";

std::string tooltip(const json& r) {
  std::string t = text(r, "label");
  for (const auto& f : {std::make_pair("accuracy", "accuracy %"), std::make_pair("mean_relative_error", "mean error %")})
    if (!std::isnan(num(r, f.first))) t += "\n" + std::string(f.second) + " " + fmt_num(100 * num(r, f.first));
  for (const auto& f : {std::make_pair("energy_uj_per_image", "energy uJ/image"), std::make_pair("area_mm2", "area mm2"),
                        std::make_pair("latency_us", "latency us"),
                        std::make_pair("throughput_images_per_s", "throughput images/s")})
    if (!std::isnan(num(r, f.first))) t += "\n" + std::string(f.second) + " " + fmt_num(num(r, f.first));
  if (!std::isnan(num(r, "avg_power_mw")))
    t += "\n" + std::string(kSimulatedPower) + " " + power_text(num(r, "avg_power_mw"));
  if (!std::isnan(num(r, "ideal_avg_power_mw")))
    t += "\n" + std::string(kIdealPower) + " " + power_text(num(r, "ideal_avg_power_mw"));
  if (on_front(r)) t += "\non the Pareto front";
  return t;
}

/// A section's content, or why it is not shown (then `html` is empty).
struct Part {
  std::string html, absent;
};
Part absent(const std::string& why) { return {"", why}; }

/// An axis over [lo, hi] (values > 0 for a log axis): logarithmic when the values span more
/// than 100x, padded either way.
PlotAxis value_axis(const std::string& label, double lo, double hi, bool from_zero = false) {
  if (lo > 0 && hi / lo > 100) return PlotAxis{label + " (log scale)", lo / 1.4, hi * 1.4, true};
  if (from_zero) return PlotAxis{label, 0, hi * 1.08 + 1e-300};
  // Equal values (every point the same latency, say) get a window of +-5 % around them.
  const double pad = hi - lo > 1e-9 * std::max(std::abs(hi), 1e-300) ? 0.06 * (hi - lo)
                                                                     : std::max(0.05 * std::abs(hi), 1e-9);
  return PlotAxis{label, lo - pad, hi + pad};
}

/// Colour of each row by the value of `key` in its point (sorted numerically when all numbers).
struct Colouring {
  std::vector<std::pair<std::string, std::string>> legend;
  std::map<std::string, std::string> of_value;
  std::string of(const json& r, const std::string& key) const {
    if (key.empty() || !r.contains("point") || !r["point"].is_object()) return palette(0);
    const auto it = of_value.find(text(r["point"], key.c_str()));
    return it == of_value.end() ? palette(0) : it->second;
  }
};
Colouring colouring(const json& rows, const std::string& key) {
  Colouring c;
  if (key.empty()) return c;
  std::vector<std::string> values;
  for (const auto& r : rows)
    if (r.contains("point") && r["point"].is_object() && r["point"].contains(key)) {
      const std::string v = text(r["point"], key.c_str());
      if (std::find(values.begin(), values.end(), v) == values.end()) values.push_back(v);
    }
  auto as_num = [](const std::string& s, double& d) {
    char* end = nullptr;
    d = std::strtod(s.c_str(), &end);
    return !s.empty() && end && *end == 0;
  };
  std::stable_sort(values.begin(), values.end(), [&](const std::string& a, const std::string& b) {
    double x, y;
    const bool na = as_num(a, x), nb = as_num(b, y);
    if (na && nb) return x < y;
    return na && !nb;
  });
  for (size_t i = 0; i < values.size(); ++i) {
    c.of_value[values[i]] = palette(i);
    c.legend.emplace_back(values[i], palette(i));
  }
  return c;
}

/// An objective as the rows carry it: field, axis name, scale to the axis unit.
struct ObjectiveField {
  std::string name;
  const char* key;
  std::string axis;
  double scale;
};
ObjectiveField objective_field(const std::string& o) {
  if (o == "accuracy") return {o, "accuracy", "accuracy (%)", 100};
  if (o == "energy") return {o, "energy_uj_per_image", "energy per image (uJ)", 1};
  if (o == "area") return {o, "area_mm2", "area (mm2)", 1};
  if (o == "latency") return {o, "latency_us", "latency (us)", 1};
  if (o == "power") return {o, "avg_power_mw", "average power (mW)", 1};
  return {o, "", o, 1};
}

const std::string kGrey = "#c4c4c4";

bool below_floor(const json& r, double floor) { return floor >= 0 && num(r, "accuracy") < floor; }

/// The front's points in key order (most accurate first, else lowest energy), numbered 1...
std::vector<const json*> front_rows(const json& rows) {
  std::vector<const json*> f;
  for (const auto& r : rows)
    if (ok(r) && on_front(r)) f.push_back(&r);
  // Rows without an accuracy (timing-only) after those with one; then lowest energy first.
  const auto key = [](const json* r) {
    const double a = num(*r, "accuracy"), e = num(*r, "energy_uj_per_image");
    return std::make_tuple(std::isnan(a) ? 1 : 0, std::isnan(a) ? 0.0 : -a, std::isnan(e) ? INFINITY : e);
  };
  std::stable_sort(f.begin(), f.end(), [&](const json* a, const json* b) { return key(a) < key(b); });
  return f;
}

/// The rows' labels as the plots show them: the key=value items every one of them shares left
/// out (they are in the table), and a front point's key number first ("#2 max_rows=72").
std::vector<std::string> names(const std::vector<const json*>& rows) {
  std::vector<std::vector<std::string>> items;
  for (const json* r : rows) {
    std::istringstream in(text(*r, "label"));
    items.emplace_back(std::istream_iterator<std::string>(in), std::istream_iterator<std::string>());
  }
  std::vector<std::string> out;
  for (size_t i = 0; i < rows.size(); ++i) {
    std::string s;
    for (const auto& it : items[i]) {
      const bool shared = rows.size() > 1 && std::all_of(items.begin(), items.end(), [&](const auto& v) {
        return std::find(v.begin(), v.end(), it) != v.end();
      });
      if (!shared) s += (s.empty() ? "" : " ") + it;
    }
    if (s.empty()) s = text(*rows[i], "label");
    const double k = num(*rows[i], "front_number");
    out.push_back(std::isnan(k) ? s : "#" + fmt_num(k) + " " + s);
  }
  return out;
}

/// A legend under one or more plots (`plots`: their ids, space-separated), in HTML (full
/// labels, wrapped): a coloured square and a name each.
std::string html_legend(const std::vector<std::pair<std::string, std::string>>& items, const std::string& note,
                        const std::string& plots) {
  std::string h = "<div class=\"legend\" data-for=\"" + html_escape(plots) + "\">";
  if (!note.empty()) h += "<span>" + html_escape(note) + "</span>";
  for (const auto& it : items)
    h += "<span><i style=\"background:" + it.second + "\"></i>" + html_escape(it.first) + "</span>";
  return h + "</div>\n";
}

const std::string kFloorColour = "#777", kFrontLineColour = "#555";

/// The accuracy floor on a plot whose y axis is accuracy (%) over the points' [ylo, yhi]: a
/// labelled dashed line when it lies near them (the axis then reaches it), else not drawn, and
/// a note at the foot of the plot says it lies below (an axis stretched to a far floor would
/// squeeze every point into its top).
struct FloorMark {
  bool line = false, below = false;
};
FloorMark floor_mark(double floor, double& ylo, double yhi) {
  FloorMark f;
  if (!(floor > 0)) return f;
  const double y = 100 * floor;
  if (y >= ylo - 0.25 * std::max(yhi - ylo, 2.0)) {
    f.line = true;
    ylo = std::min(ylo, y);
  } else {
    f.below = true;
  }
  return f;
}
void draw_floor(SvgPlot& p, const FloorMark& f, double floor, const PlotAxis& xa, const PlotAxis& ya) {
  const std::string what = "accuracy floor " + fmt_num(100 * floor) + " % (explore.min_accuracy)";
  if (f.line) {
    p.line({{xa.lo, 100 * floor}, {xa.hi, 100 * floor}}, kFloorColour, true, 1.2,
           what + ": below it, never on the front");
    p.label(xa.lo, 100 * floor, what, 4, -4);
  } else if (f.below) {
    p.label(xa.lo, ya.lo, "\u2193 " + what + ": below this axis", 4, -6);
  }
}

/// One scatter of objective `xo` against `yo`: every ok row coloured by the colour key, the
/// front large and numbered (the key's numbers), points below the accuracy floor grey.
/// `line`: join the front (2 objectives). `legend`: the plot's own legend at its right; else
/// its entries are added to `shared` (a legend under several plots).
struct Scatter {
  std::string svg;
  std::vector<std::pair<std::string, std::string>> legend;
};
Scatter scatter(const json& rows, const std::vector<const json*>& front, const ObjectiveField& xo,
                const ObjectiveField& yo, const ReportInput& in, const std::string& id, int w, int h, bool big,
                bool line) {
  std::vector<const json*> pts;
  double xlo = INFINITY, xhi = -INFINITY, ylo = INFINITY, yhi = -INFINITY;
  for (const auto& r : rows) {
    const double x = xo.scale * num(r, xo.key), y = yo.scale * num(r, yo.key);
    if (!ok(r) || std::isnan(x) || std::isnan(y)) continue;
    pts.push_back(&r);
    xlo = std::min(xlo, x), xhi = std::max(xhi, x), ylo = std::min(ylo, y), yhi = std::max(yhi, y);
  }
  if (pts.empty()) return {};
  // Accuracy, where it is one of the two, is always on the y axis (front_part puts it there).
  const double floor = in.min_accuracy;
  const FloorMark fm = std::string(yo.key) == "accuracy" ? floor_mark(floor, ylo, yhi) : FloorMark{};
  const Colouring col = colouring(rows, in.color_key);
  Scatter out;
  out.legend = col.legend;
  const bool greyed = std::any_of(pts.begin(), pts.end(), [&](const json* r) { return below_floor(*r, floor); });
  if (greyed) out.legend.emplace_back("below the accuracy floor", kGrey);
  if (fm.line) out.legend.emplace_back("accuracy floor (dashed)", kFloorColour);
  const bool joined_front = line && front.size() > 1;
  if (joined_front) out.legend.emplace_back("Pareto front (dashed)", kFrontLineColour);
  const PlotAxis xa = value_axis(xo.axis, xlo, xhi), ya = value_axis(yo.axis, ylo, yhi);
  SvgPlot p(id, w, h, xa, ya, big ? 70 : 62, big ? 50 : 44, big ? 170 : 0);
  draw_floor(p, fm, floor, xa, ya);
  const double r_small = big ? 5.5 : 4, r_front = big ? 8 : 5.5;
  for (const json* r : pts)  // the rest first, so that the front is drawn on top
    if (!on_front(*r))
      p.circle(xo.scale * num(*r, xo.key), yo.scale * num(*r, yo.key), r_small,
               below_floor(*r, floor) ? kGrey : col.of(*r, in.color_key), tooltip(*r));
  std::vector<std::pair<double, double>> at(front.size(), {kNaN, kNaN});  // the front's marks, NaN: not drawn
  for (size_t i = 0; i < front.size(); ++i) {
    const double x = xo.scale * num(*front[i], xo.key), y = yo.scale * num(*front[i], yo.key);
    if (std::isnan(x) || std::isnan(y)) continue;
    at[i] = {x, y};
    p.circle(x, y, r_front, col.of(*front[i], in.color_key), "#" + std::to_string(i + 1) + " " + tooltip(*front[i]), true);
  }
  std::vector<std::pair<double, double>> joined;
  for (const auto& xy : at)
    if (!std::isnan(xy.first)) joined.push_back(xy);
  if (joined_front && joined.size() > 1) {
    std::sort(joined.begin(), joined.end());
    p.line(joined, kFrontLineColour, true, 1.5, "Pareto front");
  }
  // The tags after every mark, so that each knows all the marks it should not cover.
  for (size_t i = 0; i < front.size(); ++i)
    if (!std::isnan(at[i].first)) p.tag(at[i].first, at[i].second, r_front, std::to_string(i + 1));
  if (big) p.legend(out.legend, in.color_key.empty() ? "" : short_label(in.color_key, 22));
  out.svg = p.str();
  return out;
}

std::string cell(double v, double scale = 1) { return "<td>" + (std::isnan(v) ? std::string() : fmt_num(v * scale)) + "</td>"; }

Part front_part(const json& rows, const ReportInput& in) {
  std::vector<ObjectiveField> obj;
  for (const auto& o : in.objectives) obj.push_back(objective_field(o));
  if (obj.size() < 2) return absent("the Pareto front (explore)");
  const std::vector<const json*> front = front_rows(rows);
  // The main view: accuracy against energy when both are objectives, else the first two.
  auto find = [&](const char* n) {
    return std::find_if(obj.begin(), obj.end(), [&](const ObjectiveField& o) { return o.name == n; });
  };
  const ObjectiveField yo = find("accuracy") != obj.end() ? *find("accuracy") : obj[1];
  ObjectiveField xo = find("energy") != obj.end() ? *find("energy") : obj[0];
  if (xo.name == yo.name) xo = obj[0].name == yo.name ? obj[1] : obj[0];  // never one objective on both axes
  const bool pairwise = obj.size() > 2;
  const std::string main = scatter(rows, front, xo, yo, in, "plot-pareto", 780, 470, true, !pairwise).svg;
  if (main.empty()) return absent("the Pareto scatter: no point has both " + xo.name + " and " + yo.name);
  std::string h;
  const int n_ok = static_cast<int>(std::count_if(rows.begin(), rows.end(), [](const json& r) { return ok(r); }));
  int greyed = 0;
  for (const auto& r : rows) greyed += ok(r) && below_floor(r, in.min_accuracy);
  h += "<p>" + std::to_string(front.size()) + " of " + std::to_string(n_ok) + " points are on the front over ";
  for (size_t i = 0; i < obj.size(); ++i) h += (i ? ", " : "") + obj[i].name;
  h += " (drawn large, numbered as in the key).";
  if (in.min_accuracy > 0)
    h += " " + std::to_string(greyed) + " point(s) below the accuracy floor of " + fmt_num(100 * in.min_accuracy) +
         " % (explore.min_accuracy) are grey and never on the front.";
  if (pairwise)
    h += " With " + std::to_string(obj.size()) +
         " objectives a front point may look dominated in any one pair of them, so the front is drawn as marks, "
         "not a line; every pair is plotted below.";
  h += "</p>\n<div class=\"row\">" + main + "<div class=\"key\"><table><tr><th>#</th><th class=\"name\">point</th>";
  for (const auto& o : obj) h += "<th>" + html_escape(o.axis) + "</th>";
  h += "</tr>\n";
  for (size_t i = 0; i < front.size(); ++i) {
    h += "<tr><td>" + std::to_string(i + 1) + "</td><td class=\"name\">" + html_escape(text(*front[i], "label")) + "</td>";
    for (const auto& o : obj) h += cell(num(*front[i], o.key), o.scale);
    h += "</tr>\n";
  }
  h += "</table></div></div>\n";
  if (pairwise) {
    // The pairs coloured as the main plot, their front points numbered alike, one legend under them.
    h += "<div class=\"grid\">";
    int k = 0;
    std::string ids;
    std::vector<std::pair<std::string, std::string>> legend;
    for (size_t a = 0; a < obj.size(); ++a)
      for (size_t b = a + 1; b < obj.size(); ++b) {
        // Accuracy on the y axis where it is one of the pair.
        const bool swap = obj[a].name == "accuracy";
        const std::string id = "plot-pair-" + std::to_string(k++);
        const Scatter sc =
            scatter(rows, front, swap ? obj[b] : obj[a], swap ? obj[a] : obj[b], in, id, 440, 300, false, false);
        if (sc.svg.empty()) continue;
        h += sc.svg;
        ids += (ids.empty() ? "" : " ") + id;
        for (const auto& it : sc.legend)
          if (std::find(legend.begin(), legend.end(), it) == legend.end()) legend.push_back(it);
      }
    h += "</div>\n" + html_legend(legend, (in.color_key.empty() ? std::string() : in.color_key + ":"), ids) +
         "<p>Every pair: the points coloured as above, the front drawn large and numbered as in the key.</p>\n";
  }
  return {h, ""};
}

/// Values of `key` among the ok rows that carry it (text of numbers and words alike).
std::vector<std::string> distinct(const json& rows, const char* key) {
  std::vector<std::string> v;
  for (const auto& r : rows)
    if (ok(r) && r.contains(key)) {
      const std::string t = text(r, key);
      if (std::find(v.begin(), v.end(), t) == v.end()) v.push_back(t);
    }
  return v;
}

/// A metric (accuracy, else the mean error) against converter bits: every ok row as a point
/// coloured by the colour key (grey below the accuracy floor), the best per bit width joined.
Part bits_plot(const json& rows, const char* key, const std::string& id, const std::string& name,
               const ReportInput& in) {
  const double floor = in.min_accuracy;
  const std::vector<std::string> values = distinct(rows, key);
  if (values.size() < 2)
    return absent(name + " plot (" + (values.empty() ? std::string("no row has them") : "not swept: all " + values[0]) + ")");
  const Metric m = y_metric(rows);
  std::vector<std::pair<double, double>> pts;
  std::vector<const json*> src;
  double maxbits = 0;
  bool none = false;
  for (const auto& r : rows) {
    if (!ok(r) || !r.contains(key)) continue;
    if (r[key].is_number()) maxbits = std::max(maxbits, r[key].get<double>());
    none = none || (r[key].is_string() && r[key] == "none");
  }
  const double none_x = maxbits + 2;
  double ylo = INFINITY, yhi = -INFINITY, xlo = INFINITY;
  for (const auto& r : rows) {
    if (!ok(r) || !r.contains(key) || std::isnan(num(r, m.key))) continue;
    const double x = r[key].is_number() ? r[key].get<double>() : r[key] == "none" ? none_x : kNaN;
    if (std::isnan(x)) continue;
    const double y = 100 * num(r, m.key);
    pts.emplace_back(x, y);
    src.push_back(&r);
    ylo = std::min(ylo, y), yhi = std::max(yhi, y), xlo = std::min(xlo, x);
  }
  if (pts.empty()) return absent(name + " plot: no row has " + key + " and " + m.name);
  const double xhi = none ? none_x : maxbits;
  PlotAxis xa{name, xlo - 0.7, xhi + 0.7};
  for (double b = std::floor(xlo); b <= maxbits; ++b) xa.ticks.emplace_back(b, fmt_num(b));
  if (none) xa.ticks.emplace_back(none_x, "none");
  const bool acc = std::string(m.key) == "accuracy";
  const FloorMark fm = acc ? floor_mark(floor, ylo, yhi) : FloorMark{};
  const PlotAxis ya = value_axis(m.name, ylo, yhi);
  const Colouring col = colouring(rows, in.color_key);
  SvgPlot p(id, 820, 330, xa, ya, 70, 50, 170);
  draw_floor(p, fm, floor, xa, ya);
  std::map<double, double> best;
  const bool lower_better = !acc;
  for (size_t i = 0; i < pts.size(); ++i) {
    p.circle(pts[i].first, pts[i].second, 5, below_floor(*src[i], floor) ? kGrey : col.of(*src[i], in.color_key),
             tooltip(*src[i]));
    auto it = best.find(pts[i].first);
    if (it == best.end())
      best[pts[i].first] = pts[i].second;
    else
      it->second = lower_better ? std::min(it->second, pts[i].second) : std::max(it->second, pts[i].second);
  }
  std::vector<std::pair<double, double>> line(best.begin(), best.end());
  const std::string kBest = "#222";
  p.line(line, kBest, false, 2, "best per bit width");
  std::vector<std::pair<std::string, std::string>> legend = col.legend;
  if (legend.empty()) legend.emplace_back("a design point", palette(0));
  if (std::any_of(src.begin(), src.end(), [&](const json* r) { return below_floor(*r, floor); }))
    legend.emplace_back("below the accuracy floor", kGrey);
  if (fm.line) legend.emplace_back("accuracy floor (dashed)", kFloorColour);
  legend.emplace_back(lower_better ? "least error per bit width (line)" : "best per bit width (line)", kBest);
  p.legend(legend, in.color_key.empty() ? "" : short_label(in.color_key, 22));
  return {p.str(), ""};
}

constexpr size_t kMostRows = 8;
/// The rows the per-layer and breakdown plots show: the front (or every ok row), most
/// accurate (or least error) first, at most kMostRows.
std::vector<const json*> selected(const json& rows) {
  std::vector<const json*> s;
  for (const auto& r : rows)
    if (ok(r) && on_front(r)) s.push_back(&r);
  if (s.empty())
    for (const auto& r : rows)
      if (ok(r)) s.push_back(&r);
  const Metric m = y_metric(rows);
  const bool acc = std::string(m.key) == "accuracy";
  std::stable_sort(s.begin(), s.end(), [&](const json* a, const json* b) {
    const double x = num(*a, m.key), y = num(*b, m.key);
    if (std::isnan(x) || std::isnan(y)) return !std::isnan(x) && std::isnan(y);
    return acc ? x > y : x < y;
  });
  if (s.size() > kMostRows) s.resize(kMostRows);
  return s;
}

/// How many rows selected() chose from: the front's, or every ok row.
size_t candidates(const json& rows) {
  const bool front = std::any_of(rows.begin(), rows.end(), on_front);
  return static_cast<size_t>(
      std::count_if(rows.begin(), rows.end(), [&](const json& r) { return ok(r) && (!front || on_front(r)); }));
}

/// " Shown: the first 8 of N ..." when a plot shows fewer rows than there were, else "".
std::string shown_of(size_t shown, size_t of) {
  return of > shown ? " Shown: the first " + std::to_string(shown) + " of " + std::to_string(of) +
                          " (front points, or all points, most accurate first)."
                    : "";
}

bool has_layers_with(const json& r, const char* key) {
  return r.contains("layers") && r["layers"].is_array() && !r["layers"].empty() && r["layers"][0].is_object() &&
         r["layers"][0].contains(key);
}

/// Beyond this many layers or stages a per-layer plot lists them down its left side, one line
/// each, instead of along its foot: every name whole and readable, however many.
constexpr size_t kMostAcross = 24;

/// The layers (or stages) of a per-layer plot in network order on a categorical axis: across
/// the foot (first at the left), or down the left side (first on top) when there are many.
/// `at(k, v)` places layer k's value v; `value_axis` is the other axis.
struct LayerAxis {
  bool across = true;
  size_t n = 0;
  PlotAxis axis;
  std::pair<double, double> at(size_t k, double v) const {
    const double c = across ? static_cast<double>(k) : static_cast<double>(n - 1 - k);
    return across ? std::make_pair(c, v) : std::make_pair(v, c);
  }
  /// A plot of the layers against `values`: `width` wide; `height` when across, else a line per layer.
  SvgPlot plot(const std::string& id, int width, int height, const PlotAxis& values, int legend_width = 0) const {
    if (across) return SvgPlot(id, width, height, axis, values, 70, 60, legend_width);
    return SvgPlot(id, width, 90 + 16 * static_cast<int>(n), values, axis, 70, 50, legend_width);
  }
  /// A bar of layer k from value v0 to v1.
  void bar(SvgPlot& p, size_t k, double v0, double v1, const std::string& fill, const std::string& title) const {
    const auto a = at(k, v0), b = at(k, v1);
    if (across)
      p.rect(a.first - 0.38, a.second, b.first + 0.38, b.second, fill, title);
    else
      p.rect(a.first, a.second - 0.38, b.first, b.second + 0.38, fill, title);
  }
};
LayerAxis layer_axis(const std::vector<std::string>& names, const std::string& label) {
  LayerAxis a;
  a.n = names.size();
  a.across = names.size() <= kMostAcross;
  a.axis = PlotAxis{label, 0, 1};
  a.axis.categories = layer_labels(names);
  if (a.across)
    a.axis.rotate_labels = -40;
  else
    std::reverse(a.axis.categories.begin(), a.axis.categories.end());  // the first on top
  return a;
}

Part layers_plot(const std::vector<const json*>& sel, size_t of) {
  std::vector<const json*> rows;
  for (const json* r : sel)
    if (has_layers_with(*r, "mean_relative_error")) rows.push_back(r);
  if (rows.empty()) return absent("per-layer error propagation (the rows carry no per-layer errors: eval and explore do)");
  std::vector<std::string> full;
  double ylo = INFINITY, yhi = 0;
  for (const auto& l : (*rows[0])["layers"]) full.push_back(text(l, "name"));
  for (const json* r : rows)
    for (const auto& l : (*r)["layers"])
      for (const char* k : {"mean_relative_error", "worst_relative_error"}) {
        const double v = 100 * num(l, k);
        if (v > 0) ylo = std::min(ylo, v), yhi = std::max(yhi, v);
      }
  if (!(yhi > 0)) ylo = yhi = 0;  // every error zero: a linear axis at 0
  const LayerAxis la = layer_axis(full, "layer (in network order)");
  const PlotAxis ya = value_axis("relative error (%)", ylo, yhi, true);
  SvgPlot p = la.plot("plot-layers", 1300, 430, ya);
  const std::vector<std::string> shown = names(rows);
  std::vector<std::pair<std::string, std::string>> legend;
  for (size_t i = 0; i < rows.size(); ++i) {
    std::vector<std::pair<double, double>> mean, worst;
    const json& L = (*rows[i])["layers"];
    for (size_t k = 0; k < L.size() && k < full.size(); ++k) {
      // A zero error has no place on a log axis: it sits on the axis' floor.
      const double a = num(L[k], "mean_relative_error"), b = num(L[k], "worst_relative_error");
      auto v_of = [&](double v) { return ya.log ? std::max(100 * v, ya.lo) : 100 * v; };
      if (!std::isnan(a)) mean.push_back(la.at(k, v_of(a)));
      if (!std::isnan(b)) worst.push_back(la.at(k, v_of(b)));
      if (!std::isnan(a))  // the value itself, not where a log axis had to put a zero
        p.circle(mean.back().first, mean.back().second, 3, series_colour(i),
                 shown[i] + "\n" + full[k] + " mean " + fmt_num(100 * a) + " %" +
                     (std::isnan(b) ? "" : ", worst " + fmt_num(100 * b) + " %"));
    }
    const std::string label = shown[i];
    p.line(mean, series_colour(i), false, 2.5, label + ": mean");
    p.line(worst, series_colour(i), true, 1.5, label + ": worst");
    legend.emplace_back(label, series_colour(i));
  }
  return {p.str() +
              html_legend(legend,
                          "each layer's mean error over its outputs: solid; worst: dashed." + shown_of(rows.size(), of),
                          "plot-layers"),
          ""};
}

/// Components of a breakdown in a fixed order, then any others it has (not "total").
std::vector<std::string> components(const std::vector<const json*>& rows, const char* key) {
  std::vector<std::string> c{"crossbar", "adc",  "dac",          "sample_hold", "shift_add",   "accumulator",
                             "shift_register", "output_register", "buffer", "interconnect", "digital", "memory"};
  for (const json* r : rows)
    for (auto it = (*r)[key].begin(); it != (*r)[key].end(); ++it)
      if (it.key() != "total" && std::find(c.begin(), c.end(), it.key()) == c.end()) c.push_back(it.key());
  return c;
}

/// Stacked bars of a breakdown per row. Totals that span more than 10x are drawn as shares of
/// each row's total (100 % bars) with the total printed, so the small rows stay readable.
Part breakdown_plot(const std::vector<const json*>& sel, bool energy) {
  const char* key = energy ? "energy_breakdown_uj" : "area_breakdown_mm2";
  const std::string unit = energy ? "uJ/image" : "mm2";
  std::vector<const json*> rows;
  for (const json* r : sel)
    if (r->contains(key) && (*r)[key].is_object()) rows.push_back(r);
  if (rows.empty()) return absent(energy ? "energy by component (no energy breakdown in the rows)" : "area by component (no area breakdown in the rows)");
  const std::vector<std::string> comps = components(rows, key);
  std::vector<double> totals;
  for (const json* r : rows) {
    double t = 0;
    for (const auto& c : comps) {
      const double v = num((*r)[key], c.c_str());
      if (v > 0) t += v;
    }
    totals.push_back(t);
  }
  const double tmax = *std::max_element(totals.begin(), totals.end());
  double tmin = INFINITY;
  for (double t : totals)
    if (t > 0) tmin = std::min(tmin, t);
  const bool shares = tmin < INFINITY && tmax / tmin > 10;
  PlotAxis ya{"", 0, 1};
  const std::vector<std::string> shown = names(rows);
  for (size_t i = rows.size(); i-- > 0;) ya.categories.push_back(short_label(shown[i], 46));  // the first on top
  const int h = 75 + 36 * static_cast<int>(rows.size());
  const std::string what = energy ? "energy per image by component" : "area by component";
  SvgPlot p(energy ? "plot-energy" : "plot-area", 1300, h,
            {shares ? what + ": share of each row's total (%), totals printed (they span " + fmt_num(tmax / tmin) + "x)"
                    : what + " (" + unit + "), totals printed",
             0, (shares ? 100 : tmax) * 1.16 + 1e-300},
            ya, 320, 45);
  std::vector<std::pair<std::string, std::string>> legend;
  for (size_t c = 0; c < comps.size(); ++c)
    if (std::any_of(rows.begin(), rows.end(), [&](const json* r) { return num((*r)[key], comps[c].c_str()) > 0; }))
      legend.emplace_back(comps[c], palette(c));
  for (size_t i = 0; i < rows.size(); ++i) {
    const double at = static_cast<double>(rows.size() - 1 - i);
    double x = 0;
    for (size_t c = 0; c < comps.size(); ++c) {
      const double v = num((*rows[i])[key], comps[c].c_str());
      if (std::isnan(v) || v <= 0) continue;
      const double w = shares ? 100 * v / totals[i] : v;
      p.rect(x, at - 0.35, x + w, at + 0.35, palette(c),
             text(*rows[i], "label") + "\n" + comps[c] + ": " + fmt_num(v) + " " + unit + " (" +
                 fmt_num(100 * v / totals[i]) + " %)");
      x += w;
    }
    p.label(x, at, fmt_num(totals[i]) + " " + unit, 6, 4);
  }
  return {p.str() + html_legend(legend, "component:", energy ? "plot-energy" : "plot-area"), ""};
}

/// A row's stages for the timing plot: its "stages" (every stage of the platform in pipeline
/// order, the interconnect included: simulate and explore), else its layers' busy and stall.
bool has_stages(const json& r) {
  return r.contains("stages") && r["stages"].is_array() && !r["stages"].empty() && r["stages"][0].is_object() &&
         r["stages"][0].contains("busy_us");
}
const json* timed_stages(const json& r) {
  if (has_stages(r)) return &r["stages"];
  if (has_layers_with(r, "busy_us")) return &r["layers"];
  return nullptr;
}

/// Time per stage on the platform: one row's busy and stall as stacked bars (its bottleneck's
/// busy time in its own colour), or several rows' busy + stall as lines. Every stage is there:
/// the linear layers, the digital stages (pooling, concatenation, additions) and the shared
/// interconnect, so that the stage that bounds the run is always on the plot.
Part timing_plot(const std::vector<const json*>& sel) {
  std::vector<const json*> rows;
  for (const json* r : sel)
    if (timed_stages(*r)) rows.push_back(r);
  if (rows.empty()) return absent("per-stage busy and stall time (the platform's: simulate and explore)");
  const json& L0 = *timed_stages(*rows[0]);
  std::vector<std::string> full;
  for (const auto& l : L0) full.push_back(text(l, "name"));
  auto t_of = [](const json& l, const char* k) { return std::max(0.0, std::isnan(num(l, k)) ? 0.0 : num(l, k)); };
  const bool stages = has_stages(*rows[0]);
  const std::string what = stages ? "stage (in pipeline order)" : "layer (in network order)";
  // Each row's bottleneck, as simulate named it.
  auto bottleneck_of = [](const json& r) {
    return r.contains("bottleneck") && r["bottleneck"].is_object() ? text(r["bottleneck"], "stage") : std::string();
  };
  std::string note;
  for (const json* r : rows)
    if (!bottleneck_of(*r).empty())
      note += (note.empty() ? "" : "; ") + (rows.size() > 1 ? text(*r, "label") + ": " : std::string()) +
              "bottleneck " + bottleneck_of(*r) + ", busy " + fmt_num(num((*r)["bottleneck"], "busy_us_per_image")) +
              " us per image";
  const std::string kBusy = "#4e79a7", kStall = "#f28e2b", kBottleneck = "#b30000";
  if (rows.size() == 1) {
    double yhi = 0;
    for (const auto& l : L0) yhi = std::max(yhi, t_of(l, "busy_us") + t_of(l, "stall_us"));
    const LayerAxis la = layer_axis(full, what + " of " + text(*rows[0], "label"));
    SvgPlot p = la.plot("plot-timing", 1100, 430, {"time per image (us)", 0, yhi * 1.05 + 1e-12}, 190);
    const std::string slow = bottleneck_of(*rows[0]);
    bool marked = false;
    for (size_t k = 0; k < L0.size(); ++k) {
      const double b = t_of(L0[k], "busy_us"), s = t_of(L0[k], "stall_us");
      const bool bottleneck = !slow.empty() && full[k] == slow;
      marked = marked || bottleneck;
      const std::string t = full[k] + (bottleneck ? " (the bottleneck)" : "") + "\nbusy " + fmt_num(b) + " us, stall " +
                            fmt_num(s) + " us";
      la.bar(p, k, 0, b, bottleneck ? kBottleneck : kBusy, t);
      if (s > 0) la.bar(p, k, b, b + s, kStall, t);
    }
    std::vector<std::pair<std::string, std::string>> legend{{"busy", kBusy}, {"stall", kStall}};
    if (marked) legend.emplace_back("busy: the bottleneck", kBottleneck);
    p.legend(legend, "time = busy + stall");
    return {p.str() + (note.empty() ? "" : "<p>" + html_escape(note) + ".</p>\n"), ""};
  }
  double lo = INFINITY, hi = 0;
  for (const json* r : rows)
    for (const auto& l : *timed_stages(*r)) {
      const double t = t_of(l, "busy_us") + t_of(l, "stall_us");
      if (t > 0) lo = std::min(lo, t), hi = std::max(hi, t);
    }
  if (!(hi > 0)) lo = 1, hi = 2;
  const PlotAxis ya = value_axis("busy + stall per image (us)", lo, hi, true);
  const LayerAxis la = layer_axis(full, what);
  SvgPlot p = la.plot("plot-timing", 1300, 430, ya);
  const std::vector<std::string> shown = names(rows);
  std::vector<std::pair<std::string, std::string>> legend;
  for (size_t i = 0; i < rows.size(); ++i) {
    std::vector<std::pair<double, double>> pts;
    const json& L = *timed_stages(*rows[i]);
    for (size_t k = 0; k < L.size() && k < full.size(); ++k) {
      const double t = t_of(L[k], "busy_us") + t_of(L[k], "stall_us");
      pts.push_back(la.at(k, ya.log ? std::max(t, ya.lo) : t));
      p.circle(pts.back().first, pts.back().second, 3, series_colour(i),
               shown[i] + "\n" + full[k] + (full[k] == bottleneck_of(*rows[i]) ? " (the bottleneck)" : "") + ": busy " +
                   fmt_num(t_of(L[k], "busy_us")) + " us, stall " + fmt_num(t_of(L[k], "stall_us")) + " us");
    }
    p.line(pts, series_colour(i), false, 2, shown[i]);
    legend.emplace_back(shown[i], series_colour(i));
  }
  return {p.str() + html_legend(legend, "one line per point:", "plot-timing") +
              (note.empty() ? "" : "<p>" + html_escape(note) + ".</p>\n"),
          ""};
}

/// How busy each kind of tile unit was (simulate's unit_utilization: its busy time over the
/// run, every copy counted), one bar per unit kind, for the first row that has it; the layers
/// each kind bounds listed under it.
Part units_part(const std::vector<const json*>& sel) {
  const json* r = nullptr;
  for (const json* x : sel)
    if (x->contains("unit_utilization") && (*x)["unit_utilization"].is_object() && !(*x)["unit_utilization"].empty()) {
      r = x;
      break;
    }
  if (!r) return absent("per-unit utilization of the tiles (simulate's unit_utilization)");
  const json& u = (*r)["unit_utilization"];
  std::vector<std::string> kinds;
  for (auto it = u.begin(); it != u.end(); ++it) kinds.push_back(it.key());
  // In datapath order where known.
  const std::vector<std::string> order{"shift_register", "dac", "crossbar", "adc", "accumulator"};
  std::stable_sort(kinds.begin(), kinds.end(), [&](const std::string& a, const std::string& b) {
    return std::find(order.begin(), order.end(), a) < std::find(order.begin(), order.end(), b);
  });
  std::map<std::string, int> bounds;  // layers bound by each unit (a tie counts for each)
  if (r->contains("layers") && (*r)["layers"].is_array())
    for (const auto& l : (*r)["layers"]) {
      const std::string b = text(l, "bound_by");
      size_t at = 0;
      while (!b.empty() && at <= b.size()) {
        const size_t plus = b.find('+', at);
        ++bounds[b.substr(at, plus == std::string::npos ? std::string::npos : plus - at)];
        if (plus == std::string::npos) break;
        at = plus + 1;
      }
    }
  const std::string kBar = "#4e79a7";
  PlotAxis xa{"busy share of the run, every copy counted (%)", 0, 112};
  PlotAxis ya{"", 0, 1};
  for (size_t i = kinds.size(); i-- > 0;) ya.categories.push_back(kinds[i]);  // the first on top
  SvgPlot p("plot-units", 660, 60 + 40 * static_cast<int>(kinds.size()), xa, ya, 160, 45);
  for (size_t i = 0; i < kinds.size(); ++i) {
    const double v = 100 * num(u, kinds[i].c_str()), at = static_cast<double>(kinds.size() - 1 - i);
    if (!(v >= 0)) continue;
    const int n = bounds.count(kinds[i]) ? bounds[kinds[i]] : 0;
    p.rect(0, at - 0.32, v, at + 0.32, kBar,
           kinds[i] + ": busy " + fmt_num(v) + " % of the run; bounds " + std::to_string(n) + " layer(s)");
    p.label(v, at, fmt_num(v) + " %" + (n ? " (bounds " + std::to_string(n) + ")" : ""), 5, 4);
  }
  return {"<div>" + p.str() + html_legend({{"a unit kind's busy share", kBar}}, "", "plot-units") +
              "</div>",
          ""};
}

/// Horizontal bars of one value per row, the value printed at each bar's end.
std::string value_bars(const std::vector<const json*>& rows, const char* key, const std::string& id,
                       const std::string& name) {
  double lo = INFINITY, hi = 0;
  for (const json* r : rows) {
    const double v = num(*r, key);
    if (v > 0) lo = std::min(lo, v), hi = std::max(hi, v);
  }
  if (!(hi > 0)) return "";
  const std::string kBar = "#4e79a7";
  PlotAxis xa = value_axis(name, lo, hi, true);
  xa.hi *= xa.log ? 3 : 1.12;  // room for the printed values
  PlotAxis ya{"", 0, 1};
  const std::vector<std::string> shown = names(rows);
  for (size_t i = rows.size(); i-- > 0;) ya.categories.push_back(short_label(shown[i], 40));  // the first on top
  SvgPlot p(id, 660, 60 + 40 * static_cast<int>(rows.size()), xa, ya, 260, 45);
  for (size_t i = 0; i < rows.size(); ++i) {
    const double v = num(*rows[i], key), at = static_cast<double>(rows.size() - 1 - i);
    if (!(v > 0)) continue;
    const double x0 = xa.log ? xa.lo : 0;
    p.rect(x0, at - 0.32, v, at + 0.32, kBar, text(*rows[i], "label") + "\n" + name + ": " + fmt_num(v));
    p.label(v, at, fmt_num(v), 5, 4);
  }
  return "<div>" + p.str() + html_legend({{name + ", one bar per point", kBar}}, "", id) + "</div>";
}

Part performance_part(const json& rows) {
  std::vector<const json*> r;
  for (const auto& x : rows)
    if (ok(x) && (!std::isnan(num(x, "throughput_images_per_s")) || !std::isnan(num(x, "latency_us")))) r.push_back(&x);
  if (r.empty()) return absent("throughput and latency (the platform's: simulate and explore)");
  std::string h =
      "<table><tr><th>point</th><th>throughput images/s</th><th>latency us</th><th>energy uJ/image</th>"
      "<th>" +
      std::string(kSimulatedPower) +
      "</th><th>peak power</th><th>area mm2</th><th>bottleneck (busy us/image)</th></tr>\n";
  for (const json* x : r) {
    std::string bottleneck;
    if (x->contains("bottleneck") && (*x)["bottleneck"].is_object())
      bottleneck = text((*x)["bottleneck"], "stage") + " (" + fmt_num(num((*x)["bottleneck"], "busy_us_per_image")) + ")";
    h += "<tr><td>" + html_escape(text(*x, "label")) + "</td>" + cell(num(*x, "throughput_images_per_s")) +
         cell(num(*x, "latency_us")) + cell(num(*x, "energy_uj_per_image")) + "<td>" +
         (std::isnan(num(*x, "avg_power_mw")) ? "" : power_text(num(*x, "avg_power_mw"))) + "</td><td>" +
         (std::isnan(num(*x, "peak_power_mw")) ? "" : power_text(num(*x, "peak_power_mw"))) + "</td>" +
         cell(num(*x, "area_mm2")) + "<td class=\"name\">" + html_escape(bottleneck) + "</td></tr>\n";
  }
  h += "</table>\n<div class=\"row\">" + value_bars(r, "throughput_images_per_s", "plot-throughput", "throughput (images/s)") +
       value_bars(r, "latency_us", "plot-latency", "latency of an image (us)") + "</div>\n";
  return {h, ""};
}

/// A fraction as a percentage with two decimals, as every accuracy is printed: "87.89 %", "88.10 %".
std::string percent_text(double fraction) {
  char b[32];
  std::snprintf(b, sizeof b, "%.2f %%", 100 * fraction);
  return b;
}

/// "1.7 [-0.6, 3.9]": the accuracy drop and its 95 % interval in points ("" without a drop).
std::string drop_text(const json& r) {
  const double d = num(r, "accuracy_drop");
  if (std::isnan(d)) return "";
  char b[96];
  std::snprintf(b, sizeof b, "%.2f", 100 * d);
  std::string s = b;
  const auto it = r.find("accuracy_drop_ci95");
  if (it != r.end() && it->is_array() && it->size() == 2 && (*it)[0].is_number() && (*it)[1].is_number()) {
    std::snprintf(b, sizeof b, " [%.2f, %.2f]", 100 * (*it)[0].get<double>(), 100 * (*it)[1].get<double>());
    s += b;
  }
  return s;
}

/// The full scales eval chose (ranging.*) for the first selected row, per layer: the inputs'
/// (DAC) against their largest value, the weights' clip, the ADCs' range, the bias correction.
Part ranges_part(const std::vector<const json*>& sel) {
  const json* r = nullptr;
  for (const json* s : sel)
    if (has_layers_with(*s, "weight_clip")) {
      r = s;
      break;
    }
  if (!r) return absent("ranges used (the rows carry no ranges: eval's do)");
  std::string h = "<p>";
  if (r->contains("ranging") && (*r)["ranging"].is_object()) {
    const json& g = (*r)["ranging"];
    h += "Weights: " + html_escape(text(g, "weights")) + " per " + html_escape(text(g, "weight_scale")) +
         "; inputs: " + html_escape(text(g, "inputs")) + "; ADCs: " + html_escape(text(g, "adc")) + " per " +
         html_escape(text(g, "adc_scope")) + "; bias correction " +
         (g.value("bias_correction", false) ? "on" : "off") + "; " + html_escape(text(*r, "negative")) + " mapping. ";
  }
  h += "Inputs and ADCs are ranged on the calibration images, never the test set.</p>\n"
       "<table><tr><th>layer</th><th>input full scale</th><th>largest input</th><th>inputs clipped %</th>"
       "<th>weights clipped</th><th>weight clip (of max |w|)</th><th>ADC full scale &micro;A</th>"
       "<th>ADC range (of calibration span)</th><th>output offset rms</th></tr>\n";
  for (const auto& l : (*r)["layers"]) {
    h += "<tr><td>" + html_escape(text(l, "name")) + "</td>" + cell(num(l, "input_full_scale")) +
         cell(num(l, "input_max")) + cell(num(l, "input_clipped"), 100) + cell(num(l, "clipped_weights")) +
         cell(num(l, "weight_clip")) + cell(num(l, "adc_full_scale_ua")) + cell(num(l, "adc_clip")) +
         cell(num(l, "output_offset_rms")) + "</tr>\n";
  }
  return Part{h + "</table>\n", ""};
}

Part accuracy_part(const json& rows) {
  std::string h;
  for (const auto& r : rows) {
    if (!ok(r) || std::isnan(num(r, "accuracy"))) continue;
    const double images = num(r, "images");
    h += "<p class=\"big\">" + (rows.size() > 1 ? html_escape(text(r, "label")) + ": " : std::string()) +
         "crossbars <b>" + percent_text(num(r, "accuracy")) + "</b>";
    if (!std::isnan(num(r, "software_accuracy"))) h += " against software " + percent_text(num(r, "software_accuracy"));
    if (images > 0) h += " on " + count_text(std::llround(images), "image");
    const std::string d = drop_text(r);
    if (!d.empty()) h += ": a drop of " + d + " points (95 % interval)";
    if (!std::isnan(num(r, "mean_relative_error")))
      h += "; mean per-layer relative error " + fmt_num(100 * num(r, "mean_relative_error")) + " %";
    h += "</p>\n";
  }
  if (h.empty()) return absent("accuracy (eval, explore, and simulate with a dataset)");
  return {h, ""};
}

/// The rows' warnings counted by kind, the first example of each.
Part warnings_part(const json& rows) {
  std::vector<std::pair<std::string, std::pair<int, std::string>>> kinds;  // kind -> count, first example
  for (const auto& r : rows) {
    if (!r.is_object()) continue;
    const auto it = r.find("warnings");
    if (it == r.end() || !it->is_array()) continue;
    for (const auto& w : *it) {
      if (!w.is_string()) continue;
      const std::string k = warning_kind(w.get<std::string>());
      auto f = std::find_if(kinds.begin(), kinds.end(), [&](const auto& x) { return x.first == k; });
      if (f == kinds.end())
        kinds.push_back({k, {1, text(r, "label") + ": " + w.get<std::string>()}});
      else
        ++f->second.first;
    }
  }
  if (kinds.empty()) return absent("");
  std::string h = "<ul>\n";
  for (const auto& k : kinds)
    h += "<li>" + std::to_string(k.second.first) + " &times; " + html_escape(k.first) + "<br><small>first: " +
         html_escape(k.second.second) + "</small></li>\n";
  return {h + "</ul>\n", ""};
}

std::string rows_table(const json& rows) {
  auto any = [&](const char* k) {
    return std::any_of(rows.begin(), rows.end(), [&](const json& r) { return !std::isnan(num(r, k)); });
  };
  struct Col {
    const char* key;
    std::string head;
    double scale;
  };
  std::vector<Col> cols;
  for (const Col& c : {Col{"accuracy", "accuracy %", 100}, Col{"mean_relative_error", "mean error %", 100},
                       Col{"worst_relative_error", "worst error %", 100},
                       Col{"energy_uj_per_image", "energy uJ/image", 1}, Col{"area_mm2", "area mm2", 1},
                       Col{"latency_us", "latency us", 1}, Col{"throughput_images_per_s", "throughput images/s", 1},
                       Col{"avg_power_mw", kSimulatedPower, 1}, Col{"ideal_avg_power_mw", kIdealPower, 1}})
    if (any(c.key)) cols.push_back(c);
  const bool drops = any("accuracy_drop"), fronts = std::any_of(rows.begin(), rows.end(), on_front);
  std::string s = "<table><tr><th>point</th><th>status</th>";
  for (const Col& c : cols) {
    s += "<th>" + c.head + "</th>";
    if (std::string(c.key) == "accuracy" && drops) s += "<th>drop, points [95 % interval]</th>";
  }
  s += std::string(fronts ? "<th>front</th>" : "") + "</tr>\n";
  for (const auto& r : rows) {
    s += "<tr><td class=\"name\">" + html_escape(text(r, "label")) + "</td><td>" +
         html_escape(ok(r) ? std::string("ok") : "failed: " + text(r, "reason")) + "</td>";
    for (const Col& c : cols) {
      if (std::string(c.key) == "avg_power_mw" || std::string(c.key) == "ideal_avg_power_mw")
        s += "<td>" + (std::isnan(num(r, c.key)) ? std::string() : power_text(num(r, c.key))) + "</td>";
      else
        s += cell(num(r, c.key), c.scale);
      if (std::string(c.key) == "accuracy" && drops) s += "<td>" + html_escape(drop_text(r)) + "</td>";
    }
    s += std::string(fronts ? std::string("<td>") + (on_front(r) ? "&#9733;" : "") + "</td>" : "") + "</tr>\n";
  }
  return s + "</table>\n";
}

}  // namespace

std::string render_html_report(const ReportInput& in) {
  // The rows, front points numbered as in the key (front_number), so every plot names them alike.
  json rows = in.rows.is_array() ? in.rows : json::array();
  {
    const std::vector<const json*> f = front_rows(rows);
    for (size_t i = 0; i < f.size(); ++i) const_cast<json&>(*f[i])["front_number"] = i + 1;
  }
  ReportInput input = in;
  if (input.color_key.empty() && !input.swept_keys.empty()) input.color_key = input.swept_keys[0];
  int n_ok = 0, n_failed = 0;
  for (const auto& r : rows) ok(r) ? ++n_ok : ++n_failed;
  const std::vector<const json*> sel = selected(rows);
  std::string h =
      "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>" + html_escape(in.title) +
      "</title>\n<style>body{font-family:sans-serif;max-width:1360px;margin:16px auto;padding:0 12px;color:#222;"
      "background:#fff}h1{font-size:22px}h2{font-size:17px;margin-top:28px;border-bottom:1px solid #ccc}"
      ".missing{color:#666;font-style:italic}.row{display:flex;gap:16px;align-items:flex-start;flex-wrap:wrap}"
      ".grid{display:flex;flex-wrap:wrap;gap:8px}svg.plot{display:block}.big{font-size:16px}"
      ".legend{font-size:12px;margin:2px 0 8px 70px}.legend span{margin-right:14px;display:inline-block}"
      ".legend i{display:inline-block;width:11px;height:11px;margin-right:5px;vertical-align:-1px}"
      "th.name{text-align:left}"
      "table{border-collapse:collapse;font-size:12px}td,th{border:1px solid #ddd;padding:3px 6px;text-align:right}"
      "td:first-child,th:first-child,td.name{text-align:left}.key{max-width:540px}"
      "pre{background:#f6f6f6;padding:8px;font-size:12px;overflow:auto}"
      "</style></head><body>\n<h1>" + html_escape(in.title) + "</h1>\n<p>xbarsim " + html_escape(in.command) + ": " +
      std::to_string(rows.size()) + " point(s), " + std::to_string(n_ok) + " ok, " + std::to_string(n_failed) + " failed";
  if (!in.swept_keys.empty()) {
    std::string keys;
    for (const auto& k : in.swept_keys) keys += (keys.empty() ? "" : ", ") + k;
    h += "; swept: " + html_escape(keys);
  }
  h += ". Hover over a mark for its values.</p>\n";
  // What the command measures first, then the rest; what cannot be shown is named at the end.
  std::vector<std::pair<std::string, std::function<Part()>>> sections;
  const auto front = [&] { return front_part(rows, input); };
  const auto table = [&] { return Part{rows_table(rows), ""}; };
  const auto accuracy = [&] { return accuracy_part(rows); };
  const auto layers = [&] { return layers_plot(sel, candidates(rows)); };
  const auto adc = [&] { return bits_plot(rows, "adc_bits", "plot-bits", "ADC bits", input); };
  const auto dac = [&] { return bits_plot(rows, "dac_bits", "plot-dac-bits", "DAC bits", input); };
  const auto performance = [&] { return performance_part(rows); };
  const auto timing = [&] { return timing_plot(sel); };
  const auto units = [&] { return units_part(sel); };
  const auto energy = [&] { return breakdown_plot(sel, true); };
  const auto area = [&] { return breakdown_plot(sel, false); };
  const auto ranges = [&] { return ranges_part(sel); };
  if (in.command == "explore") {
    sections = {{"Pareto front", front},
                {"All points", table},
                {"Per-layer error of the front", layers},
                {"Accuracy vs ADC bits", adc},
                {"Accuracy vs DAC bits", dac},
                {"Energy by component", energy},
                {"Area by component", area},
                {"Per-stage time on the platform", timing}};
  } else if (in.command == "simulate") {
    sections = {{"Throughput, latency and the bottleneck", performance},
                {"Per-stage time on the platform", timing},
                {"Utilization of the tiles' units", units},
                {"Energy by component", energy},
                {"Area by component", area},
                {"Accuracy", accuracy},
                {"Per-layer error propagation", layers},
                {"Ranges used", ranges},
                {"All points", table},
                {"Pareto front", front}};
  } else if (in.command == "eval") {
    sections = {{"Accuracy", accuracy},           {"Per-layer error propagation", layers},
                {"Ranges used", ranges},          {"Accuracy vs ADC bits", adc},
                {"Accuracy vs DAC bits", dac},
                {"Energy by component", energy},  {"Area by component", area},
                {"All points", table},            {"Throughput and latency", performance},
                {"Pareto front", front}};
  } else {
    sections = {{"All points", table},      {"Error vs ADC bits", adc}, {"Error vs DAC bits", dac},
                {"Per-layer error propagation", layers}, {"Energy by component", energy},
                {"Area by component", area}};
  }
  std::vector<std::string> not_shown;
  for (const auto& s : sections) {
    const Part p = s.second();
    if (!p.html.empty())
      h += "<h2>" + html_escape(s.first) + "</h2>\n" + p.html;
    else if (!p.absent.empty())
      not_shown.push_back(p.absent);
  }
  const Part w = warnings_part(rows);
  if (!w.html.empty()) h += "<h2>Warnings</h2>\n" + w.html;
  h += "<h2>Configuration</h2>\n<pre>" + html_escape(in.config_yaml) + "</pre>\n";
  if (!not_shown.empty()) {
    std::string list;
    for (const auto& n : not_shown) list += (list.empty() ? "" : "; ") + n;
    h += "<p class=\"missing\" id=\"not-shown\">Not in this report: " + html_escape(list) + ".</p>\n";
  }
  // Where each plot, each point tag and each tick label lies on the page (read by the browser test).
  h += "<pre id=\"layout\" hidden></pre>\n<script>window.addEventListener('load',function(){var o='';"
       "function box(k,r){o+=k+' '+Math.round(r.left+window.scrollX)+' '+Math.round(r.top+window.scrollY)+' '+"
       "Math.round(r.width)+' '+Math.round(r.height)+'\\n';}"
       "document.querySelectorAll('svg.plot').forEach(function(s){box(s.id,s.getBoundingClientRect());"
       "s.querySelectorAll('g.tag text').forEach(function(t,i){box('tag:'+s.id+':'+i,t.getBoundingClientRect());});"
       "['xtick','ytick'].forEach(function(a){s.querySelectorAll('g.'+a+'s text').forEach(function(t,i){"
       "box(a+':'+s.id+':'+i,t.getBoundingClientRect());});});});"
       "document.getElementById('layout').textContent=o;});</script>\n";
  return h + "</body></html>\n";
}

std::string warning_kind(const std::string& text) {
  std::string s = text;
  if (s.rfind("layer ", 0) == 0) {
    const size_t colon = s.find(": ");
    if (colon != std::string::npos) s = s.substr(colon + 2);
  }
  s = s.substr(0, s.find(';'));
  std::string out;
  for (size_t i = 0; i < s.size(); ++i) {
    const bool sign = (s[i] == '-' || s[i] == '+') && i + 1 < s.size() && std::isdigit(static_cast<unsigned char>(s[i + 1]));
    if (sign) ++i;  // "-3" and "3" are one kind
    if (std::isdigit(static_cast<unsigned char>(s[i]))) {
      while (i + 1 < s.size() && (std::isdigit(static_cast<unsigned char>(s[i + 1])) || s[i + 1] == '.')) ++i;
      out += '#';
    } else {
      out += s[i];
    }
  }
  return out;
}

std::string power_text(double mw) {
  char b[48];
  const double w = mw / 1e3;
  if (std::abs(w) >= 999.995)
    std::snprintf(b, sizeof b, "%.0f W", w);
  else if (std::abs(w) >= 10)
    std::snprintf(b, sizeof b, "%.2f W", w);
  else
    std::snprintf(b, sizeof b, "%.2f mW", mw);
  return b;
}

void write_html_report(const std::string& path, const ReportInput& in) { write_text_file(path, render_html_report(in)); }

}  // namespace xbarsim
