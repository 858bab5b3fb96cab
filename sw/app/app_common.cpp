#include "sw/app/app_common.h"

#include <unistd.h>

#include <chrono>
#include <climits>
#include <cstdio>
#include <fstream>

#include "sw/common/errors.h"

namespace xbarsim {

ConfigTree load_config(const CliArgs& args) { return ConfigTree::load(args.get("--config"), args.sets()); }

void write_json(const std::string& path, const nlohmann::json& j) { write_text_file(path, j.dump(2) + "\n"); }

void check_outputs(const CliArgs& args, const std::vector<std::string>& output_flags) {
  std::vector<std::string> inputs, outputs;
  for (const auto& kv : args.values()) {
    bool is_output = false;
    for (const auto& f : output_flags) is_output = is_output || kv.first == f;
    (is_output ? outputs : inputs).push_back(kv.second);
  }
  for (const auto& f : output_flags) {
    if (!args.has(f)) continue;
    check_output_path(args.get(f), f, inputs);
    int same = 0;
    for (const auto& o : outputs) same += o == args.get(f);
    if (same > 1) throw InputError(f + " '" + args.get(f) + "' is also named by another output option");
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

std::vector<std::vector<std::pair<std::string, std::string>>> sweep_combinations(const ConfigTree& cfg) {
  const unsigned long long points = cfg.sweep_points();
  const long long limit = cfg.get_int("limits.max_sweep_points");
  if (points > static_cast<unsigned long long>(limit)) {
    std::string keys;
    for (const auto& k : cfg.sweep_keys()) keys += (keys.empty() ? "" : ", ") + k;
    throw InputError("the sweep over " + keys + " has " +
                     (points == ULLONG_MAX ? std::string("more than 1.8e19") : std::to_string(points)) +
                     " points, more than limits.max_sweep_points = " + std::to_string(limit) +
                     " (raise it to run this sweep)");
  }
  if (points > 1) std::fprintf(stderr, "sweep: %llu points\n", points);
  std::vector<std::vector<std::pair<std::string, std::string>>> out(1);
  for (const auto& key : cfg.sweep_keys()) {
    std::vector<std::vector<std::pair<std::string, std::string>>> next;
    for (const auto& combo : out)
      for (const auto& v : cfg.list_items(key)) {
        auto c = combo;
        c.emplace_back(key, v);
        next.push_back(c);
      }
    out.swap(next);
  }
  return out;
}

ConfigTree sweep_point(const ConfigTree& base, const std::vector<std::pair<std::string, std::string>>& combo) {
  ConfigTree cfg = base;
  for (const auto& kv : combo) cfg.set(kv.first, kv.second);
  return cfg;
}

void for_each_sweep_point(const ConfigTree& base,
                          const std::vector<std::vector<std::pair<std::string, std::string>>>& combos,
                          const std::function<void(const ConfigTree&)>& f) {
  ProgressBar bar(static_cast<int>(combos.size()), "checking sweep points");
  int done = 0;
  for (const auto& combo : combos) {
    f(sweep_point(base, combo));
    if (combos.size() > 100) bar.update(++done);
  }
}

std::string sweep_label(const std::vector<std::pair<std::string, std::string>>& combo) {
  std::string label;
  for (const auto& kv : combo)
    label += (label.empty() ? "" : " ") + kv.first.substr(kv.first.rfind('.') + 1) + "=" + kv.second;
  return label.empty() ? "default" : label;
}

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

namespace {
double now_s() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}
}  // namespace

ProgressBar::ProgressBar(int total, std::string label)
    : total_(total), label_(std::move(label)), tty_(isatty(2)), start_(now_s()) {}

ProgressBar::~ProgressBar() { finish(); }

void ProgressBar::update(int done) {
  if (!tty_ || finished_) return;
  const double t = now_s();
  if (done < total_ && t - last_ < 0.2) return;
  last_ = t;
  const int width = 30;
  const int fill = total_ > 0 ? static_cast<int>(static_cast<double>(width) * done / total_) : width;
  const double rate = done / std::max(t - start_, 1e-9);
  std::fprintf(stderr, "\r%s [%.*s%*s] %d/%d  %.1f/s ", label_.c_str(), fill, "==============================",
               width - fill, "", done, total_, rate);
  std::fflush(stderr);
}

void ProgressBar::finish() {
  if (!tty_ || finished_) return;
  finished_ = true;
  std::fprintf(stderr, "\n");
}

}  // namespace xbarsim
