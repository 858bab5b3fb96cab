#pragma once
/// The HTML report (--report FILE.html of explore, eval, xbar-study and simulate): one
/// self-contained page — inline CSS and SVG, nothing fetched when it is viewed — that leads
/// with what its command measures (explore: the Pareto front; simulate: throughput, latency,
/// the bottleneck, energy and area; eval: accuracy with its interval and per-layer error),
/// then the rest of what the rows carry, and ends with one line naming what it cannot show.
/// Axes turn logarithmic where a series spans more than 100x; converter-bits plots appear
/// only when the bits were swept.
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace xbarsim {

struct ReportInput {
  std::string command;                  ///< explore, eval, xbar-study or simulate
  std::string title;                    ///< page heading
  std::string config_yaml;              ///< the configuration that produced it
  std::vector<std::string> swept_keys;  ///< keys that vary across rows
  std::string color_key;                ///< key colouring the scatter ("" = the first swept key)
  std::vector<std::string> objectives;  ///< Pareto objectives (names): accuracy, energy, area, latency, power
  double min_accuracy = -1;             ///< explore's accuracy floor (fraction; < 0: none): below it, greyed
  /// One object per design point / run. Fields (all optional but "label"): label, point
  /// {key: value}, status ok|failed, reason, accuracy, software_accuracy, accuracy_drop
  /// (fractions), accuracy_drop_ci95 [low, high], warnings [text],
  /// mean_relative_error, worst_relative_error, energy_uj_per_image, area_mm2, latency_us,
  /// avg_power_mw, peak_power_mw, throughput_images_per_s, bottleneck {stage, busy_us_per_image},
  /// time_ns_per_image, energy_breakdown_uj {component: uJ}, area_breakdown_mm2,
  /// adc_bits, dac_bits (number or "none"), layers [{name, mean_relative_error,
  /// worst_relative_error, busy_us, stall_us}], front (bool).
  nlohmann::json rows = nlohmann::json::array();
};

std::string render_html_report(const ReportInput& in);

/// What kind of warning `text` is, for counting warnings by kind: the text without a leading
/// "layer NAME: " and with every number as '#', up to its first ';'.
std::string warning_kind(const std::string& text);

/// A power as a person reads it: "49.76 mW", "15.46 W" (watts from 10 W up), "15460 W".
std::string power_text(double mw);
/// Writes render_html_report(in) to `path` atomically; throws InputError.
void write_html_report(const std::string& path, const ReportInput& in);

}  // namespace xbarsim
