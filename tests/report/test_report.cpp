// The HTML report: its structure on a hand-made exploration, and what a real browser draws
// of it (headless Chromium screenshot, pixels counted inside every plot's box).
#include <gtest/gtest.h>
#include <zlib.h>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include "sw/common/quantity_text.h"
#include "sw/report/html_report.h"
#include "sw/report/svg_plot.h"

using namespace xbarsim;
using nlohmann::json;

namespace {

json layers(double scale, bool timing) {
  json L = json::array();
  const char* names[] = {"/conv1/Conv", "/layer1/layer1.0/conv1/Conv", "/layer2/layer2.0/conv1/Conv", "/linear/Gemm"};
  for (int k = 0; k < 4; ++k) {
    json l = {{"name", names[k]}, {"mean_relative_error", scale * (0.01 + 0.002 * k)}, {"worst_relative_error", scale * 0.1}};
    if (timing) l.update({{"busy_us", 10.0 + 5 * k}, {"stall_us", 1.0 * k}});
    L.push_back(l);
  }
  return L;
}

json breakdown(double s) {
  return {{"crossbar", 0.1 * s}, {"adc", 0.3 * s}, {"dac", 1.0 * s}, {"accumulator", 0.05 * s}, {"shift_register", 0.02 * s},
          {"buffer", 0.2 * s}, {"interconnect", 0.1 * s}, {"digital", 0.01 * s}, {"memory", 0.1 * s}, {"total", 1.88 * s}};
}

/// Six rows of an exploration: 5 ok (two on the front), one failed; ADC bits 4/6/8/none.
ReportInput sample() {
  ReportInput in;
  in.command = "explore";
  in.title = "test exploration <script>alert(1)</script>";
  in.config_yaml = "mapping:\n  max_rows: [64, 128]  # <b>not bold</b>\n";
  in.swept_keys = {"mapping.max_rows", "converters.adc_bits"};
  in.objectives = {"accuracy", "energy", "area", "latency"};
  const std::vector<std::tuple<std::string, std::string, json, double, double, bool>> pts{
      {"64", "4", 4, 0.80, 10.0, false}, {"64", "8", 8, 0.91, 14.0, true}, {"128", "6", 6, 0.88, 9.0, true},
      {"128", "8", 8, 0.90, 16.0, false}, {"128", "none", "none", 0.92, 30.0, false}};
  for (const auto& p : pts) {
    json r;
    r["label"] = "max_rows=" + std::get<0>(p) + " adc_bits=" + std::get<1>(p);
    r["point"] = {{"mapping.max_rows", std::get<0>(p)}, {"converters.adc_bits", std::get<1>(p)}};
    r["status"] = "ok";
    r["accuracy"] = std::get<3>(p);
    r["software_accuracy"] = 0.92;
    r["energy_uj_per_image"] = std::get<4>(p);
    r["area_mm2"] = 0.2 * std::get<4>(p);
    r["latency_us"] = 300.0;
    r["avg_power_mw"] = 50.0;
    r["time_ns_per_image"] = 3e5;
    r["energy_breakdown_uj"] = breakdown(std::get<4>(p) / 1.88);
    r["area_breakdown_mm2"] = breakdown(0.01);
    r["adc_bits"] = std::get<2>(p);
    r["dac_bits"] = 8;
    r["mean_relative_error"] = 0.02;
    r["layers"] = layers(1.0 + std::get<3>(p), true);
    r["front"] = std::get<5>(p);
    in.rows.push_back(r);
  }
  in.rows[1]["accuracy_drop"] = 0.017;
  in.rows[1]["accuracy_drop_ci95"] = {-0.006, 0.039};
  in.rows[1]["warnings"] = {"layer <conv2>: 66 % of cells clipped"};
  in.rows.push_back({{"label", "max_rows=64 adc_bits=6"}, {"status", "failed"}, {"reason", "cannot <program> it"}});
  return in;
}

size_t count(const std::string& s, const std::string& what) {
  size_t n = 0;
  for (size_t p = s.find(what); p != std::string::npos; p = s.find(what, p + 1)) ++n;
  return n;
}

/// The part of `html` from the <svg> with `id` to its </svg>.
std::string plot(const std::string& html, const std::string& id) {
  const size_t a = html.find("id=\"" + id + "\"");
  if (a == std::string::npos) return "";
  return html.substr(a, html.find("</svg>", a) - a);
}

// The sample's plots: its DAC bits are all 8 (not swept, so no DAC plot); four objectives
// give six pair plots.
const char* kPlots[] = {"plot-pareto", "plot-pair-0", "plot-pair-5", "plot-bits", "plot-layers",
                        "plot-energy", "plot-area", "plot-timing"};

/// A row of a command's report: label, point, accuracy, cost, per-layer errors and timing.
json row_of(const std::string& label, double acc, double energy, double area, double latency, double throughput) {
  json r = {{"label", label}, {"status", "ok"}, {"accuracy", acc}, {"software_accuracy", 0.92},
            {"energy_uj_per_image", energy}, {"area_mm2", area}, {"latency_us", latency},
            {"throughput_images_per_s", throughput}, {"avg_power_mw", 1e3 * energy / latency},
            {"energy_breakdown_uj", breakdown(energy / 1.88)}, {"area_breakdown_mm2", breakdown(area / 1.88)},
            {"adc_bits", 8}, {"dac_bits", 8}, {"layers", layers(1.0, true)}};
  return r;
}

/// The h2 titles of a page, in order.
std::vector<std::string> sections(const std::string& h) {
  std::vector<std::string> t;
  for (size_t p = h.find("<h2>"); p != std::string::npos; p = h.find("<h2>", p + 1))
    t.push_back(h.substr(p + 4, h.find("</h2>", p) - p - 4));
  return t;
}

}  // namespace

TEST(HtmlReport, EveryPlotWithItsMarks) {
  const std::string h = render_html_report(sample());
  for (const char* id : kPlots) {
    const std::string p = plot(h, id);
    ASSERT_FALSE(p.empty()) << id;
    EXPECT_NE(p.find("<g class=\"marks\">\n<"), std::string::npos) << id << " has no marks";
  }
  EXPECT_EQ(count(plot(h, "plot-pareto"), "<circle"), 5u);  // the ok rows with an energy
  EXPECT_EQ(count(plot(h, "plot-pareto"), "stroke=\"#111\""), 2u);  // the front, outlined
  EXPECT_EQ(count(plot(h, "plot-pareto"), "<g class=\"tag\">"), 2u);  // and numbered
  EXPECT_NE(plot(h, "plot-bits").find(">none</text>"), std::string::npos);
  EXPECT_EQ(count(plot(h, "plot-timing"), "<polyline"), 2u);  // per-layer time of the two front points
  EXPECT_NE(h.find("failed: cannot &lt;program&gt; it"), std::string::npos);
  // The drop with its interval in points, and the warnings counted by kind, escaped.
  EXPECT_NE(h.find("<td>1.70 [-0.60, 3.90]</td>"), std::string::npos);
  EXPECT_EQ(count(h, "<td>1.70 ["), 1u);
  EXPECT_NE(h.find("<h2>Warnings</h2>"), std::string::npos);
  EXPECT_NE(h.find("<li>1 &times; # % of cells clipped<br><small>first: max_rows=64 adc_bits=8: layer &lt;conv2&gt;: "
                   "66 % of cells clipped</small></li>"),
            std::string::npos);
  EXPECT_EQ(h, render_html_report(sample()));  // deterministic
}

TEST(HtmlReport, EscapesAndFetchesNothing) {
  const std::string h = render_html_report(sample());
  EXPECT_EQ(h.find("<script>alert"), std::string::npos);
  EXPECT_NE(h.find("&lt;script&gt;alert(1)&lt;/script&gt;"), std::string::npos);
  EXPECT_NE(h.find("# &lt;b&gt;not bold&lt;/b&gt;"), std::string::npos);
  EXPECT_EQ(h.find("http://"), std::string::npos);
  EXPECT_EQ(h.find("https://"), std::string::npos);
  EXPECT_EQ(h.find(" src="), std::string::npos);
  EXPECT_EQ(h.find("<link"), std::string::npos);
}

TEST(HtmlReport, MissingDataAreSaid) {
  ReportInput in;
  in.command = "xbar-study";
  in.title = "study";
  in.rows = json::array({{{"label", "default"}, {"mean_relative_error", 0.01}, {"area_breakdown_mm2", breakdown(1)}},
                         {{"label", 7}, {"status", 3}, {"layers", "odd"}}});  // odd types are skipped, not thrown
  const std::string h = render_html_report(in);
  // What the rows cannot show is one line at the end, not empty sections.
  const size_t line = h.find("<p class=\"missing\" id=\"not-shown\">Not in this report: ");
  ASSERT_NE(line, std::string::npos);
  for (const char* what : {"per-layer error propagation", "energy by component", "ADC bits plot"})
    EXPECT_NE(h.find(what, line), std::string::npos) << what;
  EXPECT_EQ(count(h, "class=\"missing\""), 1u);
  EXPECT_NE(h.find("id=\"plot-area\""), std::string::npos);
  EXPECT_EQ(h.find("<h2>Energy by component</h2>"), std::string::npos);
  EXPECT_EQ(h.find("<h2>Warnings</h2>"), std::string::npos);  // none given, no section
}

TEST(HtmlReport, EachCommandLeadsWithWhatItMeasures) {
  ReportInput ex = sample();
  EXPECT_EQ(sections(render_html_report(ex)).at(0), "Pareto front");
  ReportInput sim;
  sim.command = "simulate";
  sim.swept_keys = {"mapping.scheme"};
  sim.rows = json::array({row_of("scheme=dense", 0.9, 17.4, 0.59, 349.5, 2861),
                          row_of("scheme=sparse", 0.9, 171.9, 785.6, 204, 4902)});
  sim.rows[1]["peak_power_mw"] = 15460021.9;
  const std::string s = render_html_report(sim);
  ASSERT_FALSE(sections(s).empty());
  EXPECT_EQ(sections(s)[0], "Throughput, latency and the bottleneck");
  EXPECT_NE(s.find("<th>throughput images/s</th>"), std::string::npos);
  EXPECT_NE(plot(s, "plot-throughput").find(">4902</text>"), std::string::npos);
  EXPECT_NE(s.find("<td>15460 W</td>"), std::string::npos);  // watts above 10 W
  EXPECT_NE(s.find("<td>49.79 mW</td>"), std::string::npos);
  // Areas 0.59 and 785.6 mm2: each row's bar as shares of its total, the total printed.
  EXPECT_NE(plot(s, "plot-area").find("share of each row&#39;s total"), std::string::npos);
  EXPECT_NE(plot(s, "plot-area").find(">785.6 mm2</text>"), std::string::npos);
  EXPECT_EQ(s.find("plot-pareto"), std::string::npos);
  ReportInput ev;
  ev.command = "eval";
  ev.rows = json::array({row_of("default", 0.89, 17.4, 0.59, 1, 1)});
  for (const char* k : {"latency_us", "throughput_images_per_s", "avg_power_mw"}) ev.rows[0].erase(k);
  ev.rows[0]["accuracy_drop"] = 0.025;
  ev.rows[0]["accuracy_drop_ci95"] = {0.0012, 0.0483};
  const std::string e = render_html_report(ev);
  EXPECT_EQ(sections(e).at(0), "Accuracy");
  EXPECT_NE(e.find("crossbars <b>89.00 %</b> against software 92.00 %: a drop of 2.50 [0.12, 4.83] points"),
            std::string::npos)
      << e;
  EXPECT_NE(e.find("throughput and latency (the platform&#39;s", e.find("Not in this report")), std::string::npos);
}

TEST(HtmlReport, WarningKindsAndPowers) {
  EXPECT_EQ(warning_kind("layer /a/b: 834 of 2304 cells (36 %) clipped; fewer rows"), "# of # cells (# %) clipped");
  EXPECT_EQ(warning_kind("offset -3.5 and +3 and 3"), "offset # and # and #");
  EXPECT_EQ(power_text(49.76), "49.76 mW");
  EXPECT_EQ(power_text(9999.99), "9999.99 mW");  // below 10 W
  EXPECT_EQ(power_text(15460021.9), "15460 W");
  EXPECT_EQ(power_text(12345.0), "12.35 W");
  EXPECT_EQ(power_text(999999.99), "1000 W");
}

TEST(HtmlReport, NoSectionForAnUnsweptQuantity) {
  ReportInput in = sample();
  for (auto& r : in.rows)
    if (r.contains("adc_bits")) r["adc_bits"] = 8;
  const std::string h = render_html_report(in);
  EXPECT_EQ(h.find("id=\"plot-bits\""), std::string::npos);
  EXPECT_EQ(h.find("id=\"plot-dac-bits\""), std::string::npos);
  EXPECT_EQ(h.find("<h2>Accuracy vs ADC bits</h2>"), std::string::npos);
  EXPECT_NE(h.find("ADC bits plot (not swept: all 8)"), std::string::npos);
  EXPECT_NE(render_html_report(sample()).find("id=\"plot-bits\""), std::string::npos);  // swept: there
}

TEST(HtmlReport, LogAxisWhereASeriesSpansMoreThan100x) {
  ReportInput in;
  in.command = "eval";
  json r = row_of("default", 0.9, 17, 0.5, 300, 1000);
  r["layers"] = layers(1.0, false);
  r["layers"][0]["mean_relative_error"] = 2e-5;  // 0.002 % .. 10 %: 5000x
  in.rows = json::array({r});
  EXPECT_NE(plot(render_html_report(in), "plot-layers").find("relative error (%) (log scale)"), std::string::npos);
  in.rows[0]["layers"] = layers(0.1, false);  // 0.1 % .. 1 %: 10x
  const std::string lin = plot(render_html_report(in), "plot-layers");
  ASSERT_FALSE(lin.empty());
  EXPECT_EQ(lin.find("log scale"), std::string::npos);
  // The front's scatter too: energies 1..1000 uJ.
  ReportInput ex = sample();
  ex.rows[0]["energy_uj_per_image"] = 1000.0;
  EXPECT_NE(plot(render_html_report(ex), "plot-pareto").find("energy per image (uJ) (log scale)"), std::string::npos);
  EXPECT_EQ(plot(render_html_report(sample()), "plot-pareto").find("log scale"), std::string::npos);
}

TEST(HtmlReport, FloorGreysAndManyObjectivesDrawMarksAndPairs) {
  ReportInput in = sample();
  in.min_accuracy = 0.85;  // the 80 % point is below it
  std::string h = render_html_report(in);
  EXPECT_EQ(count(plot(h, "plot-pareto"), "r=\"5.5\" fill=\"#c4c4c4\""), 1u);  // the point below the floor
  EXPECT_NE(plot(h, "plot-pareto").find(">below the accuracy floor</text>"), std::string::npos);  // and its key
  EXPECT_NE(plot(h, "plot-pareto").find("accuracy floor 85 %"), std::string::npos);
  // Four objectives: the front as marks only, and the six pairs.
  EXPECT_EQ(plot(h, "plot-pareto").find("<title>Pareto front</title>"), std::string::npos);
  for (int k = 0; k < 6; ++k) EXPECT_FALSE(plot(h, "plot-pair-" + std::to_string(k)).empty()) << k;
  EXPECT_TRUE(plot(h, "plot-pair-6").empty());
  in.objectives = {"accuracy", "energy"};  // two: the front joined, no pairs
  h = render_html_report(in);
  EXPECT_NE(plot(h, "plot-pareto").find("<title>Pareto front</title>"), std::string::npos);
  EXPECT_TRUE(plot(h, "plot-pair-0").empty());
  in.objectives = {"area", "energy"};  // no accuracy: energy across, area up (never one on both axes)
  h = plot(render_html_report(in), "plot-pareto");
  EXPECT_NE(h.find(">energy per image (uJ)</text>"), std::string::npos) << h;
  EXPECT_NE(h.find(">area (mm2)</text>"), std::string::npos) << h;
}

// ---- the rules every plot keeps (issue 39, item 5) ---------------------------------------

namespace {

/// Every plot id of a page, in order.
std::vector<std::string> plot_ids(const std::string& h) {
  std::vector<std::string> ids;
  const std::string open = "<svg class=\"plot\" id=\"";
  for (size_t p = h.find(open); p != std::string::npos; p = h.find(open, p + 1)) {
    const size_t a = p + open.size();
    ids.push_back(h.substr(a, h.find('"', a) - a));
  }
  return ids;
}

/// The part of `s` inside the first <g class="CLASS"> ... </g> (no nesting in them).
std::string group(const std::string& s, const std::string& cls) {
  const size_t a = s.find("<g class=\"" + cls + "\">");
  if (a == std::string::npos) return "";
  return s.substr(a, s.find("</g>", a) - a);
}

/// The texts of the <text> elements of `s`.
std::vector<std::string> texts(const std::string& s) {
  std::vector<std::string> t;
  for (size_t p = s.find("<text"); p != std::string::npos; p = s.find("<text", p + 1)) {
    const size_t a = s.find('>', p) + 1;
    t.push_back(s.substr(a, s.find("</text>", a) - a));
  }
  return t;
}

/// The values of attribute `attr` on the elements `tag` of `s`.
std::set<std::string> attrs(const std::string& s, const std::string& tag, const std::string& attr) {
  std::set<std::string> v;
  for (size_t p = s.find("<" + tag + " "); p != std::string::npos; p = s.find("<" + tag + " ", p + 1)) {
    const std::string el = s.substr(p, s.find('>', p) - p);
    const size_t a = el.find(" " + attr + "=\"");
    if (a != std::string::npos)
      v.insert(el.substr(a + attr.size() + 3, el.find('"', a + attr.size() + 3) - a - attr.size() - 3));
  }
  return v;
}

/// The colours a plot draws its data in: its marks' fills and lines.
std::set<std::string> mark_colours(const std::string& svg) {
  const std::string m = group(svg, "marks");
  std::set<std::string> c = attrs(m, "circle", "fill"), r = attrs(m, "rect", "fill"),
                        l = attrs(m, "polyline", "stroke");
  c.insert(r.begin(), r.end());
  c.insert(l.begin(), l.end());
  return c;
}

/// The colours of plot `id`'s legend: its own (in the SVG) and those of the HTML legends under it.
std::set<std::string> legend_colours(const std::string& h, const std::string& id) {
  std::set<std::string> c = attrs(group(plot(h, id), "legend"), "rect", "fill");
  const std::string open = "<div class=\"legend\" data-for=\"";
  for (size_t p = h.find(open); p != std::string::npos; p = h.find(open, p + 1)) {
    const size_t a = p + open.size();
    std::istringstream ids(h.substr(a, h.find('"', a) - a));
    bool mine = false;
    for (std::string x; ids >> x;) mine = mine || x == id;
    if (!mine) continue;
    const std::string div = h.substr(p, h.find("</div>", p) - p);
    for (size_t q = div.find("background:"); q != std::string::npos; q = div.find("background:", q + 1))
      c.insert(div.substr(q + 11, div.find('"', q) - q - 11));
  }
  return c;
}

/// The rules of every plot of page `h`: the tick labels of each axis distinct, and every
/// colour a plot draws data in named by its legend.
void expect_plot_rules(const std::string& h, const std::string& page) {
  const std::vector<std::string> ids = plot_ids(h);
  ASSERT_FALSE(ids.empty()) << page;
  for (const std::string& id : ids) {
    const std::string svg = plot(h, id);
    for (const char* axis : {"xticks", "yticks"}) {
      const std::vector<std::string> t = texts(group(svg, axis));
      const std::set<std::string> distinct(t.begin(), t.end());
      EXPECT_EQ(distinct.size(), t.size()) << page << " " << id << ": " << axis << " repeat a label";
    }
    const std::set<std::string> legend = legend_colours(h, id);
    for (const std::string& c : mark_colours(svg))
      EXPECT_TRUE(legend.count(c)) << page << " " << id << ": colour " << c << " drawn but not in its legend";
  }
}

/// A stage of simulate's report row ({name, kind, busy_us, stall_us}).
json stage(const std::string& name, const char* kind, double busy, double stall = 0) {
  return {{"name", name}, {"kind", kind}, {"busy_us", busy}, {"stall_us", stall}};
}

/// GoogLeNet as simulate reports it (torchvision's ONNX node names): 58 linear layers, 23
/// pooling and concatenation stages and the interconnect, 82 stages; every inception block
/// has the same long layer names. `bus_bound`: the interconnect bounds the run (198 us per
/// image), else /maxpool1/MaxPool (30.72 us).
json googlenet_row(const std::string& label, bool bus_bound, double throughput) {
  json stages = json::array();
  auto conv = [&](const std::string& n) { stages.push_back(stage(n + "/conv/Conv", "linear", 6.4, 1.0)); };
  auto pool = [&](const std::string& n, double busy) { stages.push_back(stage(n + "/MaxPool", "digital", busy)); };
  conv("/conv1");
  pool("/maxpool1", 30.72);
  conv("/conv2");
  conv("/conv3");
  pool("/maxpool2", 7.68);
  for (const char* b : {"3a", "3b", "4a", "4b", "4c", "4d", "4e", "5a", "5b"}) {
    const std::string n = std::string("/inception") + b;
    conv(n + "/branch1");
    conv(n + "/branch2/branch2.0");
    conv(n + "/branch2/branch2.1");
    conv(n + "/branch3/branch3.0");
    conv(n + "/branch3/branch3.1");
    pool(n + "/branch4/branch4.0", 1.5);
    conv(n + "/branch4/branch4.1");
    stages.push_back(stage(n + "/Concat", "digital", 0.8));
    if (std::string(b) == "3b") pool("/maxpool3", 3.84);
    if (std::string(b) == "4e") pool("/maxpool4", 1.92);
  }
  stages.push_back(stage("/avgpool/GlobalAveragePool", "digital", 0.5));
  stages.push_back(stage("/fc/Gemm", "linear", 0.9));
  stages.push_back(stage("interconnect (platform.bus_lanes)", "interconnect", bus_bound ? 198.0 : 12.5));
  json r = row_of(label, 0.8789, 160.0, 40.0, 260.0, throughput);
  r["software_accuracy"] = 0.881;
  r["images"] = 1;
  r["stages"] = stages;
  r["bottleneck"] = {{"stage", bus_bound ? "interconnect (platform.bus_lanes)" : "/maxpool1/MaxPool"},
                     {"busy_us_per_image", bus_bound ? 198.0 : 30.72}};
  json layers = json::array();
  for (const auto& s : stages)
    if (s["kind"] == "linear") layers.push_back({{"name", s["name"]}, {"busy_us", s["busy_us"]}, {"stall_us", 1.0}});
  r["layers"] = layers;
  return r;
}

ReportInput googlenet_simulate(int rows) {
  ReportInput in;
  in.command = "simulate";
  in.title = "simulate: GoogLeNet";
  in.rows = json::array({googlenet_row("bus_lanes=1", true, 32552.4)});
  if (rows > 1) {
    in.swept_keys = {"platform.bus_lanes"};
    in.rows.push_back(googlenet_row("bus_lanes=8", false, 5051.0));
  }
  return in;
}

/// Whether plot `svg` has a mark whose tooltip starts with `name` (a stage drawn under its name).
bool has_mark_named(const std::string& svg, const std::string& name) {
  return svg.find("<title>" + name) != std::string::npos || svg.find("\n" + name) != std::string::npos;
}

/// The category labels of plot-timing (across its foot or down its side).
std::vector<std::string> stage_labels(const std::string& svg) {
  std::vector<std::string> x = texts(group(svg, "xticks")), y = texts(group(svg, "yticks"));
  return x.size() > y.size() ? x : y;
}

}  // namespace

// Simulate's per-stage plot holds every stage, the one that bounds the run among them (the
// interconnect, a max-pooling), under labels that are all distinct and whole.
TEST(HtmlReport, EveryStageThatBoundsTheRunIsPlottedUnderADistinctName) {
  for (int rows : {1, 2}) {
    const ReportInput in = googlenet_simulate(rows);
    const std::string h = render_html_report(in), svg = plot(h, "plot-timing");
    ASSERT_FALSE(svg.empty()) << rows;
    for (const auto& r : in.rows) {
      const std::string slow = r["bottleneck"]["stage"];
      EXPECT_TRUE(has_mark_named(svg, slow)) << rows << " row(s): the bottleneck " << slow << " is not plotted";
    }
    const std::vector<std::string> labels = stage_labels(svg);
    EXPECT_EQ(labels.size(), 82u) << rows;
    EXPECT_EQ(std::set<std::string>(labels.begin(), labels.end()).size(), labels.size()) << rows;
    for (const char* whole : {"inception3a/branch2/branch2.1/conv", "inception5b/branch2/branch2.1/conv",
                              "maxpool1/MaxPool", "inception4e/Concat", "interconnect (platform.bus_lanes)"})
      EXPECT_NE(std::find(labels.begin(), labels.end(), whole), labels.end()) << whole;
    expect_plot_rules(h, "googlenet x" + std::to_string(rows));
  }
}

// Throughput, accuracies and powers as a person reads them, and as each command means them.
TEST(HtmlReport, NumbersReadAlikeAndEachPowerSaysWhatItIs) {
  const std::string s = render_html_report(googlenet_simulate(1));
  EXPECT_NE(s.find("<td>32.55 k</td>"), std::string::npos);  // not 3.255e+04
  EXPECT_NE(plot(s, "plot-throughput").find(">32.55 k</text>"), std::string::npos);
  EXPECT_EQ(s.substr(0, s.find("<h2>Configuration</h2>")).find("e+0"), std::string::npos);
  EXPECT_NE(s.find("crossbars <b>87.89 %</b> against software 88.10 % on 1 image"), std::string::npos);
  EXPECT_NE(s.find("<th>average power (simulated time)</th>"), std::string::npos);
  ReportInput ev;
  ev.command = "eval";
  ev.rows = json::array({row_of("default", 0.8789, 17.4, 0.59, 1, 1)});
  ev.rows[0]["software_accuracy"] = 0.881;
  ev.rows[0]["images"] = 10000;
  for (const char* k : {"latency_us", "throughput_images_per_s", "avg_power_mw"}) ev.rows[0].erase(k);
  ev.rows[0]["ideal_avg_power_mw"] = 191.3;  // eval's: energy over the reads back to back
  const std::string e = render_html_report(ev);
  EXPECT_NE(e.find("crossbars <b>87.89 %</b> against software 88.10 % on 10000 images"), std::string::npos);
  EXPECT_NE(e.find("<th>average power (ideal time, eval)</th>"), std::string::npos);
  EXPECT_EQ(e.find("average power (simulated"), std::string::npos);
  EXPECT_EQ(compact_number(32552.4), "32.55 k");
  EXPECT_EQ(compact_number(999960), "1 M");
  EXPECT_EQ(compact_number(4902), "4902");
  EXPECT_EQ(tick_texts({1993.6, 1993.8, 1994.0, 1994.2}),
            (std::vector<std::string>{"1993.6", "1993.8", "1994", "1994.2"}));
}

// Explore: the pairs coloured as the main scatter, the bits plot with a legend, the front's
// series in colours that never mean a key's value, latencies that differ in the fifth digit
// with ticks that say so, and an accuracy floor far below the points labelled, not stretched to.
TEST(HtmlReport, ExploreColoursMeanOneThingAndTheFloorIsLabelled) {
  ReportInput in = sample();
  for (size_t i = 0; i < 5; ++i) in.rows[i]["latency_us"] = 1993.6 + 0.2 * i;
  std::string h = render_html_report(in);
  expect_plot_rules(h, "explore");
  const std::set<std::string> key = legend_colours(h, "plot-pareto");
  for (int k = 0; k < 6; ++k) {
    const std::set<std::string> c = mark_colours(plot(h, "plot-pair-" + std::to_string(k)));
    EXPECT_EQ(c, (std::set<std::string>{palette(0), palette(1)})) << k << ": coloured by max_rows 64 and 128";
  }
  for (const char* id : {"plot-layers", "plot-timing"})
    for (const std::string& c : mark_colours(plot(h, id))) EXPECT_FALSE(key.count(c)) << id << " reuses " << c;
  EXPECT_NE(plot(h, "plot-bits").find(">best per bit width (line)</text>"), std::string::npos);
  // A floor of 45 % under points at 80..92 %: the axis stays on the points, the floor is said.
  in.min_accuracy = 0.45;
  h = render_html_report(in);
  expect_plot_rules(h, "explore, floor 45 %");
  const std::string p = plot(h, "plot-pareto");
  EXPECT_NE(p.find("accuracy floor 45 % (explore.min_accuracy): below this axis"), std::string::npos);
  for (const std::string& t : texts(group(p, "yticks"))) EXPECT_GT(std::stod(t), 70) << t;
  in.min_accuracy = 0.85;  // near the points: a labelled line
  h = render_html_report(in);
  EXPECT_NE(plot(h, "plot-pareto").find(">accuracy floor 85 % (explore.min_accuracy)</text>"), std::string::npos);
  expect_plot_rules(h, "explore, floor 85 %");
}

// ---- the browser ------------------------------------------------------------------------

namespace {

struct Image {
  int w = 0, h = 0;
  std::vector<unsigned char> rgb;  // w*h*3
};

uint32_t be32(const unsigned char* p) { return (uint32_t(p[0]) << 24) | (p[1] << 16) | (p[2] << 8) | p[3]; }

/// A minimal PNG reader: 8-bit RGB or RGBA, not interlaced, all five filters.
Image read_png(const std::string& path, std::string& error) {
  std::ifstream f(path, std::ios::binary);
  const std::string d((std::istreambuf_iterator<char>(f)), {});
  Image img;
  if (d.size() < 8 || d.compare(1, 3, "PNG") != 0) return error = "not a PNG", img;
  std::string idat;
  int channels = 0;
  for (size_t p = 8; p + 12 <= d.size();) {
    const auto* u = reinterpret_cast<const unsigned char*>(d.data() + p);
    const uint32_t len = be32(u);
    const std::string type = d.substr(p + 4, 4);
    if (type == "IHDR") {
      img.w = static_cast<int>(be32(u + 8));
      img.h = static_cast<int>(be32(u + 12));
      const int depth = u[16], color = u[17], interlace = u[20];
      if (depth != 8 || (color != 2 && color != 6) || interlace) return error = "unsupported PNG format", img;
      channels = color == 2 ? 3 : 4;
    } else if (type == "IDAT") {
      idat += d.substr(p + 8, len);
    }
    p += 12 + len;
  }
  const size_t stride = static_cast<size_t>(img.w) * channels;
  std::vector<unsigned char> raw((stride + 1) * img.h);
  uLongf n = raw.size();
  if (uncompress(raw.data(), &n, reinterpret_cast<const Bytef*>(idat.data()), idat.size()) != Z_OK || n != raw.size())
    return error = "bad PNG data", img;
  std::vector<unsigned char> prev(stride, 0), cur(stride);
  img.rgb.resize(static_cast<size_t>(img.w) * img.h * 3);
  for (int y = 0; y < img.h; ++y) {
    const unsigned char ft = raw[y * (stride + 1)];
    const unsigned char* in = &raw[y * (stride + 1) + 1];
    for (size_t i = 0; i < stride; ++i) {
      const int a = i >= size_t(channels) ? cur[i - channels] : 0, b = prev[i],
                c = i >= size_t(channels) ? prev[i - channels] : 0;
      int v = in[i];
      switch (ft) {
        case 1: v += a; break;
        case 2: v += b; break;
        case 3: v += (a + b) / 2; break;
        case 4: {
          const int pp = a + b - c, pa = std::abs(pp - a), pb = std::abs(pp - b), pc = std::abs(pp - c);
          v += pa <= pb && pa <= pc ? a : pb <= pc ? b : c;
          break;
        }
      }
      cur[i] = static_cast<unsigned char>(v);
    }
    for (int x = 0; x < img.w; ++x)
      for (int k = 0; k < 3; ++k) img.rgb[(static_cast<size_t>(y) * img.w + x) * 3 + k] = cur[x * channels + k];
    prev.swap(cur);
  }
  return img;
}

std::string chromium() {
  for (const char* c : {"/usr/bin/chromium", "/usr/bin/chromium-browser"})
    if (std::ifstream(c).good()) return c;
  return "";
}

int run(const std::string& cmd, std::string* out = nullptr) {
  FILE* p = popen(cmd.c_str(), "r");
  std::string text;
  char buf[4096];
  while (p && fgets(buf, sizeof buf, p)) text += buf;
  const int st = p ? pclose(p) : -1;
  if (out) *out = text;
  return st;
}

/// The page `in` as headless Chromium lays it out and draws it at `width` px: the boxes its
/// own script measured (plots by id, point tags as "tag:PLOT:i") and a screenshot, kept in
/// the test's output directory as NAME.png (a test artefact).
struct Rendered {
  std::map<std::string, std::array<int, 4>> boxes;
  Image img;
  std::string error;
};
Rendered render_in_chromium(const std::string& browser, const std::string& name, const ReportInput& in, int width) {
  Rendered r;
  const std::string dir = XBARSIM_TEST_OUTPUT_DIR;
  const std::string page = dir + "/" + name + ".html", png = dir + "/" + name + ".png", log = dir + "/chromium.log";
  write_html_report(page, in);
  std::remove(png.c_str());
  const std::string flags =
      " --headless=new --no-sandbox --disable-gpu --hide-scrollbars --window-size=" + std::to_string(width) + ",4000 ";
  std::string dom;
  if (run("timeout 90 " + browser + flags + "--dump-dom file://" + page + " 2>" + log, &dom) != 0)
    return r.error = "chromium --dump-dom failed; see " + log, r;
  if (run("timeout 90 " + browser + flags + "--screenshot=" + png + " file://" + page + " 2>>" + log) != 0)
    return r.error = "chromium --screenshot failed; see " + log, r;
  std::printf("screenshot: %s\n", png.c_str());
  const size_t a = dom.find("<pre id=\"layout\" hidden=\"\">");
  if (a == std::string::npos) return r.error = "no layout in the rendered DOM", r;
  std::istringstream layout(dom.substr(a + 27, dom.find("</pre>", a) - a - 27));
  std::string id;
  std::array<int, 4> b;
  while (layout >> id >> b[0] >> b[1] >> b[2] >> b[3]) r.boxes[id] = b;
  r.img = read_png(png, r.error);
  return r;
}

/// An exploration whose 14 front points crowd one corner of the scatter (four share a place),
/// far from the other two: their number tags must find room without covering each other.
ReportInput crowded() {
  ReportInput in = sample();
  in.objectives = {"accuracy", "energy"};
  json rows = json::array();
  for (int i = 0; i < 14; ++i) {
    const int k = i < 4 ? 0 : i - 3;  // the first four at one place
    json r = in.rows[1];
    r["label"] = "max_rows=" + std::to_string(64 + 8 * i) + " adc_bits=8 a long method name to fill the key";
    r["point"] = {{"mapping.max_rows", std::to_string(64 + 8 * i)}, {"converters.adc_bits", "8"}};
    r["energy_uj_per_image"] = 10.0 + 0.02 * k;
    r["accuracy"] = 0.900 + 0.0008 * k;
    r["front"] = true;
    r.erase("warnings");
    rows.push_back(r);
  }
  rows.push_back(in.rows[0]);
  rows.back()["energy_uj_per_image"] = 30.0;
  rows.back()["accuracy"] = 0.5;
  in.rows = rows;
  return in;
}

}  // namespace

TEST(HtmlReportBrowser, ChromiumDrawsEveryPlot) {
  const std::string browser = chromium();
  if (browser.empty()) GTEST_SKIP() << "Chromium not found (Debian package chromium); browser test skipped";
  const Rendered r = render_in_chromium(browser, "report_explore", sample(), 1400);
  ASSERT_TRUE(r.error.empty()) << r.error;
  const auto& boxes = r.boxes;
  const Image& img = r.img;
  for (const char* plot_id : kPlots) {
    ASSERT_TRUE(boxes.count(plot_id)) << plot_id << " not laid out";
    const auto& bx = boxes.at(plot_id);
    ASSERT_GT(bx[2], 100) << plot_id;
    ASSERT_LE(bx[0] + bx[2], 1400) << plot_id << " is wider than the window";
    ASSERT_LE(bx[1] + bx[3], img.h) << plot_id << " lies below the screenshot";
    // Saturated pixels: the coloured data marks, not the black axes and grey grid.
    long coloured = 0;
    for (int y = bx[1]; y < bx[1] + bx[3]; ++y)
      for (int x = bx[0]; x < std::min(bx[0] + bx[2], img.w); ++x) {
        const unsigned char* p = &img.rgb[(static_cast<size_t>(y) * img.w + x) * 3];
        coloured += std::max({p[0], p[1], p[2]}) - std::min({p[0], p[1], p[2]}) > 60;
      }
    EXPECT_GT(coloured, 150) << plot_id << ": its data marks did not draw";
  }
}

TEST(HtmlReportBrowser, NoTwoPointTagsOverlapAndEveryCommandsReportIsKept) {
  const std::string browser = chromium();
  if (browser.empty()) GTEST_SKIP() << "Chromium not found (Debian package chromium); browser test skipped";
  const Rendered r = render_in_chromium(browser, "report_crowded_front", crowded(), 1400);
  ASSERT_TRUE(r.error.empty()) << r.error;
  // The tags' text as the browser laid it out (not the boxes the report computed).
  std::vector<std::pair<std::string, std::array<int, 4>>> tags;
  for (const auto& b : r.boxes)
    if (b.first.rfind("tag:plot-pareto:", 0) == 0) tags.push_back(b);
  ASSERT_EQ(tags.size(), 14u);
  const auto& plot = r.boxes.at("plot-pareto");
  for (size_t i = 0; i < tags.size(); ++i) {
    const auto& a = tags[i].second;
    EXPECT_GE(a[0], plot[0]) << tags[i].first << " outside its plot";
    EXPECT_LE(a[0] + a[2], plot[0] + plot[2]) << tags[i].first << " outside its plot";
    for (size_t k = 0; k < i; ++k) {
      const auto& b = tags[k].second;
      const bool overlap = a[0] < b[0] + b[2] && b[0] < a[0] + a[2] && a[1] < b[1] + b[3] && b[1] < a[1] + a[3];
      EXPECT_FALSE(overlap) << tags[i].first << " overlaps " << tags[k].first;
    }
  }
  // A report of each command, kept as a screenshot beside the test (report_*.png).
  ReportInput sim;
  sim.command = "simulate";
  sim.title = "simulate: dense and sparse, sequential and pipelined";
  sim.swept_keys = {"mapping.scheme", "platform.schedule"};
  sim.rows = json::array({row_of("scheme=dense schedule=sequential", 0.9, 17.4, 0.59, 349.5, 2861),
                          row_of("scheme=dense schedule=pipelined", 0.9, 17.4, 0.59, 354.4, 5051),
                          row_of("scheme=sparse schedule=sequential", 0.9, 171.9, 785.6, 204, 4902),
                          row_of("scheme=sparse schedule=pipelined", 0.9, 171.9, 785.6, 689, 6237)});
  ReportInput ev;
  ev.command = "eval";
  ev.title = "eval";
  ev.rows = json::array({row_of("default", 0.89, 17.4, 0.59, 1, 1)});
  for (const auto& in : {std::make_pair("report_simulate", sim), std::make_pair("report_eval", ev)}) {
    const Rendered k = render_in_chromium(browser, in.first, in.second, 1400);
    ASSERT_TRUE(k.error.empty()) << in.first << ": " << k.error;
    EXPECT_GT(k.img.h, 500) << in.first;
  }
}

// GoogLeNet's 82 stages as the browser draws them (one row: bars; two: lines), and the
// exploration: every tick label whole inside its plot, none over another of its axis.
TEST(HtmlReportBrowser, EveryTickLabelIsWholeAndApartOnAGoogLeNetSizedNetwork) {
  const std::string browser = chromium();
  if (browser.empty()) GTEST_SKIP() << "Chromium not found (Debian package chromium); browser test skipped";
  ReportInput ex = sample();
  for (size_t i = 0; i < 5; ++i) ex.rows[i]["latency_us"] = 1993.6 + 0.2 * i;
  const std::vector<std::pair<std::string, ReportInput>> pages{{"report_googlenet_1", googlenet_simulate(1)},
                                                               {"report_googlenet_2", googlenet_simulate(2)},
                                                               {"report_explore_ticks", ex}};
  for (const auto& page : pages) {
    const Rendered r = render_in_chromium(browser, page.first, page.second, 1400);
    ASSERT_TRUE(r.error.empty()) << page.first << ": " << r.error;
    expect_plot_rules(render_html_report(page.second), page.first);
    size_t ticks = 0;
    for (const auto& plot : r.boxes) {
      if (plot.first.find(':') != std::string::npos) continue;  // a plot's own box
      const auto& P = plot.second;
      for (const char* axis : {"xtick:", "ytick:"}) {
        std::vector<std::pair<std::string, std::array<int, 4>>> t;
        for (const auto& b : r.boxes)
          if (b.first.rfind(axis + plot.first + ":", 0) == 0) t.push_back(b);
        ticks += t.size();
        for (size_t i = 0; i < t.size(); ++i) {
          const auto& a = t[i].second;
          EXPECT_TRUE(a[0] >= P[0] - 1 && a[1] >= P[1] - 1 && a[0] + a[2] <= P[0] + P[2] + 1 &&
                      a[1] + a[3] <= P[1] + P[3] + 1)
              << page.first << " " << t[i].first << " is cut off by its plot";
          for (size_t k = 0; k < i; ++k) {
            const auto& b = t[k].second;
            const bool overlap = a[0] < b[0] + b[2] && b[0] < a[0] + a[2] && a[1] < b[1] + b[3] && b[1] < a[1] + a[3];
            EXPECT_FALSE(overlap) << page.first << " " << t[i].first << " overlaps " << t[k].first;
          }
        }
      }
    }
    EXPECT_GT(ticks, page.first == "report_explore_ticks" ? 50u : 82u) << page.first;
  }
}
