#pragma once
/// The HTML report (--report FILE.html of explore, eval, xbar-study and simulate): one
/// self-contained page — inline CSS and SVG, nothing fetched when it is viewed — with the
/// Pareto scatter, accuracy vs converter bits, per-layer error propagation, power and area by
/// component, per-layer latency/busy/stall and the configuration. Plots whose data a command
/// does not produce are replaced by a line saying so.
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
  std::vector<std::string> objectives;  ///< Pareto objectives (names), shown in the summary
  /// One object per design point / run. Fields (all optional but "label"): label, point
  /// {key: value}, status ok|failed, reason, accuracy, software_accuracy, accuracy_drop
  /// (fractions), accuracy_drop_ci95 [low, high], warnings [text],
  /// mean_relative_error, worst_relative_error, energy_uj_per_image, area_mm2, latency_us,
  /// avg_power_mw, time_ns_per_image, energy_breakdown_uj {component: uJ}, area_breakdown_mm2,
  /// adc_bits, dac_bits (number or "none"), layers [{name, mean_relative_error,
  /// worst_relative_error, busy_us, stall_us}], front (bool).
  nlohmann::json rows = nlohmann::json::array();
};

std::string render_html_report(const ReportInput& in);
/// Writes render_html_report(in) to `path` atomically; throws InputError.
void write_html_report(const std::string& path, const ReportInput& in);

}  // namespace xbarsim
