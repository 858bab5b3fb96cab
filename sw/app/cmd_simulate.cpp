// xbarsim simulate: the SystemC/TLM-2.0 accelerator running a network, with timing,
// power, area, energy and (with a dataset) accuracy.
#include <systemc>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <random>

#include "platform/Accelerator.h"
#include "sw/app/app_common.h"
#include "sw/app/model_source.h"
#include "sw/hw/overhead.h"

namespace xbarsim {

namespace {

/// Seeded random images (pixels uniform 0..255) for runs without data.
Dataset synthetic_images(const Shape& s, int count, uint64_t seed) {
  Dataset d;
  d.name = "synthetic";
  d.shape = s;
  d.pixels.resize(static_cast<size_t>(count) * s.size());
  d.labels.assign(count, 0);
  std::mt19937_64 rng(seed);
  for (auto& p : d.pixels) p = static_cast<uint8_t>(rng() & 0xff);
  return d;
}

int cmd_simulate(int argc, char** argv) {
  const CliArgs args(argc, argv, 0, {"--model", "--preset", "--dataset", "--images", "--timing", "--vcd"});
  check_outputs(args, {"--json", "--csv", "--vcd"});
  const std::string vcd = args.get("--vcd");
  if (args.has("--vcd") && (vcd.size() < 5 || vcd.compare(vcd.size() - 4, 4, ".vcd") != 0))
    throw InputError("--vcd '" + vcd + "': the trace file name must end in .vcd (SystemC adds the suffix)");
  std::vector<std::string> sets = args.sets();
  if (args.has("--images")) sets.push_back("platform.images=" + args.get("--images"));
  if (args.has("--timing")) sets.push_back("platform.timing=" + args.get("--timing"));
  const ConfigTree cfg = ConfigTree::load(args.get("--config"), sets);
  if (!cfg.sweep_keys().empty())
    throw InputError("simulate runs one configuration per process (SystemC elaborates once); '" +
                     cfg.sweep_keys().front() + "' is a list");
  Model model = model_from_args(args, cfg);
  apply_preprocessing_overrides(cfg, model.pre, model.input.c);
  const AnalogConfig ac = parse_analog_config(cfg);
  const ComponentLibrary lib = load_component_library(cfg);
  const PlatformConfig pc = parse_platform_config(cfg, lib.adc_columns_per_unit);
  const HardwareSettings hw = parse_hardware_settings(cfg);

  const bool with_data = args.has("--dataset");
  Dataset test, calib;
  if (with_data) {
    const std::string dir = resolve_data_dir(cfg);
    test = load_dataset(args.get("--dataset"), dir, "test", 0, pc.images);
    calib = load_dataset(args.get("--dataset"), dir, "calib", 0, cfg.get_int32("eval.calibration_images"));
    if (!(test.shape == model.input)) throw InputError("dataset image shape does not match the model input");
  } else {
    test = synthetic_images(model.input, pc.images, 1);
    calib = synthetic_images(model.input, 20, 2);
  }
  if (!ac.xbar.is_linear())
    std::fprintf(stderr, "xbarsim simulate: nonlinear devices: every crossbar input vector is a Newton circuit solve "
                         "(slow); consider --images 1\n");
  CrossbarBackend programmed(model, ac);
  {
    ProgressBar bar(static_cast<int>(model.linear.size()), "programming");
    programmed.program(calib, cfg.get_int32("eval.calibration_samples"),
                       [&](int d, int) { bar.update(d); });
  }
  const auto t_sim = std::chrono::steady_clock::now();
  ProgressBar bar(test.count(), "simulating ");
  Accelerator acc(
      "accelerator", model, programmed, pc, [&](int k, float* x) { test.preprocess(k, model.pre, x); },
      args.get("--vcd"), [&](int done) { bar.update(done); });
  sc_core::sc_start();
  bar.finish();
  const double sim_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_sim).count();
  const SimulationResult& r = acc.result();
  const int images = static_cast<int>(r.logits.size());

  // Per-layer costs from the same component library and counting rules as `overhead`.
  nlohmann::json j;
  j["model"] = model.path;
  j["clock_mhz"] = pc.clock_mhz;
  j["timing"] = pc.detailed ? "detailed" : "ideal";
  j["schedule"] = pc.pipelined ? "pipelined" : "sequential";
  j["replication"] = pc.replication;
  j["images"] = images;
  j["layers"] = nlohmann::json::array();
  long long iterations = 0;
  double power = 0, area = 0, energy = 0, slowest_ns = 0;
  std::printf("%-30s %-12s %6s %5s %6s %6s %6s %8s %9s %11s %10s\n", "layer", "kernel", "rows", "cols", "xbars",
              "ADCs", "DACs", "iters", "cycles", "latency_us", "power_mW");
  for (size_t l = 0; l < model.linear.size(); ++l) {
    const LinearLayer& L = model.linear[l];
    MappingCost c = mapping_cost(L.rows(), L.c_out, static_cast<long long>(L.rows()) * L.c_out, L.iterations(), hw, lib);
    double ns = 0;
    for (const auto& img : r.layer_latency_ns) ns += img[l];
    ns /= std::max(images, 1);
    const double p_mw = c.total_power_mw * pc.replication;
    const long long cycles = std::llround(ns / pc.clock_ns());
    iterations += L.iterations();
    power += p_mw;
    area += c.total_area_mm2 * pc.replication;
    energy += energy_uj(p_mw, ns * 1e-3);
    slowest_ns = std::max(slowest_ns, ns);
    j["layers"].push_back({{"name", L.name},
                           {"kernel", {L.k_h, L.k_w, L.c_in, L.c_out}},
                           {"rows", L.rows()},
                           {"cols", L.c_out},
                           {"crossbars", c.crossbars * pc.replication},
                           {"iterations", L.iterations()},
                           {"cycles", cycles},
                           {"latency_us", ns * 1e-3},
                           {"adcs", c.adcs * pc.replication},
                           {"dacs", c.dacs * pc.replication},
                           {"power_mw", p_mw},
                           {"area_mm2", c.total_area_mm2 * pc.replication}});
    const std::string kernel = std::to_string(L.k_h) + "x" + std::to_string(L.k_w) + "x" + std::to_string(L.c_in) +
                               "x" + std::to_string(L.c_out);
    std::printf("%-30s %-12s %6d %5d %6lld %6lld %6lld %8d %9lld %11.3f %10.2f\n", L.name.c_str(), kernel.c_str(),
                L.rows(), L.c_out, c.crossbars * pc.replication, c.adcs * pc.replication, c.dacs * pc.replication,
                L.iterations(), cycles, ns * 1e-3, p_mw);
  }
  double latency_ns = 0;
  for (double t : r.image_latency_ns) latency_ns += t;
  latency_ns /= std::max(images, 1);
  const double throughput = 1e9 / (pc.pipelined ? std::max(slowest_ns, 1e-9) : std::max(latency_ns, 1e-9));
  j["iterations_total"] = iterations;
  j["cycles_total"] = std::llround(latency_ns / pc.clock_ns());
  j["latency_us"] = latency_ns * 1e-3;
  j["throughput_images_per_s"] = throughput;
  j["power_mw"] = power;
  j["area_mm2"] = area;
  j["energy_uj_per_image"] = energy;
  j["component_library"] = lib.source;
  j["simulation_wall_time_s"] = sim_s;
  j["simulated_images_per_wall_s"] = images / std::max(sim_s, 1e-9);
  std::printf("\n%s, %s timing, %s schedule: %lld iterations/image, %lld cycles/image, latency %.3f us, %.0f images/s "
              "(modelled), power %.1f mW, area %.4f mm2, energy %.3f uJ/image\n",
              model.path.c_str(), pc.detailed ? "detailed" : "ideal", pc.pipelined ? "pipelined" : "sequential",
              iterations, j["cycles_total"].get<long long>(), latency_ns * 1e-3, throughput, power, area, energy);
  std::printf("simulation: %d images in %.2f s wall (%.1f images/s), programming excluded\n", images, sim_s,
              images / std::max(sim_s, 1e-9));
  if (with_data) {
    int correct = 0;
    for (int k = 0; k < images; ++k) {
      Eigen::Index a;
      r.logits[k].maxCoeff(&a);
      correct += a == test.labels[k];
    }
    j["accuracy"] = static_cast<double>(correct) / images;
    std::printf("accuracy %.2f %% on %d images\n", 100.0 * correct / images, images);
  }
  if (args.has("--json")) write_json(args.get("--json"), j);
  if (args.has("--csv")) {
    OutputFile csv_file(args.get("--csv"));
    std::ostream& csv = csv_file.stream();
    csv << "layer,k_h,k_w,c_in,c_out,rows,cols,crossbars,iterations,cycles,latency_us,adcs,dacs,power_mw,area_mm2\n";
    for (const auto& l : j["layers"])
      csv << l["name"].get<std::string>() << "," << l["kernel"][0] << "," << l["kernel"][1] << "," << l["kernel"][2]
          << "," << l["kernel"][3] << "," << l["rows"] << "," << l["cols"] << "," << l["crossbars"] << ","
          << l["iterations"] << "," << l["cycles"] << "," << l["latency_us"] << "," << l["adcs"] << "," << l["dacs"]
          << "," << l["power_mw"] << "," << l["area_mm2"] << "\n";
    csv_file.commit();
  }
  return 0;
}

}  // namespace

namespace {
const CommandRegistrar kRegister{
    "simulate", cmd_simulate,
    "simulate (--model M.onnx | --preset resnet20) [--dataset cifar10 --images N] [--timing ideal|detailed]\n"
    "         [--vcd out.vcd] [--config F] [--set k=v]... [--json F] [--csv F]\n"
    "      SystemC/TLM-2.0 accelerator: iterations, latency, throughput, power, area, energy, accuracy"};
}  // namespace

}  // namespace xbarsim
