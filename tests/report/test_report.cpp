// The HTML report: its structure on a hand-made exploration, and what a real browser draws
// of it (headless Chromium screenshot, pixels counted inside every plot's box).
#include <gtest/gtest.h>
#include <zlib.h>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>
#include <sstream>

#include "sw/report/html_report.h"

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

const char* kPlots[] = {"plot-pareto", "plot-bits", "plot-dac-bits", "plot-layers", "plot-power", "plot-area",
                        "plot-timing"};

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
  EXPECT_NE(plot(h, "plot-bits").find(">none</text>"), std::string::npos);
  EXPECT_EQ(count(plot(h, "plot-timing"), "<rect x"), 4u + 3u + 2u + 1u);  // busy + nonzero stalls + legend + frame
  EXPECT_NE(h.find("failed: cannot &lt;program&gt; it"), std::string::npos);
  // The drop with its interval in points, and the warnings under the table, escaped.
  EXPECT_NE(h.find("<td>1.7 [-0.6, 3.9]</td>"), std::string::npos);
  EXPECT_EQ(count(h, "<td>1.7 ["), 1u);
  EXPECT_NE(h.find("<h2>Warnings</h2>"), std::string::npos);
  EXPECT_NE(h.find("<li>max_rows=64 adc_bits=8: layer &lt;conv2&gt;: 66 % of cells clipped</li>"), std::string::npos);
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
  EXPECT_NE(h.find("No Pareto scatter"), std::string::npos);
  EXPECT_NE(h.find("No per-layer timing"), std::string::npos);
  EXPECT_NE(h.find("No power breakdown"), std::string::npos);
  EXPECT_NE(h.find("id=\"plot-area\""), std::string::npos);
  EXPECT_EQ(h.find("<h2>Warnings</h2>"), std::string::npos);  // none given, no section
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

}  // namespace

TEST(HtmlReportBrowser, ChromiumDrawsEveryPlot) {
  const std::string browser = chromium();
  if (browser.empty()) GTEST_SKIP() << "Chromium not found (Debian package chromium); browser test skipped";
  const std::string dir = XBARSIM_TEST_OUTPUT_DIR;
  const std::string page = dir + "/report_test.html", png = dir + "/report_screenshot.png", log = dir + "/chromium.log";
  write_html_report(page, sample());
  std::remove(png.c_str());
  const std::string flags = " --headless=new --no-sandbox --disable-gpu --hide-scrollbars --window-size=1280,3600 ";
  std::string dom;
  ASSERT_EQ(run("timeout 90 " + browser + flags + "--dump-dom file://" + page + " 2>" + log, &dom), 0)
      << "chromium --dump-dom failed; see " << log;
  ASSERT_EQ(run("timeout 90 " + browser + flags + "--screenshot=" + png + " file://" + page + " 2>>" + log), 0)
      << "chromium --screenshot failed; see " << log;
  std::printf("screenshot: %s\n", png.c_str());
  // Each plot's box on the page, as the page's own script measured it in the browser.
  const size_t a = dom.find("<pre id=\"layout\" hidden=\"\">");
  ASSERT_NE(a, std::string::npos) << "no layout in the rendered DOM";
  std::istringstream layout(dom.substr(a + 27, dom.find("</pre>", a) - a - 27));
  std::map<std::string, std::array<int, 4>> boxes;
  std::string id;
  std::array<int, 4> b;
  while (layout >> id >> b[0] >> b[1] >> b[2] >> b[3]) boxes[id] = b;
  std::string error;
  const Image img = read_png(png, error);
  ASSERT_TRUE(error.empty()) << error;
  for (const char* plot_id : kPlots) {
    ASSERT_TRUE(boxes.count(plot_id)) << plot_id << " not laid out";
    const auto& bx = boxes[plot_id];
    ASSERT_GT(bx[2], 100) << plot_id;
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
