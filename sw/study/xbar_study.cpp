#include "sw/study/xbar_study.h"

#include <chrono>

#include "sw/analog/synthetic.h"

namespace xbarsim {

const char* to_string(KernelKind k) {
  return k == KernelKind::Bimodal ? "bimodal" : k == KernelKind::Ternary ? "ternary" : "gaussian";
}

XbarStudySpec parse_xbar_study_spec(const ConfigTree& cfg) {
  XbarStudySpec s;
  s.ac = parse_analog_config(cfg, "study.method");
  s.rows = cfg.get_int32("study.rows");
  s.cols = cfg.get_int32("study.cols");
  s.vectors = cfg.get_int32("study.vectors");
  s.sparsity = cfg.get_double("study.sparsity");
  s.kernel = require_enum<KernelKind>(
      cfg, "study.kernel",
      {{"gaussian", KernelKind::Gaussian}, {"bimodal", KernelKind::Bimodal}, {"ternary", KernelKind::Ternary}});
  s.seed = static_cast<uint64_t>(cfg.get_int("study.seed"));
  const double values = static_cast<double>(s.vectors) * std::max(s.rows, s.cols);
  if (values > 2e9)
    throw InputError("study.vectors x study.rows = " + std::to_string(static_cast<long long>(values)) +
                     " input values is more than a study holds (2e9); use fewer vectors");
  if (s.ac.mapping.scheme == MappingScheme::Sparse)
    throw InputError(
        "configuration key 'mapping.scheme': xbar-study maps one weight matrix; 'sparse' (Toeplitz) "
        "applies to convolutions (overhead, simulate)");
  return s;
}

namespace {
std::vector<double> to_vector(const Eigen::VectorXd& v) { return std::vector<double>(v.data(), v.data() + v.size()); }
}  // namespace

nlohmann::json XbarStudyResult::to_json() const {
  nlohmann::json j;
  j["rows"] = spec.rows;
  j["cols"] = spec.cols;
  j["vectors"] = spec.vectors;
  j["kernel"] = to_string(spec.kernel);
  j["sparsity"] = spec.sparsity;
  j["method"] = spec.ac.mitigation.name();
  j["memristor_model"] = to_string(spec.ac.xbar.memristor.model);
  if (spec.ac.xbar.memristor.model == MemristorModel::Sinh) j["memristor_k_per_v"] = spec.ac.xbar.memristor.k_per_v;
  j["dac_predistortion"] = spec.ac.converters.dac_predistortion;
  j["transistor_model"] = to_string(spec.ac.xbar.transistor.model);
  j["mean_relative_error"] = error.mean_relative_error;
  j["worst_relative_error"] = error.worst_relative_error;
  j["bit_accuracy_mean"] = error.bit_accuracy_mean();
  j["bit_accuracy_worst"] = error.bit_accuracy_worst();
  j["crossbars"] = nlohmann::json::array();
  for (const auto& x : crossbars) {
    const Block& b = x.report.block;
    j["crossbars"].push_back({{"row0", b.row0},
                              {"rows", b.rows},
                              {"col0", b.col0},
                              {"cols", b.cols},
                              {"physical_cols", x.report.physical_cols},
                              {"out_of_range_cells", x.report.out_of_range_cells},
                              {"min_column_gain", x.report.min_column_gain},
                              {"conversion_amplitude", x.report.conversion_amplitude},
                              {"mean_relative_error", x.error.mean_relative_error},
                              {"worst_relative_error", x.error.worst_relative_error}});
  }
  j["crossbar_count"] = inventory.crossbars;
  j["adc_count"] = inventory.adcs;
  j["dac_count"] = inventory.dacs;
  j["area_mm2"] = area_mm2.total();
  j["area_breakdown_mm2"] = area_mm2.to_json();
  j["out_of_range_cells"] = out_of_range_cells;
  j["out_of_range_fraction"] =
      inventory.cells_used ? static_cast<double>(out_of_range_cells) / inventory.cells_used : 0.0;
  j["min_column_gain"] = min_column_gain;
  j["column_mean_relative_error"] = to_vector(error.column_mean);
  j["column_worst_relative_error"] = to_vector(error.column_worst);
  j["program_time_s"] = program_time_s;
  j["evaluate_time_s"] = evaluate_time_s;
  return j;
}

XbarStudyResult run_xbar_study(const XbarStudySpec& spec, const HardwareContext& hw) {
  XbarStudyResult r;
  r.spec = spec;
  const AnalogConfig& ac = spec.ac;
  const auto t0 = std::chrono::steady_clock::now();
  const Eigen::MatrixXd w = synthetic_kernel(to_string(spec.kernel), spec.rows, spec.cols, spec.seed);
  const Eigen::MatrixXd x = synthetic_inputs(spec.vectors, spec.rows, spec.sparsity, 1.0, spec.seed + 1);
  // Calibration draws from the same input distribution, never from the test vectors.
  const Eigen::MatrixXd calib =
      synthetic_inputs(std::max(100, 10 * ac.calibration.samples), spec.rows, spec.sparsity, 1.0, spec.seed + 2);
  constexpr bool kSignedInputs = false;  // synthetic inputs span [0, 1]
  AnalogLayer layer(ac, w, 1.0, kSignedInputs, spec.seed);
  layer.program(calib);
  const auto t1 = std::chrono::steady_clock::now();
  r.actual = layer.forward(x);
  r.ideal = x * w;
  r.evaluate_time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t1).count();
  r.program_time_s = std::chrono::duration<double>(t1 - t0).count();
  r.error = relative_error(r.actual, r.ideal);
  r.inventory = matrix_inventory(spec.rows, spec.cols, spec.vectors, ac.mapping, hw.columns_per_adc);
  stream_inputs(r.inventory, ac.converters, kSignedInputs);
  r.area_mm2 = hw.arch.core().layer_area_mm2(hw, r.inventory);
  for (int b = 0; b < layer.crossbars(); ++b) {
    const CrossbarReport& rep = layer.reports()[b];
    const Block& blk = rep.block;
    r.out_of_range_cells += rep.out_of_range_cells;
    r.min_column_gain = std::min(r.min_column_gain, rep.min_column_gain);
    const Eigen::MatrixXd ideal_b = x.middleCols(blk.row0, blk.rows) * w.block(blk.row0, blk.col0, blk.rows, blk.cols);
    r.crossbars.push_back({rep, relative_error(layer.partial(b, x), ideal_b)});
  }
  return r;
}

}  // namespace xbarsim
