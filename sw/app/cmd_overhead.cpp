// xbarsim overhead: argument parsing and rendering of the dense vs sparse mapping cost
// (sw/study/overhead_study.h).
#include <chrono>
#include <cstdio>
#include <memory>

#include "sw/app/app_common.h"
#include "sw/app/model_source.h"
#include "sw/app/table.h"
#include "sw/analog/input_slicing.h"
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

/// The machine's bill (IMA, tile, chip), its peak efficiency and the network's mapping on it.
void print_machine(const MachineReport& r, const HardwareContext& hw) {
  const double area = r.area_mm2(), power = r.peak_power_mw();
  std::printf("\nmachine %s (%s): %d tiles x %d IMAs x %d crossbars of %d x %d, %d-bit cells\n", r.name.c_str(),
              hw.arch.source.c_str(), r.tiles, r.imas_per_tile, r.crossbars_per_ima, hw.arch.crossbar.rows,
              hw.arch.crossbar.cols, hw.arch.crossbar.cell_bits);
  const Table bill({{"level", -6}, {"unit", -22}, {"count", 9}, {"area_mm2", 12, 5}, {"peak_mW", 12, 4}});
  bill.print_header(stdout);
  for (const auto& [level, lines] : {std::pair<const char*, const std::vector<BillLine>*>{"IMA", &r.bill.ima},
                                     {"tile", &r.bill.tile},
                                     {"chip", &r.bill.chip}}) {
    for (const BillLine& l : *lines) bill.print_row(stdout, {level, l.unit, l.count, l.area_mm2, l.peak_mw});
    bill.print_row(stdout, {level, "total", "", MachineBill::area(*lines), MachineBill::peak_mw(*lines)});
  }
  std::printf(
      "peak: %.4g TOPS, %.1f GOPS/s/mm^2, %.1f GOPS/W (every crossbar reading: %d-bit inputs in %d reads, "
      "weights on %d columns each)\n",
      r.peak_gops * 1e-3, r.peak_gops / area, r.peak_gops / (power * 1e-3), hw.converters.activation_bits(),
      make_input_slicing(hw.converters.activation_bits(), hw.converters.dac_bits, false, 1.0).slices,
      hw.mapping.columns_per_weight());
  const Mapping& m = r.mapping;  // it fits (overhead_study refuses a network that does not)
  std::printf(
      "mapping: %lld of %lld IMAs (%.1f %%) on %lld of %lld tiles; %.2f %% of the chip's cells hold weights; "
      "predicted bottleneck %s (%.3f us per image)\n",
      m.imas_used, m.imas_available, 100.0 * m.imas_used / m.imas_available, m.tiles_used, m.tiles_available,
      100.0 * m.cell_utilization, m.bottleneck_stage.empty() ? "-" : m.bottleneck_stage.c_str(), m.bottleneck_ns * 1e-3);
  std::vector<std::string> names;
  for (const LayerPlacement& p : m.layers) names.push_back(p.name);
  const Table t({{"layer", fit_width("layer", names)},
                 {"xbars", 6},
                 {"IMAs", 5},
                 {"copies", 6},
                 {"tiles", -9},
                 {"compute_us", 11, 3},
                 {"input_us", 9, 3},
                 {"cell_util", 9, 3}});
  t.print_header(stdout);
  for (const LayerPlacement& p : m.layers)
    t.print_row(stdout, {p.name, p.crossbars, (long long)p.imas, (long long)p.replication,
                         std::to_string(m.tile_of(p.first_ima)) + "-" + std::to_string(m.tile_of(p.last_ima())),
                         p.compute_ns * 1e-3, p.input_ns * 1e-3, p.cell_utilization});
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
  std::vector<std::string> names;
  for (const auto& l : rep.layers) names.push_back(l.name);
  const Table table({{"layer", fit_width("layer", names)},
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
    const std::string kernel = l.kernel_text();
    const std::string input = std::to_string(l.input.h) + "x" + std::to_string(l.input.w);
    table.print_row(stdout, cells(l.name, kernel, input, "dense", l.dense));
    table.print_row(stdout, cells("", "", "", "sparse", l.sparse));
  }
  table.print_row(stdout, cells("TOTAL", "", "", "dense", rep.dense_total));
  table.print_row(stdout, cells("", "", "", "sparse", rep.sparse_total));
  if (rep.machine) print_machine(*rep.machine, hw);
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
