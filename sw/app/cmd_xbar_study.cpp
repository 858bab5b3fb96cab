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

StudyResult run_study(const ConfigTree& cfg) {
  const AnalogConfig ac = parse_analog_config(cfg, "study.method");
  const long long rows = cfg.get_int("study.rows"), cols = cfg.get_int("study.cols");
  const long long vectors = cfg.get_int("study.vectors");
  if (rows < 1 || rows > 1 << 16) throw InputError("configuration key 'study.rows' must be in 1..65536");
  if (cols < 1 || cols > 1 << 16) throw InputError("configuration key 'study.cols' must be in 1..65536");
  if (vectors < 1) throw InputError("configuration key 'study.vectors' must be >= 1");
  const double sparsity = cfg.get_double("study.sparsity");
  if (!(sparsity >= 0 && sparsity < 1)) throw InputError("configuration key 'study.sparsity' must be in [0, 1)");
  const std::string kernel = require_one_of(cfg, "study.kernel", {"gaussian", "bimodal", "ternary"});
  const uint64_t seed = static_cast<uint64_t>(cfg.get_int("study.seed"));

  const auto t0 = std::chrono::steady_clock::now();
  const Eigen::MatrixXd w = synthetic_kernel(kernel, static_cast<int>(rows), static_cast<int>(cols), seed);
  const Eigen::MatrixXd x = synthetic_inputs(static_cast<int>(vectors), static_cast<int>(rows), sparsity, 1.0, seed + 1);
  // Calibration draws from the same input distribution, never from the test vectors.
  const Eigen::MatrixXd calib = synthetic_inputs(std::max(100, 10 * ac.calibration_samples), static_cast<int>(rows),
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
  const ConfigTree base = load_config(args);
  const auto combos = sweep_combinations(base);
  for (const auto& combo : combos) {  // validate every run before any output
    ConfigTree cfg = base;
    for (const auto& kv : combo) cfg.set(kv.first, kv.second);
    parse_analog_config(cfg, "study.method");
    require_one_of(cfg, "study.kernel", {"gaussian", "bimodal", "ternary"});
  }
  nlohmann::json all = nlohmann::json::array();
  SweepCsv csv(args.get("--csv"), combos.front(), "vector,column,ideal,actual");
  std::printf("%-40s %8s %9s %11s %11s %7s %7s %9s %6s\n", "run", "xbars", "oor_cells", "mean_RE_%", "worst_RE_%",
              "bits_m", "bits_w", "min_gain", "time_s");
  int run = 0;
  for (const auto& combo : combos) {
    ConfigTree cfg = base;
    for (const auto& kv : combo) cfg.set(kv.first, kv.second);
    const std::string label = sweep_label(combo);
    if (combos.size() > 1) std::fprintf(stderr, "[%d/%zu] %s\n", run + 1, combos.size(), label.c_str());
    StudyResult r = run_study(cfg);
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
