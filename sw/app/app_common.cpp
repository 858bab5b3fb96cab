#include "sw/app/app_common.h"

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <string>
#include <cstdio>
#include <fstream>

#include "sw/common/errors.h"
#include "sw/common/input_file.h"
#include "sw/common/ranks.h"
#include "sw/report/html_report.h"

namespace xbarsim {

ConfigTree load_config(const CliArgs& args) { return ConfigTree::load(args.get("--config"), args.sets()); }

void write_json(const std::string& path, const nlohmann::json& j) { write_text_file(path, j.dump(2) + "\n"); }

void check_outputs(const CliArgs& args, const std::vector<std::string>& output_flags,
                   const std::vector<std::pair<std::string, std::string>>& more) {
  std::vector<std::string> inputs;
  std::vector<std::pair<std::string, std::string>> outputs;  // (flag, path)
  const auto is_output = [&](const std::string& flag) {
    return std::find(output_flags.begin(), output_flags.end(), flag) != output_flags.end() ||
           std::any_of(more.begin(), more.end(), [&](const auto& o) { return o.first == flag; });
  };
  for (const auto& kv : args.values())
    if (!is_output(kv.first)) inputs.push_back(kv.second);
  for (const auto& f : output_flags)
    if (args.has(f)) outputs.emplace_back(f, args.get(f));
  outputs.insert(outputs.end(), more.begin(), more.end());
  for (size_t i = 0; i < outputs.size(); ++i) {
    check_output_path(outputs[i].second, outputs[i].first, inputs);
    for (size_t k = 0; k < i; ++k)
      if (outputs[k].second == outputs[i].second || same_file(outputs[k].second, outputs[i].second))
        throw InputError(outputs[i].first + " '" + outputs[i].second + "' is also the file of " + outputs[k].first);
  }
}

}  // namespace xbarsim

namespace xbarsim {
std::vector<CommandInfo>& command_registry() {
  static std::vector<CommandInfo> registry;
  return registry;
}
}  // namespace xbarsim

namespace xbarsim {

SweepCsv::SweepCsv(const std::string& path, const std::vector<std::pair<std::string, std::string>>& first_combo,
                   const std::string& columns) {
  if (path.empty()) return;
  out_ = std::make_unique<OutputFile>(path);
  std::ostream& os = out_->stream();
  os.precision(12);
  os << "run";
  for (const auto& kv : first_combo) os << "," << kv.first;
  os << "," << columns << "\n";
}

std::ostream& SweepCsv::row(int run, const std::vector<std::pair<std::string, std::string>>& combo) {
  std::ostream& os = out_->stream();
  os << run;
  for (const auto& kv : combo) os << "," << kv.second;
  return os;
}

SweepOutputs::SweepOutputs(const CliArgs& args, const std::vector<std::pair<std::string, std::string>>& first_point,
                           const std::string& csv_columns)
    : json_path_(args.get("--json")),
      report_path_(args.get("--report")),
      csv_(args.get("--csv"), first_point, csv_columns) {}

void SweepOutputs::set_report(const std::string& command, const ConfigTree& base, const std::string& subject) {
  report_.command = command;
  report_.title = "xbarsim " + command + (subject.empty() ? "" : ": " + subject);
  report_.config_yaml = base.dump();
  report_.swept_keys = base.sweep_keys();
}

void SweepOutputs::add(nlohmann::json j, const std::vector<std::pair<std::string, std::string>>& point) {
  if (!report_path_.empty()) report_.rows.push_back(report_row(j, point));
  for (const auto& kv : point) j["sweep"][kv.first] = kv.second;
  all_.push_back(std::move(j));
}

void SweepOutputs::finish() {
  csv_.commit();
  if (!json_path_.empty()) write_json(json_path_, all_.size() == 1 ? all_[0] : all_);
  if (!report_path_.empty()) write_html_report(report_path_, report_);
}

nlohmann::json point_json(const std::vector<std::pair<std::string, std::string>>& point) {
  nlohmann::json j = nlohmann::json::object();
  for (const auto& kv : point) j[kv.first] = kv.second;
  return j;
}

bool network_errors(const nlohmann::json& layers, double& mean, double& worst) {
  mean = worst = 0;
  bool errors = false;
  for (const auto& l : layers)
    if (l.contains("mean_relative_error")) {
      errors = true;
      mean += l["mean_relative_error"].get<double>() / layers.size();
      worst = std::max(worst, l["worst_relative_error"].get<double>());
    }
  return errors;
}

std::string drop_interval_text(double low, double high) {
  char s[64];
  std::snprintf(s, sizeof s, "%+.4f..%+.4f", low, high);
  return s;
}

const char* const kFractionsNote =
    "accuracies, drops and relative errors are fractions (0.9 = 90 %), as in the CSV and the JSON";

int fit_width(const std::string& header, const std::vector<std::string>& values) {
  size_t w = header.size();
  for (const auto& v : values) w = std::max(w, v.size());
  return -static_cast<int>(w);
}

void WarningSummary::add(const std::string& where, const std::string& text) {
  const std::string k = warning_kind(text);
  for (Kind& x : kinds_)
    if (x.kind == k) {
      ++x.count;
      return;
    }
  kinds_.push_back({k, where.empty() ? text : where + ": " + text, 1});
}

void WarningSummary::print(std::FILE* out) const {
  if (kinds_.empty()) return;
  int total = 0;
  for (const Kind& k : kinds_) total += k.count;
  std::fprintf(out, "\nwarnings: %d in all, of %zu kind%s\n", total, kinds_.size(), kinds_.size() == 1 ? "" : "s");
  for (const Kind& k : kinds_) std::fprintf(out, "  %d x %s\n    first: %s\n", k.count, k.kind.c_str(), k.first.c_str());
}

nlohmann::json platform_stages(const nlohmann::json& j) {
  std::vector<std::pair<long long, nlohmann::json>> order;  // (place in the pipeline, stage)
  for (const char* list : {"layers", "digital_stages"}) {
    if (!j.contains(list) || !j[list].is_array()) continue;
    for (const auto& s : j[list]) {
      if (!s.is_object() || !s.contains("stage") || !s["stage"].is_number_integer() || !s.contains("busy_us")) continue;
      nlohmann::json S = {{"name", s.value("name", std::string())},
                          {"kind", std::string(list) == "layers" ? "linear" : "digital"}};
      for (const char* k : {"busy_us", "stall_us"})
        if (s.contains(k)) S[k] = s[k];
      order.emplace_back(s["stage"].get<long long>(), std::move(S));
    }
  }
  std::stable_sort(order.begin(), order.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  nlohmann::json stages = nlohmann::json::array();
  for (auto& s : order) stages.push_back(std::move(s.second));
  // The shared bus carries every stage's outputs: a stage of its own, which may bound the run.
  if (!stages.empty() && j.contains("interconnect_busy_us_per_image"))
    stages.push_back({{"name", "interconnect (platform.bus_lanes)"},
                      {"kind", "interconnect"},
                      {"busy_us", j["interconnect_busy_us_per_image"]},
                      {"stall_us", 0.0}});
  return stages;
}

nlohmann::json report_row(const nlohmann::json& j, const std::vector<std::pair<std::string, std::string>>& point) {
  nlohmann::json row;
  row["label"] = sweep_label(point);
  row["point"] = point_json(point);
  if (j.contains("crossbar_accuracy")) row["accuracy"] = j["crossbar_accuracy"];
  for (const char* k : {"accuracy", "software_accuracy", "images", "mean_relative_error", "worst_relative_error",
                        "energy_uj_per_image", "area_mm2", "latency_us", "avg_power_mw", "ideal_avg_power_mw",
                        "peak_power_mw", "throughput_images_per_s", "bottleneck", "time_ns_per_image",
                        "energy_breakdown_uj", "area_breakdown_mm2", "adc_bits", "dac_bits", "accuracy_drop",
                        "accuracy_drop_ci95", "warnings", "unit_utilization"})
    if (j.contains(k) && !row.contains(k)) row[k] = j[k];
  if (j.contains("layers") && j["layers"].is_array()) {
    row["layers"] = nlohmann::json::array();
    for (const auto& l : j["layers"]) {
      nlohmann::json L = {{"name", l.value("name", std::string())}};
      for (const char* k : {"mean_relative_error", "worst_relative_error", "busy_us", "stall_us", "bound_by"})
        if (l.contains(k)) L[k] = l[k];
      row["layers"].push_back(L);
    }
    double mean = 0, worst = 0;
    if (network_errors(j["layers"], mean, worst) && !row.contains("mean_relative_error")) {
      row["mean_relative_error"] = mean;
      row["worst_relative_error"] = worst;
    }
  }
  const nlohmann::json stages = platform_stages(j);
  if (!stages.empty()) row["stages"] = stages;
  return row;
}

namespace {
double now_s() { return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count(); }
}  // namespace

ProgressBar::ProgressBar(int total, std::string label)
    : total_(total), label_(std::move(label)), tty_(isatty(2)), start_(now_s()) {}

ProgressBar::~ProgressBar() { finish(); }

namespace {
/// "1h02m", "3m05s", "12s".
std::string duration_text(double s) {
  char buf[32];
  const long t = std::lround(std::max(s, 0.0));
  if (t >= 3600)
    std::snprintf(buf, sizeof buf, "%ldh%02ldm", t / 3600, t / 60 % 60);
  else if (t >= 60)
    std::snprintf(buf, sizeof buf, "%ldm%02lds", t / 60, t % 60);
  else
    std::snprintf(buf, sizeof buf, "%lds", t);
  return buf;
}
}  // namespace

void ProgressBar::update(int done) {
  if (finished_ || !Ranks::root()) return;  // under MPI, rank 0 speaks for the job
  const double t = now_s();
  rate_.observe(t, done);
  // A terminal gets a bar redrawn 5 times a second; a log file a line every 30 s.
  if (done < total_ && t - last_ < (tty_ ? 0.2 : 30.0)) return;
  if (!tty_ && (last_ < 0 && t - start_ < 30.0)) return;
  last_ = t;
  const double rate = rate_.rate(), left_s = rate_.eta_s(total_);
  const std::string eta = done < total_ && left_s >= 0 ? "  ETA " + duration_text(left_s) : "";
  if (!tty_) {
    std::fprintf(stderr, "%s: %d/%d  %.3g/s%s\n", label_.c_str(), done, total_, rate, eta.c_str());
    return;
  }
  const int width = 30;
  const int fill = total_ > 0 ? static_cast<int>(static_cast<double>(width) * done / total_) : width;
  std::fprintf(stderr, "\r%s [%.*s%*s] %d/%d  %.3g/s%s   ", label_.c_str(), fill,
               "==============================", width - fill, "", done, total_, rate, eta.c_str());
  std::fflush(stderr);
}

void ProgressBar::finish() {
  if (!tty_ || finished_) return;
  finished_ = true;
  std::fprintf(stderr, "\n");
}

}  // namespace xbarsim
