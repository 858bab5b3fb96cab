// xbarsim xbar-study: argument parsing and rendering of the single-crossbar study
// (sw/study/xbar_study.h).
#include <cstdio>

#include "sw/app/app_common.h"
#include "sw/app/table.h"
#include "sw/study/sweep.h"
#include "sw/study/xbar_study.h"

namespace xbarsim {

namespace {

struct PointSpec {
  XbarStudySpec study;
  HardwareContext hw;
};

int cmd_xbar_study(int argc, char** argv) {
  const CliArgs args(argc, argv, 0, {});
  check_outputs(args, {"--json", "--csv"});
  const ConfigTree base = load_config(args);
  const auto points = sweep_points(base);
  const std::vector<PointSpec> specs = check_sweep<PointSpec>(base, points, [](const ConfigTree& cfg) {
    PointSpec p{parse_xbar_study_spec(cfg), {}};
    p.hw = make_hardware_context(cfg, p.study.ac);
    return p;
  });
  SweepOutputs out(args, points.front(), "vector,column,ideal,actual");
  const Table table({{"run", -40},
                     {"xbars", 8},
                     {"oor_cells", 9},
                     {"mean_RE_%", 11},
                     {"worst_RE_%", 11},
                     {"bits_m", 7, 2},
                     {"bits_w", 7, 2},
                     {"min_gain", 9},
                     {"time_s", 6, 2}});
  table.print_header(stdout);
  for (size_t run = 0; run < points.size(); ++run) {
    const std::string label = sweep_label(points[run]);
    if (points.size() > 1) std::fprintf(stderr, "[%zu/%zu] %s\n", run + 1, points.size(), label.c_str());
    const XbarStudyResult r = run_xbar_study(specs[run].study, specs[run].hw);
    table.print_row(stdout, {label, r.inventory.crossbars, r.out_of_range_cells, 100 * r.error.mean_relative_error,
                             100 * r.error.worst_relative_error, r.error.bit_accuracy_mean(),
                             r.error.bit_accuracy_worst(), r.min_column_gain, r.program_time_s + r.evaluate_time_s});
    if (out.csv().enabled())
      for (Eigen::Index a = 0; a < r.ideal.rows(); ++a)
        for (Eigen::Index c = 0; c < r.ideal.cols(); ++c)
          out.csv().row(static_cast<int>(run), points[run])
              << "," << a << "," << c << "," << r.ideal(a, c) << "," << r.actual(a, c) << "\n";
    nlohmann::json j = r.to_json();
    out.add(std::move(j), points[run]);
  }
  out.finish();
  return 0;
}

}  // namespace

namespace {
const CommandRegistrar kRegister{
    "xbar-study", cmd_xbar_study,
    "xbar-study [--config F] [--set study.rows=576 --set study.method=[none,conversion]]... [--json F] [--csv F]\n"
    "      single-crossbar error study (mapping, conversion, calibration, converters, noise); list values sweep"};
}  // namespace

}  // namespace xbarsim
