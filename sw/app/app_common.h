#pragma once
/// Helpers shared by the xbarsim subcommands, and the subcommand registry.
#include <nlohmann/json.hpp>
#include <cstdio>
#include <fstream>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "sw/common/cli_args.h"
#include "sw/common/config.h"
#include "sw/common/output_file.h"
#include "sw/common/progress_rate.h"
#include "sw/report/html_report.h"
#include "sw/study/sweep.h"

namespace xbarsim {

/// Configuration from --config (optional) and the --set overrides.
ConfigTree load_config(const CliArgs& args);

/// Writes a JSON report (pretty-printed) to `path` (atomically, checked); throws InputError.
void write_json(const std::string& path, const nlohmann::json& j);

/// Checks, before any work and once the files the run reads are registered (its inputs have
/// been loaded or located, sw/common/input_file.h), every output flag of `output_flags` that
/// was given and the outputs `more` ((flag, path): e.g. a sweep's trace files): writable, not a
/// directory, distinct from each other, from every file the run reads and from the values of
/// all other flags that name existing files. Throws InputError naming the flag and the path.
void check_outputs(const CliArgs& args, const std::vector<std::string>& output_flags,
                   const std::vector<std::pair<std::string, std::string>>& more = {});

/// A CSV file whose rows start with the run index and the run's sweep values.
class SweepCsv {
 public:
  /// Opens `path` (nothing when empty) and writes the header: run, the sweep keys, `columns`.
  SweepCsv(const std::string& path, const std::vector<std::pair<std::string, std::string>>& first_combo,
           const std::string& columns);
  bool enabled() const { return out_ != nullptr; }
  /// Starts a row for `run` / `combo`; the caller appends ",..." fields and a newline.
  std::ostream& row(int run, const std::vector<std::pair<std::string, std::string>>& combo);
  /// Completes the file (until then it is a temporary file beside the target).
  void commit() {
    if (out_) out_->commit();
  }

 private:
  std::unique_ptr<OutputFile> out_;
};

/// {key: value} of a sweep point.
nlohmann::json point_json(const std::vector<std::pair<std::string, std::string>>& point);

/// The network's error from per-layer JSON (eval's "layers"): the mean of the layers' mean
/// relative errors and the largest worst error. False when no layer carries errors.
bool network_errors(const nlohmann::json& layers, double& mean, double& worst);
/// An accuracy drop's 95 % interval as the tables print it, in fractions as everywhere: "-0.0060..+0.0390".
std::string drop_interval_text(double low, double high);

/// The width of a left-aligned table column (negative, as Table::Column takes it) that fits
/// `header` and every one of `values`.
int fit_width(const std::string& header, const std::vector<std::string>& values);

/// A run's warnings, printed after its table: how many of each kind (sw/report's
/// warning_kind) and the first of each with where it came from.
class WarningSummary {
 public:
  void add(const std::string& where, const std::string& text);
  /// "warnings: N in all, of K kinds" and one paragraph per kind; nothing without warnings.
  void print(std::FILE* out) const;

 private:
  struct Kind {
    std::string kind, first;
    int count = 0;
  };
  std::vector<Kind> kinds_;
};

/// The line under a command's tables that says in which units its ratios are.
extern const char* const kFractionsNote;

/// Every stage of simulate's JSON `j` in pipeline order, as the HTML report plots them: the
/// linear layers and the digital stages ({name, kind linear|digital, busy_us, stall_us}, by
/// their "stage") and, on the layer-sized platform, the shared bus ("interconnect", busy
/// interconnect_busy_us_per_image). Empty when `j` has no stages (eval's JSON).
nlohmann::json platform_stages(const nlohmann::json& j);

/// A command's JSON result as a row of the HTML report (sw/report/html_report.h): its sweep
/// point, accuracy, errors (the layers' mean and worst when not given), cost and per-layer data.
nlohmann::json report_row(const nlohmann::json& j, const std::vector<std::pair<std::string, std::string>>& point);

/// What a sweeping command writes: one JSON object per point (with its "sweep" values;
/// the object alone for a single point, a list otherwise), its CSV rows and the HTML report.
class SweepOutputs {
 public:
  SweepOutputs(const CliArgs& args, const std::vector<std::pair<std::string, std::string>>& first_point,
               const std::string& csv_columns);
  /// Names the command, what it ran on (the page's title: "xbarsim eval: M on N images") and
  /// its configuration for --report.
  void set_report(const std::string& command, const ConfigTree& base, const std::string& subject = "");
  SweepCsv& csv() { return csv_; }
  void add(nlohmann::json j, const std::vector<std::pair<std::string, std::string>>& point);
  /// Completes the CSV and writes the JSON (--json) and the report (--report).
  void finish();

 private:
  std::string json_path_, report_path_;
  ReportInput report_;
  SweepCsv csv_;
  nlohmann::json all_ = nlohmann::json::array();
};

/// A progress bar on stderr, drawn only when stderr is a terminal (a log gets a line every
/// 30 s); rate-limited. Its rate and ETA count from the first update, not from construction
/// (RateMeter): the setup before the first item is not spent on the items.
class ProgressBar {
 public:
  ProgressBar(int total, std::string label);
  ~ProgressBar();
  void update(int done);
  /// The same with a new total (e.g. fewer images to evaluate than announced).
  void update(int done, int total) {
    total_ = total;
    update(done);
  }
  void finish();

 private:
  int total_;
  std::string label_;
  bool tty_;
  double start_, last_ = -1;
  RateMeter rate_;
  bool finished_ = false;
};

/// parse_sweep with a progress bar on stderr while the points are checked.
template <typename Spec>
std::vector<Spec> check_sweep(const ConfigTree& base, const std::vector<SweepPoint>& points,
                              const std::function<Spec(const ConfigTree&)>& parse) {
  ProgressBar bar(static_cast<int>(points.size()), "checking sweep points");
  std::vector<Spec> specs = parse_sweep<Spec>(base, points, parse, [&](int d, int) { bar.update(d); });
  bar.finish();
  return specs;
}

/// A subcommand entry point: receives the arguments after the subcommand name.
using CommandFn = int (*)(int argc, char** argv);

struct CommandInfo {
  std::string name;
  CommandFn run;
  std::string usage;    ///< one-line synopsis plus a short description
  bool shards = false;  ///< shares its work among MPI ranks; the others refuse to run under mpirun -n N > 1
};

/// All registered subcommands, sorted by registration order.
std::vector<CommandInfo>& command_registry();

/// Registers a subcommand at static-initialisation time. Use in the command's .cpp
/// (compiled into the xbarsim executable): `static CommandRegistrar reg{"name", fn, "usage"};`
struct CommandRegistrar {
  CommandRegistrar(const char* name, CommandFn fn, const char* usage, bool shards = false) {
    command_registry().push_back({name, fn, usage, shards});
  }
};

}  // namespace xbarsim
