#pragma once
/// Minimal SVG plotting for the HTML report: one plot = axes (linear, log or categorical)
/// with nice ticks (<g class="xticks">, <g class="yticks">), data marks inside
/// <g class="marks">, and a legend (<g class="legend">). Output is deterministic.
#include <string>
#include <utility>
#include <vector>

namespace xbarsim {

/// Escapes &, <, >, " and ' for HTML text and attributes.
std::string html_escape(const std::string& s);
/// A compact number: 4 significant digits, k/M/G/T from 10^4 up ("32.55 k"; compact_number).
std::string fmt_num(double v);
/// The texts of an axis' tick values: fmt_num, with more digits where two would read alike
/// (1993.6, 1993.8, 1994.0: "1993.6 1993.8 1994", never "1994 1994 1994").
std::vector<std::string> tick_texts(const std::vector<double>& values);
/// Saturated categorical colours (cycled): the values of the key that colours the points.
const std::string& palette(size_t i);
/// Colours of series that are rows (one line per front point), none of them a palette()
/// colour: a colour that means a key's value in one plot never means a point in another.
const std::string& series_colour(size_t i);
/// The width the layout assumes for a character of 11 px sans-serif (a little above the mean).
constexpr double kCharWidthPx = 6.6;

struct PlotAxis {
  PlotAxis(std::string label_ = "", double lo_ = 0, double hi_ = 1, bool log_ = false)
      : label(std::move(label_)), lo(lo_), hi(hi_), log(log_) {}
  std::string label;
  double lo = 0, hi = 1;
  bool log = false;
  std::vector<std::string> categories;  ///< non-empty: categorical axis, value i at category i
  /// Extra ticks with text (e.g. "none" beside the numbers); replaces the automatic ticks when set.
  std::vector<std::pair<double, std::string>> ticks;
  /// Degrees (e.g. -40 for long category names); turned to -90 when the categories are closer
  /// than 40 px. The plot grows below to hold the longest whole.
  int rotate_labels = 0;
};

class SvgPlot {
 public:
  /// `margin_left` / `margin_bottom` make room for long tick labels; `legend_width` on the right.
  SvgPlot(std::string id, int width, int height, PlotAxis x, PlotAxis y, int margin_left = 70,
          int margin_bottom = 50, int legend_width = 0);
  double px(double x) const;
  double py(double y) const;
  void circle(double x, double y, double r, const std::string& fill, const std::string& title, bool outline = false);
  void line(const std::vector<std::pair<double, double>>& pts, const std::string& color, bool dashed = false,
            double width = 2, const std::string& title = "");
  void rect(double x0, double y0, double x1, double y1, const std::string& fill, const std::string& title);
  void label(double x, double y, const std::string& text, int dx = 6, int dy = -6);
  /// A boxed tag (a point's number) beside the mark of radius `r` at (x, y): the first place
  /// around it, ring by ring, inside the plot area that overlaps no tag placed before (and,
  /// where possible, no mark); from the second ring on, a leader line joins it to the mark.
  /// Drawn as <g class="tag"> above the marks.
  void tag(double x, double y, double r, const std::string& text);
  void legend(const std::vector<std::pair<std::string, std::string>>& items, const std::string& title = "");
  std::string str() const;

 private:
  std::string axis_svg() const;
  std::string id_;
  int w_, h_, ml_, mb_, lw_;
  PlotAxis x_, y_;
  std::string marks_, labels_, legend_, tags_;
  struct Box {
    double x0, y0, x1, y1;
  };
  std::vector<Box> tag_boxes_;
  std::vector<std::pair<std::pair<double, double>, double>> mark_px_;  ///< circles: centre, radius (px)
};

}  // namespace xbarsim
