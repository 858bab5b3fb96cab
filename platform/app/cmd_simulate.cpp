// xbarsim simulate: the SystemC/TLM-2.0 accelerator (platform/Pipeline.h) running a network.
// Argument parsing and rendering; timing, stalls and throughput come from the simulation,
// counts from the shared inventory, energy from the actions the processes counted.
#include <cstdio>

#include "platform/app/simulation.h"
#include "sw/app/app_common.h"
#include "sw/app/model_source.h"
#include "sw/app/table.h"
#include "sw/study/hardware.h"
#include "sw/study/sweep.h"

namespace xbarsim {

namespace {

/// One simulation in this process: the model and images of the arguments.
nlohmann::json simulate_once(const CliArgs& args, const ConfigTree& cfg, bool print) {
  Model model = model_from_args(args, cfg);
  apply_preprocessing_overrides(cfg, model.pre, model.input.c);
  const int images = make_hardware_context(cfg, parse_analog_config(cfg)).platform.images;
  const SimulationData data = simulation_data(args.get("--dataset"), cfg, model, images);
  return simulate_model(cfg, model, data, args.get("--vcd"), print);
}

void print_summary(const nlohmann::json& j) {
  std::printf(
      "\n%s, %s timing, %s schedule, %d images: %lld iterations/image, latency %.3f us, makespan %.3f us, "
      "%.0f images/s\nenergy %.3f uJ/image, average power %.2f mW, peak power %.1f mW, area %.4f mm2\n",
      j["model"].get<std::string>().c_str(), j["timing"].get<std::string>().c_str(),
      j["schedule"].get<std::string>().c_str(), j["images"].get<int>(), j["iterations_total"].get<long long>(),
      j["latency_us"].get<double>(), j["makespan_us"].get<double>(), j["throughput_images_per_s"].get<double>(),
      j["energy_uj_per_image"].get<double>(), j["avg_power_mw"].get<double>(), j["peak_power_mw"].get<double>(),
      j["area_mm2"].get<double>());
  std::printf("simulation: %.2f s wall (%.1f images/s), programming excluded\n",
              j["simulation_wall_time_s"].get<double>(), j["simulated_images_per_wall_s"].get<double>());
  if (j.contains("accuracy")) std::printf("accuracy %.2f %%\n", 100 * j["accuracy"].get<double>());
}

int cmd_simulate(int argc, char** argv) {
  const CliArgs args(argc, argv, 0,
                     {"--model", "--preset", "--dataset", "--images", "--timing", "--vcd", "--vcd-images", "--report"});
  check_outputs(args, {"--json", "--csv", "--vcd", "--report"});
  const std::string vcd = args.get("--vcd");
  if (args.has("--vcd") && (vcd.size() < 5 || vcd.compare(vcd.size() - 4, 4, ".vcd") != 0))
    throw InputError("--vcd '" + vcd + "': the trace file name must end in .vcd (SystemC adds the suffix)");
  std::vector<std::string> sets = args.sets();
  if (args.has("--images")) sets.push_back("platform.images=" + args.get("--images"));
  if (args.has("--timing")) sets.push_back("platform.timing=" + args.get("--timing"));
  if (args.has("--vcd-images")) sets.push_back("platform.vcd_images=" + args.get("--vcd-images"));
  const ConfigTree base = ConfigTree::load(args.get("--config"), sets);
  const auto points = sweep_points(base);
  check_sweep<HardwareContext>(base, points, [](const ConfigTree& cfg) {  // every point before any runs
    return make_hardware_context(cfg, parse_analog_config(cfg));
  });
  SweepOutputs out(args, points.front(),
                   "latency_us,makespan_us,throughput_images_per_s,energy_uj_per_image,avg_power_mw,peak_power_mw,"
                   "area_mm2");
  out.set_report("simulate", base);
  if (points.size() == 1) {
    const nlohmann::json j = simulate_once(args, base, true);
    print_summary(j);
    if (out.csv().enabled()) {
      out.csv().row(0, points[0]) << "," << j["latency_us"] << "," << j["makespan_us"] << ","
                                  << j["throughput_images_per_s"] << "," << j["energy_uj_per_image"] << ","
                                  << j["avg_power_mw"] << "," << j["peak_power_mw"] << "," << j["area_mm2"] << "\n";
    }
    out.add(j, points[0]);
    out.finish();
    return 0;
  }
  const Table table({{"run", -40},
                     {"latency_us", 11, 3},
                     {"img/s", 10, 1},
                     {"energy_uJ", 10, 3},
                     {"avg_mW", 9, 2},
                     {"area_mm2", 9, 4}});
  table.print_header(stdout);
  for (size_t k = 0; k < points.size(); ++k) {
    const ConfigTree cfg = sweep_config(base, points[k]);
    const nlohmann::json j = run_in_child([&] { return simulate_once(args, cfg, false); });
    table.print_row(
        stdout, {sweep_label(points[k]), j["latency_us"].get<double>(), j["throughput_images_per_s"].get<double>(),
                 j["energy_uj_per_image"].get<double>(), j["avg_power_mw"].get<double>(), j["area_mm2"].get<double>()});
    if (out.csv().enabled())
      out.csv().row(static_cast<int>(k), points[k])
          << "," << j["latency_us"] << "," << j["makespan_us"] << "," << j["throughput_images_per_s"] << ","
          << j["energy_uj_per_image"] << "," << j["avg_power_mw"] << "," << j["peak_power_mw"] << "," << j["area_mm2"]
          << "\n";
    out.add(j, points[k]);
  }
  out.finish();
  return 0;
}

}  // namespace

namespace {
const CommandRegistrar kRegister{
    "simulate", cmd_simulate,
    "simulate (--model M.onnx | --preset resnet20) [--dataset cifar10 --images N] [--timing ideal|detailed]\n"
    "         [--vcd out.vcd [--vcd-images K]] [--config F] [--set k=v]... [--json F] [--csv F]\n"
    "         [--report F.html]\n"
    "      SystemC/TLM-2.0 accelerator: latency, makespan, throughput, stalls, energy, power, area, accuracy;\n"
    "      list values sweep (one process per point)"};
}  // namespace

}  // namespace xbarsim
