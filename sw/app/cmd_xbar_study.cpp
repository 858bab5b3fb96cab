// xbarsim xbar-study: argument parsing and rendering of the single-crossbar study
// (sw/study/xbar_study.h).
#include <cstdio>
#include <sstream>

#include "sw/app/app_common.h"
#include "sw/app/table.h"
#include "sw/common/ranks.h"
#include "sw/study/sweep.h"
#include "sw/study/xbar_study.h"

namespace xbarsim {

namespace {

struct PointSpec {
  XbarStudySpec study;
  HardwareContext hw;
};

int cmd_xbar_study(int argc, char** argv) {
  const CliArgs args(argc, argv, 0, {"--report"});
  const ConfigTree base = load_config(args);
  const auto points = sweep_points(base);
  const std::vector<PointSpec> specs = check_sweep<PointSpec>(base, points, [](const ConfigTree& cfg) {
    PointSpec p{parse_xbar_study_spec(cfg), {}};
    p.hw = make_hardware_context(cfg, p.study.ac);
    return p;
  });
  check_outputs(args, {"--json", "--csv", "--report"});  // the configuration and component library are read
  const std::vector<std::string> labels = sweep_labels(points);
  const Table table({{"run", fit_width("run", labels)},
                     {"xbars", 8},
                     {"oor_cells", 9},
                     {"mean_rel_error", 14, 6},
                     {"worst_rel_error", 15, 6},
                     {"bits_m", 7, 2},
                     {"bits_w", 7, 2},
                     {"min_gain", 9},
                     {"time_s", 6, 2}});
  // Under MPI the points are shared round-robin among the ranks; rank 0 prints and writes
  // them in order once every rank is done (with one rank, each as it finishes).
  const int rank = Ranks::rank(), ranks = Ranks::size();
  std::unique_ptr<SweepOutputs> out;
  if (rank == 0) {
    out = std::make_unique<SweepOutputs>(args, points.front(), "vector,column,ideal,actual");
    out->set_report("xbar-study", base);
    table.print_header(stdout);
  }
  auto emit = [&](size_t run, const nlohmann::json& done) {
    const nlohmann::json& j = done["json"];
    table.print_row(stdout, {labels[run], j["crossbar_count"].get<long long>(),
                             j["out_of_range_cells"].get<long long>(), j["mean_relative_error"].get<double>(),
                             j["worst_relative_error"].get<double>(), done["bits_mean"].get<double>(),
                             done["bits_worst"].get<double>(), j["min_column_gain"].get<double>(),
                             j["program_time_s"].get<double>() + j["evaluate_time_s"].get<double>()});
    if (out->csv().enabled()) {
      const std::string& rows = done["csv"].get_ref<const std::string&>();
      for (size_t a = 0, b; a < rows.size(); a = b + 1) {
        b = rows.find('\n', a);
        out->csv().row(static_cast<int>(run), points[run]) << rows.substr(a, b - a + 1);
      }
    }
    out->add(j, points[run]);
  };
  nlohmann::json mine = nlohmann::json::array();
  for (size_t run = rank; run < points.size(); run += ranks) {
    const std::string& label = labels[run];
    if (points.size() > 1 && rank == 0) std::fprintf(stderr, "[%zu/%zu] %s\n", run + 1, points.size(), label.c_str());
    const XbarStudyResult r = run_xbar_study(specs[run].study, specs[run].hw);
    std::string csv;
    if (!args.get("--csv").empty()) {
      std::ostringstream os;
      os.precision(12);
      for (Eigen::Index a = 0; a < r.ideal.rows(); ++a)
        for (Eigen::Index c = 0; c < r.ideal.cols(); ++c)
          os << "," << a << "," << c << "," << r.ideal(a, c) << "," << r.actual(a, c) << "\n";
      csv = os.str();
    }
    nlohmann::json done = {{"run", run},
                           {"json", r.to_json()},
                           {"bits_mean", r.error.bit_accuracy_mean()},
                           {"bits_worst", r.error.bit_accuracy_worst()},
                           {"csv", csv}};
    if (ranks == 1)
      emit(run, done);
    else
      mine.push_back(std::move(done));
  }
  if (ranks > 1) {
    const std::vector<std::string> all = Ranks::gather(mine.dump());
    if (rank != 0) return 0;
    std::vector<nlohmann::json> by_run(points.size());
    for (const std::string& part : all)
      for (auto& done : nlohmann::json::parse(part)) {
        const size_t run = done["run"];  // (before the move: an assignment's right side goes first)
        by_run[run] = std::move(done);
      }
    for (size_t run = 0; run < points.size(); ++run) emit(run, by_run[run]);
  }
  std::printf("\n%s\n", kFractionsNote);
  out->finish();
  return 0;
}

}  // namespace

namespace {
const CommandRegistrar kRegister{
    "xbar-study", cmd_xbar_study,
    "xbar-study [--config F] [--set study.rows=576 --set study.method=[none,conversion]]... [--json F] [--csv F]\n"
    "           [--report F.html]\n"
    "      single-crossbar error study (mapping, conversion, calibration, converters, noise); list values sweep;\n"
    "      under mpirun the sweep points are shared among the ranks",
    true};
}  // namespace

}  // namespace xbarsim
