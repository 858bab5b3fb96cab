#include "sw/app/app_common.h"

#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <fstream>

#include "sw/common/errors.h"

namespace xbarsim {

ConfigTree load_config(const CliArgs& args) { return ConfigTree::load(args.get("--config"), args.sets()); }

void write_json(const std::string& path, const nlohmann::json& j) {
  std::ofstream out(path);
  if (!out) throw InputError("cannot write '" + path + "'");
  out << j.dump(2) << "\n";
  if (!out) throw InputError("error while writing '" + path + "'");
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

std::string sweep_label(const std::vector<std::pair<std::string, std::string>>& combo) {
  std::string label;
  for (const auto& kv : combo)
    label += (label.empty() ? "" : " ") + kv.first.substr(kv.first.rfind('.') + 1) + "=" + kv.second;
  return label.empty() ? "default" : label;
}

SweepCsv::SweepCsv(const std::string& path, const std::vector<std::pair<std::string, std::string>>& first_combo,
                   const std::string& columns) {
  if (path.empty()) return;
  out_.open(path);
  if (!out_) throw InputError("cannot write '" + path + "'");
  out_.precision(12);
  out_ << "run";
  for (const auto& kv : first_combo) out_ << "," << kv.first;
  out_ << "," << columns << "\n";
}

std::ostream& SweepCsv::row(int run, const std::vector<std::pair<std::string, std::string>>& combo) {
  out_ << run;
  for (const auto& kv : combo) out_ << "," << kv.second;
  return out_;
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
