#pragma once
/// xbar-study as a library function: one crossbar (or its partitions) with a synthetic
/// kernel, the paper's single-crossbar study.
#include <string>
#include <vector>

#include "sw/analog/error_metrics.h"
#include "sw/study/hardware.h"

namespace xbarsim {

enum class KernelKind { Gaussian, Bimodal, Ternary };
const char* to_string(KernelKind k);

/// The `study.` section and the analog configuration it runs, parsed and validated once.
struct XbarStudySpec {
  AnalogConfig ac;
  int rows = 0, cols = 0, vectors = 0;
  double sparsity = 0;
  KernelKind kernel = KernelKind::Gaussian;
  uint64_t seed = 0;
};
XbarStudySpec parse_xbar_study_spec(const ConfigTree& cfg);

struct XbarStudyCrossbar {
  CrossbarReport report;
  ErrorStats error;  ///< of this crossbar's partial output
};

struct XbarStudyResult {
  XbarStudySpec spec;
  ErrorStats error;
  std::vector<XbarStudyCrossbar> crossbars;
  LayerInventory inventory;  ///< the one counting rule (vectors = iterations)
  ComponentBreakdown area_mm2;
  long long out_of_range_cells = 0;
  double min_column_gain = 1, program_time_s = 0, evaluate_time_s = 0;
  Eigen::MatrixXd ideal, actual;  ///< vectors x cols
  nlohmann::json to_json() const;
};

XbarStudyResult run_xbar_study(const XbarStudySpec& spec, const HardwareContext& hw);

}  // namespace xbarsim
