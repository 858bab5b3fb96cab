// xbarsim overhead: argument parsing and rendering of the dense vs sparse mapping cost
// (sw/study/overhead_study.h).
#include <chrono>
#include <cstdio>
#include <memory>

#include "sw/app/app_common.h"
#include "sw/app/model_source.h"
#include "sw/app/table.h"
#include "sw/study/overhead_study.h"

namespace xbarsim {

namespace {

std::vector<Table::Cell> cells(const std::string& name, const std::string& kernel, const std::string& input,
                               const std::string& map, const MappingOverhead& c) {
  const LayerInventory& v = c.inv;
  return {name,
          kernel,
          input,
          map,
          std::to_string(v.rows) + " x " + std::to_string(v.cols),
          v.crossbars,
          v.adcs,
          v.dacs,
          v.utilization(),
          c.peak_power_mw.crossbar,
          c.area_mm2.crossbar,
          c.peak_power_mw.arrays_and_converters(),
          c.area_mm2.arrays_and_converters(),
          v.iterations};
}

/// One CSV row per layer and mapping.
void write_csv(std::ostream& os, const OverheadReport& rep) {
  const Table t(
      {{"layer", 0},       {"k_h", 0},           {"k_w", 0},           {"c_in", 0},           {"c_out", 0},
       {"in_h", 0},        {"in_w", 0},          {"mapping", 0},       {"rows", 0},           {"cols", 0},
       {"crossbars", 0},   {"adcs", 0},          {"dacs", 0},          {"cells_used", 0},     {"cells_present", 0},
       {"utilization", 0}, {"xbar_power_mw", 0}, {"xbar_area_mm2", 0}, {"total_power_mw", 0}, {"total_area_mm2", 0},
       {"iterations", 0}});
  t.csv_header(os);
  for (const auto& l : rep.layers)
    for (const auto* c : {&l.dense, &l.sparse}) {
      const LayerInventory& v = c->inv;
      t.csv_row(os, {l.name,
                     (long long)l.k_h,
                     (long long)l.k_w,
                     (long long)l.c_in,
                     (long long)l.c_out,
                     (long long)l.input.h,
                     (long long)l.input.w,
                     std::string(c == &l.dense ? "dense" : "sparse"),
                     v.rows,
                     v.cols,
                     v.crossbars,
                     v.adcs,
                     v.dacs,
                     v.cells_used,
                     v.cells_present,
                     v.utilization(),
                     c->peak_power_mw.crossbar,
                     c->area_mm2.crossbar,
                     c->peak_power_mw.arrays_and_converters(),
                     c->area_mm2.arrays_and_converters(),
                     v.iterations});
    }
}

int cmd_overhead(int argc, char** argv) {
  const CliArgs args(argc, argv, 0, {"--model", "--preset", "--input-size"});
  const ConfigTree cfg = load_config(args);
  const auto t0 = std::chrono::steady_clock::now();
  const AnalogConfig ac = parse_analog_config(cfg);
  const HardwareContext hw = make_hardware_context(cfg, ac);
  const Model m = model_from_args(args, cfg);
  check_outputs(args, {"--json", "--csv"});
  const OverheadReport rep = overhead_study(m, hw);
  const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  std::printf("%s: %zu linear layers, crossbars at most %s x %s, ADC %d bit, DAC %d bit, %d columns per ADC (%s)\n",
              m.path.c_str(), rep.layers.size(),
              hw.mapping.max_rows ? std::to_string(hw.mapping.max_rows).c_str() : "unbounded",
              hw.mapping.max_cols ? std::to_string(hw.mapping.max_cols).c_str() : "unbounded",
              hw.cost.adc_bits_priced(), hw.cost.dac_bits_priced(), hw.columns_per_adc, hw.lib.source.c_str());
  const Table table({{"layer", -30},
                     {"kernel", -12},
                     {"input", -9},
                     {"map", -6},
                     {"rows x cols", 19},
                     {"xbars", 8},
                     {"ADCs", 8},
                     {"DACs", 9},
                     {"util", 6, 3},
                     {"xbar_P_mW", 12, 4},
                     {"xbar_A_mm2", 12, 6},
                     {"total_P_mW", 12, 4},
                     {"total_A_mm2", 12, 6},
                     {"iters", 9}});
  table.print_header(stdout);
  std::unique_ptr<OutputFile> csv;
  if (args.has("--csv")) {
    csv = std::make_unique<OutputFile>(args.get("--csv"));
    write_csv(csv->stream(), rep);
    csv->commit();
  }
  for (const auto& l : rep.layers) {
    const std::string kernel = std::to_string(l.k_h) + "x" + std::to_string(l.k_w) + "x" + std::to_string(l.c_in) +
                               "x" + std::to_string(l.c_out);
    const std::string input = std::to_string(l.input.h) + "x" + std::to_string(l.input.w);
    table.print_row(stdout, cells(l.name, kernel, input, "dense", l.dense));
    table.print_row(stdout, cells("", "", "", "sparse", l.sparse));
  }
  table.print_row(stdout, cells("TOTAL", "", "", "dense", rep.dense_total));
  table.print_row(stdout, cells("", "", "", "sparse", rep.sparse_total));
  std::fprintf(stderr, "xbarsim overhead: %.2f ms\n", ms);
  if (args.has("--json")) {
    nlohmann::json j = rep.to_json();
    j["model"] = m.path;
    j["component_library"] = hw.lib.source;
    j["study_time_ms"] = ms;
    write_json(args.get("--json"), j);
  }
  return 0;
}

}  // namespace

namespace {
const CommandRegistrar kRegister{
    "overhead", cmd_overhead,
    "overhead (--model M.onnx | --preset lenet|resnet20|resnet32|resnet56) [--input-size H,W] [--set k=v]...\n"
    "      dense vs sparse (Toeplitz) mapping: crossbars, converters, peak power, area per layer"};
}  // namespace

}  // namespace xbarsim
