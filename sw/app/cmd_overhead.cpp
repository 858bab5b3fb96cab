// xbarsim overhead: dense vs sparse mapping cost of every Conv/Gemm layer.
#include <chrono>
#include <cstdio>
#include <fstream>

#include "sw/app/app_common.h"
#include "sw/app/model_source.h"
#include "sw/hw/overhead.h"

namespace xbarsim {

namespace {

nlohmann::json cost_json(const MappingCost& c) {
  return {{"rows", c.rows},
          {"cols", c.cols},
          {"crossbars", c.crossbars},
          {"adcs", c.adcs},
          {"dacs", c.dacs},
          {"cells_used", c.cells_used},
          {"cells_present", c.cells_present},
          {"utilization", c.utilization()},
          {"xbar_power_mw", c.xbar_power_mw},
          {"xbar_area_mm2", c.xbar_area_mm2},
          {"total_power_mw", c.total_power_mw},
          {"total_area_mm2", c.total_area_mm2},
          {"iterations", c.iterations}};
}

int cmd_overhead(int argc, char** argv) {
  const CliArgs args(argc, argv, 0, {"--model", "--preset", "--input-size"});
  check_outputs(args, {"--json", "--csv"});
  const ConfigTree cfg = load_config(args);
  const auto t0 = std::chrono::steady_clock::now();
  const Model m = model_from_args(args, cfg);
  const HardwareSettings hw = parse_hardware_settings(cfg);
  const ComponentLibrary lib = load_component_library(cfg);
  const auto layers = overhead_study(m, hw, lib);
  const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();

  std::printf("%s: %zu linear layers, crossbars at most %s x %s, ADC %d bit, DAC %d bit (%s)\n", m.path.c_str(),
              layers.size(), hw.max_rows ? std::to_string(hw.max_rows).c_str() : "unbounded",
              hw.max_cols ? std::to_string(hw.max_cols).c_str() : "unbounded", hw.adc_bits, hw.dac_bits,
              lib.source.c_str());
  std::printf("%-30s %-12s %-7s %-6s %15s %6s %6s %7s %6s %12s %12s %12s %10s %8s\n", "layer", "kernel", "input",
              "map", "rows x cols", "xbars", "ADCs", "DACs", "util", "xbar_P_mW", "xbar_A_mm2", "total_P_mW",
              "total_A_mm2", "iters");
  MappingCost dense_total, sparse_total;
  nlohmann::json j;
  j["model"] = m.path;
  j["layers"] = nlohmann::json::array();
  std::unique_ptr<OutputFile> csv_file;
  if (args.has("--csv")) {
    csv_file = std::make_unique<OutputFile>(args.get("--csv"));
    csv_file->stream() << "layer,k_h,k_w,c_in,c_out,in_h,in_w,mapping,rows,cols,crossbars,adcs,dacs,cells_used,cells_present,"
           "utilization,xbar_power_mw,xbar_area_mm2,total_power_mw,total_area_mm2,iterations\n";
  }
  for (const auto& l : layers) {
    const std::string kernel = std::to_string(l.k_h) + "x" + std::to_string(l.k_w) + "x" + std::to_string(l.c_in) +
                               "x" + std::to_string(l.c_out);
    const std::string input = std::to_string(l.input.h) + "x" + std::to_string(l.input.w);
    for (const auto* which : {"dense", "sparse"}) {
      const MappingCost& c = std::string(which) == "dense" ? l.dense : l.sparse;
      const std::string rc = std::to_string(c.rows) + " x " + std::to_string(c.cols);
      std::printf("%-30s %-12s %-7s %-6s %15s %6lld %6lld %7lld %6.3f %12.4g %12.4g %12.4g %10.4g %8lld\n",
                  std::string(which) == "dense" ? l.name.c_str() : "", std::string(which) == "dense" ? kernel.c_str() : "",
                  std::string(which) == "dense" ? input.c_str() : "", which, rc.c_str(), c.crossbars, c.adcs, c.dacs,
                  c.utilization(), c.xbar_power_mw, c.xbar_area_mm2, c.total_power_mw, c.total_area_mm2, c.iterations);
      if (csv_file)
        csv_file->stream() << l.name << "," << l.k_h << "," << l.k_w << "," << l.c_in << "," << l.c_out << "," << l.input.h << ","
            << l.input.w << "," << which << "," << c.rows << "," << c.cols << "," << c.crossbars << "," << c.adcs
            << "," << c.dacs << "," << c.cells_used << "," << c.cells_present << "," << c.utilization() << ","
            << c.xbar_power_mw << "," << c.xbar_area_mm2 << "," << c.total_power_mw << "," << c.total_area_mm2
            << "," << c.iterations << "\n";
    }
    dense_total += l.dense;
    sparse_total += l.sparse;
    j["layers"].push_back({{"name", l.name},
                           {"kernel", {l.k_h, l.k_w, l.c_in, l.c_out}},
                           {"input", {l.input.h, l.input.w}},
                           {"dense", cost_json(l.dense)},
                           {"sparse", cost_json(l.sparse)}});
  }
  std::printf("%-30s %-12s %-7s %-6s %15s %6lld %6lld %7lld %6.3f %12.4g %12.4g %12.4g %10.4g %8lld\n", "TOTAL", "",
              "", "dense", "", dense_total.crossbars, dense_total.adcs, dense_total.dacs, dense_total.utilization(),
              dense_total.xbar_power_mw, dense_total.xbar_area_mm2, dense_total.total_power_mw,
              dense_total.total_area_mm2, dense_total.iterations);
  std::printf("%-30s %-12s %-7s %-6s %15s %6lld %6lld %7lld %6.3f %12.4g %12.4g %12.4g %10.4g %8lld\n", "", "", "",
              "sparse", "", sparse_total.crossbars, sparse_total.adcs, sparse_total.dacs, sparse_total.utilization(),
              sparse_total.xbar_power_mw, sparse_total.xbar_area_mm2, sparse_total.total_power_mw,
              sparse_total.total_area_mm2, sparse_total.iterations);
  std::fprintf(stderr, "xbarsim overhead: %.2f ms\n", ms);
  j["totals"] = {{"dense", cost_json(dense_total)}, {"sparse", cost_json(sparse_total)}};
  j["study_time_ms"] = ms;
  if (csv_file) csv_file->commit();
  if (args.has("--json")) write_json(args.get("--json"), j);
  return 0;
}

}  // namespace

namespace {
const CommandRegistrar kRegister{
    "overhead", cmd_overhead,
    "overhead (--model M.onnx | --preset lenet|resnet20|resnet32|resnet56) [--input-size H,W] [--set k=v]...\n"
    "      dense vs sparse (Toeplitz) mapping: crossbars, converters, power, area per layer"};
}  // namespace

}  // namespace xbarsim
