#include "sw/report/svg_plot.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "sw/common/quantity_text.h"

namespace xbarsim {

std::string html_escape(const std::string& s) {
  std::string o;
  o.reserve(s.size());
  for (char c : s) switch (c) {
      case '&': o += "&amp;"; break;
      case '<': o += "&lt;"; break;
      case '>': o += "&gt;"; break;
      case '"': o += "&quot;"; break;
      case '\'': o += "&#39;"; break;
      default: o += c;
    }
  return o;
}

std::string fmt_num(double v) { return compact_number(v, 4); }

std::vector<std::string> tick_texts(const std::vector<double>& values) {
  std::vector<std::string> t;
  for (int digits = 4; digits <= 15; ++digits) {
    t.clear();
    for (double v : values) t.push_back(compact_number(v, digits));
    std::vector<std::string> sorted = t;
    std::sort(sorted.begin(), sorted.end());
    if (std::adjacent_find(sorted.begin(), sorted.end()) == sorted.end()) break;
  }
  return t;
}

const std::string& series_colour(size_t i) {
  // Darker tones than palette()'s, none of them one of its colours.
  static const std::vector<std::string> p{"#393b79", "#8c6d31", "#843c39", "#637939",
                                          "#7b4173", "#d6616b", "#6b6ecf", "#bd9e39"};
  return p[i % p.size()];
}

const std::string& palette(size_t i) {
  static const std::vector<std::string> p{"#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#17becf",
                                          "#e377c2", "#8c564b", "#bcbd22", "#3b3eac", "#e6550d", "#31a354"};
  return p[i % p.size()];
}

namespace {

/// About `n` round tick values covering [lo, hi].
std::vector<double> nice_ticks(double lo, double hi, int n) {
  if (!(hi > lo)) return {lo};
  const double raw = (hi - lo) / n, mag = std::pow(10.0, std::floor(std::log10(raw)));
  const double step = mag * (raw / mag < 1.5 ? 1 : raw / mag < 3 ? 2 : raw / mag < 7 ? 5 : 10);
  std::vector<double> t;
  for (double v = std::ceil(lo / step - 1e-9) * step; v <= hi + 1e-9 * step; v += step)
    t.push_back(std::abs(v) < step * 1e-9 ? 0.0 : v);
  return t;
}

std::string num_attr(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%.1f", v);
  return b;
}

}  // namespace

SvgPlot::SvgPlot(std::string id, int width, int height, PlotAxis x, PlotAxis y, int margin_left, int margin_bottom,
                 int legend_width)
    : id_(std::move(id)), w_(width), h_(height), ml_(margin_left), mb_(margin_bottom), lw_(legend_width),
      x_(std::move(x)), y_(std::move(y)) {
  // A categorical axis makes room for its labels, whole: below the plot (turned upright when
  // the categories are close), or at its left.
  auto longest = [](const PlotAxis& a) {
    size_t n = 0;
    for (const auto& c : a.categories) n = std::max(n, c.size());
    return static_cast<double>(n);
  };
  if (!x_.categories.empty()) {
    const double room = (w_ - 20 - lw_ - ml_) / static_cast<double>(x_.categories.size());
    if (x_.rotate_labels && room < 40) x_.rotate_labels = -90;
    const double angle = x_.rotate_labels * 3.14159265358979 / 180;
    const int need = static_cast<int>(
        std::ceil(14 + kCharWidthPx * longest(x_) * std::abs(std::sin(angle)) + 11 * std::abs(std::cos(angle)) + 26));
    if (need > mb_) {
      h_ += need - mb_;
      mb_ = need;
    }
  }
  if (!y_.categories.empty()) ml_ = std::max(ml_, static_cast<int>(std::ceil(12 + kCharWidthPx * longest(y_))));
  for (PlotAxis* a : {&x_, &y_}) {
    if (!a->categories.empty()) {
      a->lo = -0.5;
      a->hi = a->categories.size() - 0.5;
      a->log = false;
    } else if (a->log) {
      a->lo = std::max(a->lo, 1e-300);
      a->hi = std::max(a->hi, a->lo * 1.0001);
    } else if (!(a->hi > a->lo)) {
      const double pad = a->lo == 0 ? 1 : std::abs(a->lo) * 0.1;
      a->lo -= pad;
      a->hi += pad;
    }
  }
}

double SvgPlot::px(double x) const {
  const double l = ml_, r = w_ - 20 - lw_;
  const double f = x_.log ? (std::log(x) - std::log(x_.lo)) / (std::log(x_.hi) - std::log(x_.lo))
                          : (x - x_.lo) / (x_.hi - x_.lo);
  return l + f * (r - l);
}

double SvgPlot::py(double y) const {
  const double t = 20, b = h_ - mb_;
  const double f = y_.log ? (std::log(y) - std::log(y_.lo)) / (std::log(y_.hi) - std::log(y_.lo))
                          : (y - y_.lo) / (y_.hi - y_.lo);
  return b - f * (b - t);
}

void SvgPlot::circle(double x, double y, double r, const std::string& fill, const std::string& title, bool outline) {
  mark_px_.push_back({{px(x), py(y)}, r});
  marks_ += "<circle cx=\"" + num_attr(px(x)) + "\" cy=\"" + num_attr(py(y)) + "\" r=\"" + fmt_num(r) + "\" fill=\"" +
            fill + "\"" + (outline ? " stroke=\"#111\" stroke-width=\"2\"" : " fill-opacity=\"0.85\"") + "><title>" +
            html_escape(title) + "</title></circle>\n";
}

void SvgPlot::line(const std::vector<std::pair<double, double>>& pts, const std::string& color, bool dashed,
                   double width, const std::string& title) {
  if (pts.empty()) return;
  std::string p;
  for (const auto& xy : pts) p += num_attr(px(xy.first)) + "," + num_attr(py(xy.second)) + " ";
  marks_ += "<polyline fill=\"none\" stroke=\"" + color + "\" stroke-width=\"" + fmt_num(width) + "\"" +
            (dashed ? " stroke-dasharray=\"6 4\"" : "") + " points=\"" + p + "\">" +
            (title.empty() ? "" : "<title>" + html_escape(title) + "</title>") + "</polyline>\n";
}

void SvgPlot::rect(double x0, double y0, double x1, double y1, const std::string& fill, const std::string& title) {
  const double a = std::min(px(x0), px(x1)), b = std::max(px(x0), px(x1));
  const double c = std::min(py(y0), py(y1)), d = std::max(py(y0), py(y1));
  marks_ += "<rect x=\"" + num_attr(a) + "\" y=\"" + num_attr(c) + "\" width=\"" + num_attr(b - a) + "\" height=\"" +
            num_attr(d - c) + "\" fill=\"" + fill + "\"><title>" + html_escape(title) + "</title></rect>\n";
}

void SvgPlot::label(double x, double y, const std::string& text, int dx, int dy) {
  labels_ += "<text x=\"" + num_attr(px(x) + dx) + "\" y=\"" + num_attr(py(y) + dy) +
             "\" font-size=\"11\" fill=\"#222\">" + html_escape(text) + "</text>\n";
}

void SvgPlot::tag(double x, double y, double r, const std::string& text) {
  const double cx = px(x), cy = py(y);
  // Box size from the text: bold 12 px digits and letters are at most ~8.5 px wide.
  const double w = 9.0 * static_cast<double>(text.size()) + 8, h = 17;
  const double left = ml_, right = w_ - 20 - lw_, top = 20, bottom = h_ - mb_;
  auto hits = [](const Box& a, const Box& b) {
    return a.x0 < b.x1 + 1 && b.x0 < a.x1 + 1 && a.y0 < b.y1 + 1 && b.y0 < a.y1 + 1;
  };
  auto covers_mark = [&](const Box& b) {
    for (const auto& m : mark_px_) {
      const double nx = std::clamp(m.first.first, b.x0, b.x1), ny = std::clamp(m.first.second, b.y0, b.y1);
      if (std::hypot(nx - m.first.first, ny - m.first.second) < m.second) return true;
    }
    return false;
  };
  const double rings[] = {r + 2, r + 14, r + 28, r + 46, r + 70, r + 100, r + 140};
  // Directions (unit vectors): right, left, up, down, then the diagonals.
  const double dirs[][2] = {{1, 0}, {-1, 0}, {0, -1}, {0, 1}, {0.7, -0.7}, {-0.7, -0.7}, {0.7, 0.7}, {-0.7, 0.7}};
  Box best{0, 0, 0, 0};
  bool found = false, leader = false;
  for (int pass = 0; pass < 2 && !found; ++pass)  // first without covering a mark, then allowing it
    for (size_t ri = 0; ri < sizeof rings / sizeof rings[0] && !found; ++ri)
      for (const auto& d : dirs) {
        // The box touches the ring at the point in direction d.
        const double ax = cx + d[0] * rings[ri], ay = cy + d[1] * rings[ri];
        const double x0 = d[0] > 0.1 ? ax : d[0] < -0.1 ? ax - w : ax - w / 2;
        const double y0 = d[1] > 0.1 ? ay : d[1] < -0.1 ? ay - h : ay - h / 2;
        const Box b{x0, y0, x0 + w, y0 + h};
        if (b.x0 < left + 1 || b.x1 > right - 1 || b.y0 < top + 1 || b.y1 > bottom - 1) continue;
        if (std::any_of(tag_boxes_.begin(), tag_boxes_.end(), [&](const Box& o) { return hits(o, b); })) continue;
        if (pass == 0 && covers_mark(b)) continue;
        best = b;
        found = true;
        leader = ri > 0;
        break;
      }
  if (!found) {  // nowhere free: beside the mark, overlapping (a crowded plot; the key table still lists it)
    best = {cx + r + 2, cy - h / 2, cx + r + 2 + w, cy + h / 2};
  }
  tag_boxes_.push_back(best);
  std::string g = "<g class=\"tag\">";
  if (leader) {
    const double bx = std::clamp(cx, best.x0, best.x1), by = std::clamp(cy, best.y0, best.y1);
    g += "<line x1=\"" + num_attr(cx) + "\" y1=\"" + num_attr(cy) + "\" x2=\"" + num_attr(bx) + "\" y2=\"" +
         num_attr(by) + "\" stroke=\"#555\" stroke-width=\"1\"/>";
  }
  g += "<rect x=\"" + num_attr(best.x0) + "\" y=\"" + num_attr(best.y0) + "\" width=\"" + num_attr(w) +
       "\" height=\"" + num_attr(h) + "\" rx=\"3\" fill=\"#fff\" fill-opacity=\"0.9\" stroke=\"#333\"/>";
  g += "<text x=\"" + num_attr((best.x0 + best.x1) / 2) + "\" y=\"" + num_attr(best.y1 - 4.5) +
       "\" font-size=\"12\" font-weight=\"bold\" text-anchor=\"middle\">" + html_escape(text) + "</text></g>\n";
  tags_ += g;
}

void SvgPlot::legend(const std::vector<std::pair<std::string, std::string>>& items, const std::string& title) {
  const int x = w_ - lw_ + 4;
  int y = 30;
  legend_ += "<g class=\"legend\">\n";
  if (!title.empty()) {
    legend_ += "<text x=\"" + std::to_string(x) + "\" y=\"" + std::to_string(y) +
               "\" font-size=\"12\" font-weight=\"bold\">" + html_escape(title) + "</text>\n";
    y += 18;
  }
  for (const auto& it : items) {
    legend_ += "<rect x=\"" + std::to_string(x) + "\" y=\"" + std::to_string(y - 10) +
               "\" width=\"12\" height=\"12\" fill=\"" + it.second + "\"/><text x=\"" + std::to_string(x + 18) +
               "\" y=\"" + std::to_string(y) + "\" font-size=\"12\">" + html_escape(it.first) + "</text>\n";
    y += 18;
  }
  legend_ += "</g>\n";
}

std::string SvgPlot::axis_svg() const {
  std::string s;
  const double l = ml_, r = w_ - 20 - lw_, t = 20, b = h_ - mb_;
  s += "<rect x=\"" + num_attr(l) + "\" y=\"" + num_attr(t) + "\" width=\"" + num_attr(r - l) + "\" height=\"" +
       num_attr(b - t) + "\" fill=\"none\" stroke=\"#444\"/>\n";
  // `across`: the labels stand side by side (x), else one above the other (y); `length`: px.
  auto ticks = [](const PlotAxis& a, bool across, double length) {
    std::vector<std::pair<double, std::string>> out = a.ticks;
    if (!out.empty()) return out;
    if (!a.categories.empty()) {
      for (size_t i = 0; i < a.categories.size(); ++i) out.emplace_back(static_cast<double>(i), a.categories[i]);
    } else if (a.log) {
      // 1, 2, 5 in each decade over a few decades; powers of ten only over many.
      const bool many = std::log10(a.hi / a.lo) > 4;
      for (double d = std::floor(std::log10(a.lo)); d <= std::ceil(std::log10(a.hi)); ++d)
        for (double m : many ? std::vector<double>{1.0} : std::vector<double>{1.0, 2.0, 5.0}) {
          const double v = m * std::pow(10.0, d);
          if (v >= a.lo * 0.999 && v <= a.hi * 1.001) out.emplace_back(v, fmt_num(v));
        }
    } else {
      // About 6 ticks; fewer where their labels would not stand apart.
      for (int n = 6;; --n) {
        const std::vector<double> v = nice_ticks(a.lo, a.hi, n);
        const std::vector<std::string> t = tick_texts(v);
        size_t longest = 0;
        for (const auto& x : t) longest = std::max(longest, x.size());
        const double gap = v.size() > 1 ? length * (v[1] - v[0]) / (a.hi - a.lo) : length;
        if (n <= 2 || gap >= (across ? kCharWidthPx * static_cast<double>(longest) + 10 : 16)) {
          for (size_t i = 0; i < v.size(); ++i) out.emplace_back(v[i], t[i]);
          break;
        }
      }
    }
    return out;
  };
  s += "<g class=\"xticks\">\n";
  for (const auto& tk : ticks(x_, true, r - l)) {
    const double x = px(tk.first);
    if (x < l - 0.5 || x > r + 0.5) continue;
    s += "<line x1=\"" + num_attr(x) + "\" y1=\"" + num_attr(t) + "\" x2=\"" + num_attr(x) + "\" y2=\"" + num_attr(b) +
         "\" stroke=\"#e4e4e4\"/>\n";
    if (x_.rotate_labels)
      s += "<text font-size=\"11\" text-anchor=\"end\" transform=\"translate(" + num_attr(x + 4) + "," +
           num_attr(b + 8) + ") rotate(" + std::to_string(x_.rotate_labels) + ")\">" + html_escape(tk.second) +
           "</text>\n";
    else
      s += "<text x=\"" + num_attr(x) + "\" y=\"" + num_attr(b + 16) + "\" font-size=\"11\" text-anchor=\"middle\">" +
           html_escape(tk.second) + "</text>\n";
  }
  s += "</g>\n<g class=\"yticks\">\n";
  for (const auto& tk : ticks(y_, false, b - t)) {
    const double y = py(tk.first);
    if (y < t - 0.5 || y > b + 0.5) continue;
    s += "<line x1=\"" + num_attr(l) + "\" y1=\"" + num_attr(y) + "\" x2=\"" + num_attr(r) + "\" y2=\"" + num_attr(y) +
         "\" stroke=\"#e4e4e4\"/>\n";
    s += "<text x=\"" + num_attr(l - 6) + "\" y=\"" + num_attr(y + 4) + "\" font-size=\"11\" text-anchor=\"end\">" +
         html_escape(tk.second) + "</text>\n";
  }
  s += "</g>\n";
  s += "<text x=\"" + num_attr((l + r) / 2) + "\" y=\"" + std::to_string(h_ - 8) +
       "\" font-size=\"13\" text-anchor=\"middle\">" + html_escape(x_.label) + "</text>\n";
  s += "<text font-size=\"13\" text-anchor=\"middle\" transform=\"translate(16," + num_attr((t + b) / 2) +
       ") rotate(-90)\">" + html_escape(y_.label) + "</text>\n";
  return s;
}

std::string SvgPlot::str() const {
  return "<svg class=\"plot\" id=\"" + html_escape(id_) + "\" width=\"" +
         std::to_string(w_) + "\" height=\"" + std::to_string(h_) + "\" viewBox=\"0 0 " + std::to_string(w_) + " " +
         std::to_string(h_) + "\" font-family=\"sans-serif\">\n" + axis_svg() + "<g class=\"marks\">\n" + marks_ +
         "</g>\n" + labels_ + tags_ + legend_ + "</svg>\n";
}

}  // namespace xbarsim
