#include "sw/report/html_report.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>

#include "sw/common/output_file.h"
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
/// "/layer1/layer1.0/conv1/Conv" -> "layer1.0/conv1".
std::string short_layer(std::string s) {
  for (const char* suffix : {"/Conv", "/Gemm", "/MatMul"})
    if (s.size() > std::strlen(suffix) && s.compare(s.size() - std::strlen(suffix), std::string::npos, suffix) == 0)
      s.erase(s.size() - std::strlen(suffix));
  const size_t a = s.rfind('/');
  if (a != std::string::npos && a > 0) {
    const size_t b = s.rfind('/', a - 1);
    s = s.substr(b == std::string::npos ? 0 : b + 1);
  }
  if (!s.empty() && s[0] == '/') s.erase(0, 1);
  return s;
}

/// The y metric of the scatter and the bits plots: accuracy (%) when any row has it, else
/// the mean relative error (%).
struct Metric {
  const char* key;
  std::string name;
};
Metric y_metric(const json& rows) {
  for (const auto& r : rows)
    if (ok(r) && !std::isnan(num(r, "accuracy"))) return {"accuracy", "accuracy (%)"};
  return {"mean_relative_error", "mean relative error (%)"};
}

std::string tooltip(const json& r) {
  std::string t = text(r, "label");
  for (const auto& f : {std::make_pair("accuracy", "accuracy %"), std::make_pair("mean_relative_error", "mean error %")})
    if (!std::isnan(num(r, f.first))) t += "\n" + std::string(f.second) + " " + fmt_num(100 * num(r, f.first));
  for (const auto& f : {std::make_pair("energy_uj_per_image", "energy uJ/image"), std::make_pair("area_mm2", "area mm2"),
                        std::make_pair("latency_us", "latency us"), std::make_pair("avg_power_mw", "power mW")})
    if (!std::isnan(num(r, f.first))) t += "\n" + std::string(f.second) + " " + fmt_num(num(r, f.first));
  if (on_front(r)) t += "\non the Pareto front";
  return t;
}

std::string missing(const std::string& why) { return "<p class=\"missing\">" + html_escape(why) + "</p>\n"; }

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

std::string pareto_plot(const json& rows, const std::string& color_key) {
  const Metric m = y_metric(rows);
  std::vector<const json*> pts;
  double xlo = INFINITY, xhi = -INFINITY, ylo = INFINITY, yhi = -INFINITY;
  for (const auto& r : rows) {
    const double x = num(r, "energy_uj_per_image"), y = 100 * num(r, m.key);
    if (!ok(r) || std::isnan(x) || std::isnan(y) || x <= 0) continue;
    pts.push_back(&r);
    xlo = std::min(xlo, x), xhi = std::max(xhi, x), ylo = std::min(ylo, y), yhi = std::max(yhi, y);
  }
  if (pts.empty()) return missing("No Pareto scatter: no row has both an energy per image and " + m.name + ".");
  const bool log = xhi / xlo > 20;
  PlotAxis xa{"energy per image (uJ)" + std::string(log ? ", log scale" : ""), log ? xlo / 1.3 : xlo - 0.05 * (xhi - xlo),
              log ? xhi * 1.3 : xhi + 0.05 * (xhi - xlo), log};
  const double pad = std::max(0.05 * (yhi - ylo), 0.2);
  PlotAxis ya{m.name, ylo - pad, yhi + pad};
  const Colouring col = colouring(rows, color_key);
  SvgPlot p("plot-pareto", 1100, 460, xa, ya, 70, 50, col.legend.empty() ? 0 : 190);
  std::vector<std::pair<double, double>> front;
  for (const json* r : pts) {
    const bool f = on_front(*r);
    const double x = num(*r, "energy_uj_per_image"), y = 100 * num(*r, m.key);
    p.circle(x, y, f ? 8 : 5.5, col.of(*r, color_key), tooltip(*r), f);
    if (f) front.emplace_back(x, y);
  }
  std::sort(front.begin(), front.end());
  if (front.size() > 1) p.line(front, "#555", true, 1.5, "Pareto front (projection on energy and " + m.name + ")");
  size_t labelled = 0;
  for (const json* r : pts)
    if (on_front(*r) && labelled++ < 12)
      p.label(num(*r, "energy_uj_per_image"), 100 * num(*r, m.key), short_label(text(*r, "label"), 40));
  if (!col.legend.empty()) p.legend(col.legend, short_label(color_key, 24));
  return p.str();
}

std::string bits_plot(const json& rows, const char* key, const std::string& id, const std::string& name) {
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
  if (pts.empty()) return missing("No " + name + " plot: no row has " + key + " and " + m.name + ".");
  const double xhi = none ? none_x : maxbits;
  PlotAxis xa{name, xlo - 0.7, xhi + 0.7};
  for (double b = std::floor(xlo); b <= maxbits; ++b) xa.ticks.emplace_back(b, fmt_num(b));
  if (none) xa.ticks.emplace_back(none_x, "none");
  const double pad = std::max(0.05 * (yhi - ylo), 0.2);
  SvgPlot p(id, 545, 330, xa, {m.name, ylo - pad, yhi + pad});
  std::map<double, double> best;
  const bool lower_better = std::string(m.key) != "accuracy";
  for (size_t i = 0; i < pts.size(); ++i) {
    p.circle(pts[i].first, pts[i].second, 5, palette(0), tooltip(*src[i]));
    auto it = best.find(pts[i].first);
    if (it == best.end())
      best[pts[i].first] = pts[i].second;
    else
      it->second = lower_better ? std::min(it->second, pts[i].second) : std::max(it->second, pts[i].second);
  }
  std::vector<std::pair<double, double>> line(best.begin(), best.end());
  p.line(line, palette(1), false, 2, "best per bit width");
  return p.str();
}

/// The rows the per-layer and breakdown plots show: the front (or every ok row), most
/// accurate (or least error) first, at most 8.
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
  if (s.size() > 8) s.resize(8);
  return s;
}

std::string layers_plot(const std::vector<const json*>& sel) {
  std::vector<const json*> rows;
  for (const json* r : sel)
    if (r->contains("layers") && (*r)["layers"].is_array() && !(*r)["layers"].empty() &&
        (*r)["layers"][0].contains("mean_relative_error"))
      rows.push_back(r);
  if (rows.empty()) return missing("No per-layer error propagation: the rows carry no per-layer errors (eval and explore do).");
  std::vector<std::string> names;
  double yhi = 0;
  for (const auto& l : (*rows[0])["layers"]) names.push_back(short_layer(text(l, "name")));
  for (const json* r : rows)
    for (const auto& l : (*r)["layers"]) {
      const double w = num(l, "worst_relative_error");
      yhi = std::max(yhi, 100 * (std::isnan(w) ? num(l, "mean_relative_error") : w));
    }
  PlotAxis xa{"layer (in network order)", 0, 1};
  xa.categories = names;
  xa.rotate_labels = -40;
  SvgPlot p("plot-layers", 1100, 430, xa, {"relative error (%): mean solid, worst dashed", 0, yhi * 1.05 + 1e-9}, 70,
            120, 230);
  std::vector<std::pair<std::string, std::string>> legend;
  for (size_t i = 0; i < rows.size(); ++i) {
    std::vector<std::pair<double, double>> mean, worst;
    const json& L = (*rows[i])["layers"];
    for (size_t k = 0; k < L.size() && k < names.size(); ++k) {
      const double a = num(L[k], "mean_relative_error"), b = num(L[k], "worst_relative_error");
      if (!std::isnan(a)) mean.emplace_back(static_cast<double>(k), 100 * a);
      if (!std::isnan(b)) worst.emplace_back(static_cast<double>(k), 100 * b);
    }
    const std::string label = text(*rows[i], "label");
    p.line(mean, palette(i), false, 2.5, label + ": mean");
    p.line(worst, palette(i), true, 1.5, label + ": worst");
    for (const auto& xy : mean)
      p.circle(xy.first, xy.second, 3, palette(i), label + "\n" + names[static_cast<size_t>(xy.first)] + " mean " + fmt_num(xy.second) + " %");
    legend.emplace_back(short_label(label, 30), palette(i));
  }
  p.legend(legend, "design point");
  return p.str();
}

const std::vector<std::string>& components() {
  static const std::vector<std::string> c{"crossbar", "adc",    "dac",          "accumulator", "shift_register",
                                          "buffer",   "interconnect", "digital", "memory"};
  return c;
}

std::string breakdown_plot(const std::vector<const json*>& sel, bool power) {
  const char* key = power ? "energy_breakdown_uj" : "area_breakdown_mm2";
  std::vector<const json*> rows;
  for (const json* r : sel)
    if (r->contains(key) && (*r)[key].is_object() && (!power || num(*r, "time_ns_per_image") > 0)) rows.push_back(r);
  if (rows.empty())
    return missing(power ? "No power breakdown: the rows carry no energy breakdown with a time per image."
                         : "No area breakdown: the rows carry no area breakdown.");
  std::vector<std::string> names;
  double xhi = 0;
  for (const json* r : rows) {
    names.push_back(short_label(text(*r, "label"), 30));
    double total = 0;
    for (const auto& c : components()) {
      double v = num((*r)[key], c.c_str());
      if (std::isnan(v)) continue;
      if (power) v *= 1e6 / num(*r, "time_ns_per_image");
      total += v;
    }
    xhi = std::max(xhi, total);
  }
  PlotAxis ya{"", 0, 1};
  ya.categories = names;
  const int h = 70 + 34 * static_cast<int>(rows.size());
  const int legend_h = 60 + 18 * static_cast<int>(components().size() + 1);
  SvgPlot p(power ? "plot-power" : "plot-area", 1100, std::max(h, legend_h),
            {power ? "average power by component (mW)" : "area by component (mm2)", 0, xhi * 1.05 + 1e-12}, ya, 230, 45,
            150);
  std::vector<std::pair<std::string, std::string>> legend;
  for (size_t c = 0; c < components().size(); ++c) legend.emplace_back(components()[c], palette(c));
  for (size_t i = 0; i < rows.size(); ++i) {
    double x = 0;
    for (size_t c = 0; c < components().size(); ++c) {
      double v = num((*rows[i])[key], components()[c].c_str());
      if (std::isnan(v) || v <= 0) continue;
      if (power) v *= 1e6 / num(*rows[i], "time_ns_per_image");
      p.rect(x, i - 0.35, x + v, i + 0.35, palette(c),
             text(*rows[i], "label") + "\n" + components()[c] + ": " + fmt_num(v) + (power ? " mW" : " mm2"));
      x += v;
    }
  }
  p.legend(legend, "component");
  return p.str();
}

std::string timing_plot(const std::vector<const json*>& sel) {
  const json* row = nullptr;
  for (const json* r : sel)
    if (!row && r->contains("layers") && (*r)["layers"].is_array() && !(*r)["layers"].empty() &&
        (*r)["layers"][0].contains("busy_us"))
      row = r;
  if (!row) return missing("No per-layer timing: the platform's busy and stall times come from simulate and explore.");
  const json& L = (*row)["layers"];
  std::vector<std::string> names;
  double yhi = 0;
  for (const auto& l : L) {
    names.push_back(short_layer(text(l, "name")));
    const double b = num(l, "busy_us"), s = num(l, "stall_us");
    yhi = std::max(yhi, (std::isnan(b) ? 0 : b) + (std::isnan(s) ? 0 : s));
  }
  PlotAxis xa{"layer of " + short_label(text(*row, "label"), 60), 0, 1};
  xa.categories = names;
  xa.rotate_labels = -40;
  SvgPlot p("plot-timing", 1100, 430, xa, {"time per image (us)", 0, yhi * 1.05 + 1e-12}, 70, 120, 150);
  for (size_t k = 0; k < L.size(); ++k) {
    const double b = std::max(0.0, std::isnan(num(L[k], "busy_us")) ? 0.0 : num(L[k], "busy_us"));
    const double s = std::max(0.0, std::isnan(num(L[k], "stall_us")) ? 0.0 : num(L[k], "stall_us"));
    const std::string t = names[k] + "\nbusy " + fmt_num(b) + " us, stall " + fmt_num(s) + " us, latency " + fmt_num(b + s) + " us";
    p.rect(k - 0.38, 0, k + 0.38, b, palette(0), t);
    if (s > 0) p.rect(k - 0.38, b, k + 0.38, b + s, palette(1), t);
  }
  p.legend({{"busy", palette(0)}, {"stall", palette(1)}}, "latency = busy + stall");
  return p.str();
}

/// "1.7 [-0.6, 3.9]": the accuracy drop and its 95 % interval in points ("" without a drop).
std::string drop_text(const json& r) {
  const double d = num(r, "accuracy_drop");
  if (std::isnan(d)) return "";
  std::string s = fmt_num(100 * d);
  const auto it = r.find("accuracy_drop_ci95");
  if (it != r.end() && it->is_array() && it->size() == 2 && (*it)[0].is_number() && (*it)[1].is_number())
    s += " [" + fmt_num(100 * (*it)[0].get<double>()) + ", " + fmt_num(100 * (*it)[1].get<double>()) + "]";
  return s;
}

/// The rows' warnings (eval: layers whose conversion clipped many cells), one item each.
std::string warnings_list(const json& rows) {
  std::string s;
  for (const auto& r : rows) {
    if (!r.is_object()) continue;
    const auto it = r.find("warnings");
    if (it == r.end() || !it->is_array()) continue;
    for (const auto& w : *it)
      if (w.is_string()) s += "<li>" + html_escape(text(r, "label")) + ": " + html_escape(w.get<std::string>()) + "</li>\n";
  }
  return s.empty() ? "" : "<h2>Warnings</h2>\n<ul>\n" + s + "</ul>\n";
}

std::string rows_table(const json& rows) {
  std::string s =
      "<table><tr><th>point</th><th>status</th><th>accuracy %</th><th>drop, points [95 % interval]</th>"
      "<th>mean error %</th><th>worst error %</th>"
      "<th>energy uJ/image</th><th>area mm2</th><th>latency us</th><th>power mW</th><th>front</th></tr>\n";
  auto cell = [](double v, double scale = 1) { return "<td>" + (std::isnan(v) ? std::string("") : fmt_num(v * scale)) + "</td>"; };
  for (const auto& r : rows) {
    s += "<tr><td>" + html_escape(text(r, "label")) + "</td><td>" +
         html_escape(ok(r) ? std::string("ok") : "failed: " + text(r, "reason")) + "</td>" + cell(num(r, "accuracy"), 100) +
         "<td>" + html_escape(drop_text(r)) + "</td>" +
         cell(num(r, "mean_relative_error"), 100) + cell(num(r, "worst_relative_error"), 100) +
         cell(num(r, "energy_uj_per_image")) + cell(num(r, "area_mm2")) + cell(num(r, "latency_us")) +
         cell(num(r, "avg_power_mw")) + "<td>" + (on_front(r) ? "&#9733;" : "") + "</td></tr>\n";
  }
  return s + "</table>\n";
}

}  // namespace

std::string render_html_report(const ReportInput& in) {
  const json& rows = in.rows.is_array() ? in.rows : json::array();
  std::string color = in.color_key;
  if (color.empty() && !in.swept_keys.empty()) color = in.swept_keys[0];
  int n_ok = 0, n_failed = 0, n_front = 0;
  for (const auto& r : rows) {
    ok(r) ? ++n_ok : ++n_failed;
    n_front += on_front(r);
  }
  std::string objectives;
  for (const auto& o : in.objectives) objectives += (objectives.empty() ? "" : ", ") + o;
  const std::vector<const json*> sel = selected(rows);
  std::string h =
      "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>" + html_escape(in.title) +
      "</title>\n<style>body{font-family:sans-serif;max-width:1140px;margin:16px auto;color:#222;background:#fff}"
      "h1{font-size:22px}h2{font-size:17px;margin-top:28px;border-bottom:1px solid #ccc}"
      ".missing{color:#777;font-style:italic}.row{display:flex;gap:10px}svg.plot{display:block}"
      "table{border-collapse:collapse;font-size:12px}td,th{border:1px solid #ddd;padding:3px 6px;text-align:right}"
      "td:first-child,th:first-child{text-align:left}pre{background:#f6f6f6;padding:8px;font-size:12px;overflow:auto}"
      "</style></head><body>\n<h1>" + html_escape(in.title) + "</h1>\n<p>xbarsim " + html_escape(in.command) + ": " +
      std::to_string(rows.size()) + " row(s), " + std::to_string(n_ok) + " ok, " + std::to_string(n_failed) + " failed";
  if (!objectives.empty())
    h += "; Pareto front over " + html_escape(objectives) + ": " + std::to_string(n_front) + " point(s), drawn large with a dark outline";
  if (!in.swept_keys.empty()) {
    std::string keys;
    for (const auto& k : in.swept_keys) keys += (keys.empty() ? "" : ", ") + k;
    h += "; swept: " + html_escape(keys);
  }
  h += ". Hover over a mark for its values.</p>\n";
  h += "<h2>Accuracy vs energy (Pareto)</h2>\n" + pareto_plot(rows, color);
  h += "<h2>Accuracy vs converter bits</h2>\n<div class=\"row\">" +
       bits_plot(rows, "adc_bits", "plot-bits", "ADC bits") + bits_plot(rows, "dac_bits", "plot-dac-bits", "DAC bits") +
       "</div>\n";
  h += "<h2>Per-layer error propagation</h2>\n" + layers_plot(sel);
  h += "<h2>Power by component</h2>\n" + breakdown_plot(sel, true);
  h += "<h2>Area by component</h2>\n" + breakdown_plot(sel, false);
  h += "<h2>Per-layer latency, busy and stall (platform)</h2>\n" + timing_plot(sel);
  h += "<h2>All points</h2>\n" + rows_table(rows) + warnings_list(rows);
  h += "<h2>Configuration</h2>\n<pre>" + html_escape(in.config_yaml) + "</pre>\n";
  // Where each plot lies on the page (read by the browser test; harmless elsewhere).
  h += "<pre id=\"layout\" hidden></pre>\n<script>window.addEventListener('load',function(){var o='';"
       "document.querySelectorAll('svg.plot').forEach(function(s){var r=s.getBoundingClientRect();"
       "o+=s.id+' '+Math.round(r.left+window.scrollX)+' '+Math.round(r.top+window.scrollY)+' '+Math.round(r.width)+' '+"
       "Math.round(r.height)+'\\n';});document.getElementById('layout').textContent=o;});</script>\n";
  return h + "</body></html>\n";
}

void write_html_report(const std::string& path, const ReportInput& in) { write_text_file(path, render_html_report(in)); }

}  // namespace xbarsim
