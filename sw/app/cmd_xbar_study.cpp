// xbarsim xbar-study: one crossbar with a synthetic kernel, the paper's single-crossbar study.
#include <chrono>
#include <cstdio>
#include <fstream>
#include <iostream>

#include "sw/analog/analog_layer.h"
#include "sw/analog/error_metrics.h"
#include "sw/analog/synthetic.h"
#include "sw/app/app_common.h"

namespace xbarsim {

namespace {

struct StudyResult {
  nlohmann::json json;
  Eigen::MatrixXd ideal, actual;
};

/// The `study.` section and the analog configuration it runs, parsed and validated once.
struct StudySpec {
  AnalogConfig ac;
  int rows = 0, cols = 0, vectors = 0;
  double sparsity = 0;
  std::string kernel;
  uint64_t seed = 0;
};

StudySpec parse_study_spec(const ConfigTree& cfg) {
  StudySpec s;
  s.ac = parse_analog_config(cfg, "study.method");
  s.rows = cfg.get_int32("study.rows");
  s.cols = cfg.get_int32("study.cols");
  s.vectors = cfg.get_int32("study.vectors");
  s.sparsity = cfg.get_double("study.sparsity");
  s.kernel = require_one_of(cfg, "study.kernel", {"gaussian", "bimodal", "ternary"});
  s.seed = static_cast<uint64_t>(cfg.get_int("study.seed"));
  const double cells = static_cast<double>(s.vectors) * std::max(s.rows, s.cols);
  if (cells > 2e9)
    throw InputError("study.vectors x study.rows = " + std::to_string(static_cast<long long>(cells)) +
                     " input values is more than a study holds (2e9); use fewer vectors");
  return s;
}

StudyResult run_study(const StudySpec& spec) {
  const AnalogConfig& ac = spec.ac;
  const int rows = spec.rows, cols = spec.cols, vectors = spec.vectors;
  const double sparsity = spec.sparsity;
  const std::string& kernel = spec.kernel;
  const uint64_t seed = spec.seed;

  const auto t0 = std::chrono::steady_clock::now();
  const Eigen::MatrixXd w = synthetic_kernel(kernel, rows, cols, seed);
  const Eigen::MatrixXd x = synthetic_inputs(vectors, rows, sparsity, 1.0, seed + 1);
  // Calibration draws from the same input distribution, never from the test vectors.
  const Eigen::MatrixXd calib = synthetic_inputs(std::max(100, 10 * ac.calibration_samples), rows,
                                                 sparsity, 1.0, seed + 2);
  AnalogLayer layer(ac, w, 1.0, false, seed);
  layer.program(calib);
  const auto t1 = std::chrono::steady_clock::now();
  StudyResult r;
  r.actual = layer.forward(x);
  r.ideal = x * w;
  const auto t2 = std::chrono::steady_clock::now();
  const ErrorStats st = relative_error(r.actual, r.ideal);

  nlohmann::json& j = r.json;
  j["rows"] = rows;
  j["cols"] = cols;
  j["vectors"] = vectors;
  j["kernel"] = kernel;
  j["sparsity"] = sparsity;
  j["method"] = ac.method;
  j["memristor_model"] = to_string(ac.xbar.memristor.model);
  j["transistor_model"] = to_string(ac.xbar.transistor.model);
  j["mean_relative_error"] = st.mean_relative_error;
  j["worst_relative_error"] = st.worst_relative_error;
  j["bit_accuracy_mean"] = st.bit_accuracy_mean();
  j["bit_accuracy_worst"] = st.bit_accuracy_worst();
  int oor = 0, cells = 0, adcs = 0;
  double min_gain = 1;
  j["crossbars"] = nlohmann::json::array();
  for (int b = 0; b < layer.crossbars(); ++b) {
    const CrossbarReport& rep = layer.reports()[b];
    const Block& blk = rep.block;
    oor += rep.out_of_range_cells;
    cells += blk.rows * rep.physical_cols;
    adcs += (rep.physical_cols + 127) / 128;
    min_gain = std::min(min_gain, rep.min_column_gain);
    const Eigen::MatrixXd part = layer.partial(b, x);
    const ErrorStats ps = relative_error(part, x.middleCols(blk.row0, blk.rows) * w.block(blk.row0, blk.col0, blk.rows, blk.cols));
    j["crossbars"].push_back({{"row0", blk.row0}, {"rows", blk.rows}, {"col0", blk.col0}, {"cols", blk.cols},
                              {"physical_cols", rep.physical_cols}, {"out_of_range_cells", rep.out_of_range_cells},
                              {"min_column_gain", rep.min_column_gain},
                              {"conversion_amplitude", rep.conversion_amplitude},
                              {"mean_relative_error", ps.mean_relative_error},
                              {"worst_relative_error", ps.worst_relative_error}});
  }
  j["crossbar_count"] = layer.crossbars();
  j["adc_count"] = adcs;
  j["out_of_range_cells"] = oor;
  j["out_of_range_fraction"] = cells ? static_cast<double>(oor) / cells : 0.0;
  j["min_column_gain"] = min_gain;
  j["column_mean_relative_error"] = std::vector<double>(st.column_mean.data(), st.column_mean.data() + st.column_mean.size());
  j["column_worst_relative_error"] =
      std::vector<double>(st.column_worst.data(), st.column_worst.data() + st.column_worst.size());
  j["program_time_s"] = std::chrono::duration<double>(t1 - t0).count();
  j["evaluate_time_s"] = std::chrono::duration<double>(t2 - t1).count();
  return r;
}

int cmd_xbar_study(int argc, char** argv) {
  const CliArgs args(argc, argv, 0, {});
  check_outputs(args, {"--json", "--csv"});
  const ConfigTree base = load_config(args);
  const auto combos = sweep_combinations(base);
  std::vector<StudySpec> specs;  // every run validated before any output
  for_each_sweep_point(base, combos, [&](const ConfigTree& cfg) { specs.push_back(parse_study_spec(cfg)); });
  nlohmann::json all = nlohmann::json::array();
  SweepCsv csv(args.get("--csv"), combos.front(), "vector,column,ideal,actual");
  std::printf("%-40s %8s %9s %11s %11s %7s %7s %9s %6s\n", "run", "xbars", "oor_cells", "mean_RE_%", "worst_RE_%",
              "bits_m", "bits_w", "min_gain", "time_s");
  int run = 0;
  for (const auto& combo : combos) {
    const std::string label = sweep_label(combo);
    if (combos.size() > 1) std::fprintf(stderr, "[%d/%zu] %s\n", run + 1, combos.size(), label.c_str());
    StudyResult r = run_study(specs[run]);
    nlohmann::json& j = r.json;
    for (const auto& kv : combo) j["sweep"][kv.first] = kv.second;
    std::printf("%-40s %8d %9d %11.4f %11.4f %7.2f %7.2f %9.4f %6.2f\n", label.c_str(), j["crossbar_count"].get<int>(),
                j["out_of_range_cells"].get<int>(), 100 * j["mean_relative_error"].get<double>(),
                100 * j["worst_relative_error"].get<double>(), j["bit_accuracy_mean"].get<double>(),
                j["bit_accuracy_worst"].get<double>(), j["min_column_gain"].get<double>(),
                j["program_time_s"].get<double>() + j["evaluate_time_s"].get<double>());
    std::fflush(stdout);
    if (csv.enabled())
      for (Eigen::Index a = 0; a < r.ideal.rows(); ++a)
        for (Eigen::Index c = 0; c < r.ideal.cols(); ++c)
          csv.row(run, combo) << "," << a << "," << c << "," << r.ideal(a, c) << "," << r.actual(a, c) << "\n";
    all.push_back(j);
    ++run;
  }
  csv.commit();
  if (args.has("--json")) write_json(args.get("--json"), combos.size() == 1 ? all[0] : all);
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
