// xbarsim simulate: the SystemC/TLM-2.0 accelerator running a network. Argument parsing and
// rendering; the timing comes from the platform, the counts from the shared inventory and
// the energy from the modules' action counters priced by the component library.
#include <systemc>

#include <chrono>
#include <cstdio>
#include <random>

#include "platform/Accelerator.h"
#include "sw/app/app_common.h"
#include "sw/app/model_source.h"
#include "sw/app/table.h"
#include "sw/common/seed.h"
#include "sw/study/hardware.h"

namespace xbarsim {

namespace {

/// Units of one layer times its replication (the buffer holds one copy of the activations).
LayerInventory replicated(LayerInventory v, int r) {
  for (auto f :
       {&LayerInventory::crossbars, &LayerInventory::dacs, &LayerInventory::adcs, &LayerInventory::accumulators,
        &LayerInventory::cells_present, &LayerInventory::shift_register_entries})
    v.*f *= r;
  return v;
}

struct DataForRun {
  Dataset test, calib;
  bool labelled = false;
};

DataForRun simulation_data(const CliArgs& args, const ConfigTree& cfg, const Model& model, int images) {
  DataForRun d;
  if (args.has("--dataset")) {
    const std::string dir = resolve_data_dir(cfg);
    d.test = load_dataset(args.get("--dataset"), dir, "test", 0, images);
    d.calib = load_dataset(args.get("--dataset"), dir, "calib", 0, cfg.get_int32("eval.calibration_images"));
    if (!(d.test.shape == model.input)) throw InputError("dataset image shape does not match the model input");
    d.labelled = true;
  } else {
    const uint64_t seed = static_cast<uint64_t>(cfg.get_int("data.synthetic_seed"));
    d.test = random_dataset(model.input, images, derive_seed(seed, {1}));
    d.calib = random_dataset(model.input, 20, derive_seed(seed, {2}));
  }
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
  const AnalogConfig ac = parse_analog_config(cfg);
  if (ac.mapping.scheme == MappingScheme::Sparse)
    throw InputError("configuration key 'mapping.scheme': the platform runs the dense mapping (sparse: see overhead)");
  const HardwareContext hw = make_hardware_context(cfg, ac);
  const PlatformConfig& pc = hw.platform;
  Model model = model_from_args(args, cfg);
  apply_preprocessing_overrides(cfg, model.pre, model.input.c);
  const DataForRun data = simulation_data(args, cfg, model, pc.images);
  if (!ac.xbar.is_linear())
    std::fprintf(stderr,
                 "xbarsim simulate: nonlinear devices: every crossbar input vector is a Newton circuit solve "
                 "(slow); consider --images 1\n");
  CrossbarBackend programmed(model, ac);
  {
    ProgressBar bar(static_cast<int>(model.linear.size()), "programming");
    programmed.program(data.calib, cfg.get_int32("eval.calibration_samples"), [&](int d, int) { bar.update(d); });
  }
  const auto t_sim = std::chrono::steady_clock::now();
  ProgressBar bar(data.test.count(), "simulating ");
  Accelerator acc(
      "accelerator", model, programmed, pc, [&](int k, float* x) { data.test.preprocess(k, model.pre, x); }, vcd,
      [&](int done) { bar.update(done); });
  sc_core::sc_start();
  bar.finish();
  const double sim_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_sim).count();
  const SimulationResult& r = acc.result();
  const int images = static_cast<int>(r.logits.size());

  nlohmann::json j;
  j["model"] = model.path;
  j["clock_mhz"] = pc.clock_mhz;
  j["timing"] = pc.detailed ? "detailed" : "ideal";
  j["schedule"] = pc.pipelined ? "pipelined" : "sequential";
  j["replication"] = pc.replication;
  j["images"] = images;
  j["layers"] = nlohmann::json::array();
  const Table table({{"layer", -30},
                     {"kernel", -12},
                     {"rows", 6},
                     {"cols", 5},
                     {"xbars", 6},
                     {"ADCs", 6},
                     {"DACs", 6},
                     {"iters", 8},
                     {"cycles", 9},
                     {"latency_us", 11, 3},
                     {"energy_uJ", 10, 4}});
  table.print_header(stdout);
  CostReport cost;
  long long iterations = 0;
  double slowest_ns = 0;
  for (size_t l = 0; l < model.linear.size(); ++l) {
    const LinearLayer& L = model.linear[l];
    const LayerInventory v =
        replicated(layer_inventory(L, MappingScheme::Dense, ac.mapping, hw.columns_per_adc), pc.replication);
    ActionCounts a = acc.tile(static_cast<int>(l)).actions();
    for (double* x : {&a.dac_conversions, &a.adc_conversions, &a.cell_reads, &a.accumulates, &a.shifts,
                      &a.buffer_read_bytes, &a.buffer_write_bytes})
      *x /= std::max(images, 1);  // per image
    double ns = 0;
    for (const auto& img : r.layer_latency_ns) ns += img[l];
    ns /= std::max(images, 1);
    add_layer_cost(cost, hw, v, a);
    const double e_uj = hw.cost.energy_pj(a, v, ns).total() * 1e-6;
    const long long cycles = std::llround(ns / pc.clock_ns());
    iterations += L.iterations();
    slowest_ns = std::max(slowest_ns, ns);
    j["layers"].push_back({{"name", L.name},
                           {"kernel", {L.k_h, L.k_w, L.c_in, L.c_out}},
                           {"rows", L.rows()},
                           {"cols", L.c_out},
                           {"crossbars", v.crossbars},
                           {"adcs", v.adcs},
                           {"dacs", v.dacs},
                           {"iterations", L.iterations()},
                           {"cycles", cycles},
                           {"latency_us", ns * 1e-3},
                           {"busy_us", ns * 1e-3},
                           {"energy_uj", e_uj},
                           {"area_mm2", hw.cost.area_mm2(v).total()}});
    const std::string kernel = std::to_string(L.k_h) + "x" + std::to_string(L.k_w) + "x" + std::to_string(L.c_in) +
                               "x" + std::to_string(L.c_out);
    table.print_row(stdout, {L.name, kernel, (long long)L.rows(), (long long)L.c_out, v.crossbars, v.adcs, v.dacs,
                             (long long)L.iterations(), cycles, ns * 1e-3, e_uj});
  }
  double latency_ns = 0;
  for (double t : r.image_latency_ns) latency_ns += t;
  latency_ns /= std::max(images, 1);
  cost.time_ns = latency_ns;  // leakage runs for the whole image
  const double throughput = 1e9 / (pc.pipelined ? std::max(slowest_ns, 1e-9) : std::max(latency_ns, 1e-9));
  j["iterations_total"] = iterations;
  j["cycles_total"] = std::llround(latency_ns / pc.clock_ns());
  j["latency_us"] = latency_ns * 1e-3;
  j["throughput_images_per_s"] = throughput;
  j.update(cost.to_json());
  j["component_library"] = hw.lib.source;
  j["simulation_wall_time_s"] = sim_s;
  j["simulated_images_per_wall_s"] = images / std::max(sim_s, 1e-9);
  std::printf(
      "\n%s, %s timing, %s schedule: %lld iterations/image, %lld cycles/image, latency %.3f us, %.0f images/s "
      "(modelled)\nenergy %.3f uJ/image, average power %.2f mW, peak power %.1f mW, area %.4f mm2\n",
      model.path.c_str(), pc.detailed ? "detailed" : "ideal", pc.pipelined ? "pipelined" : "sequential", iterations,
      j["cycles_total"].get<long long>(), latency_ns * 1e-3, throughput, cost.energy_uj().total(), cost.avg_power_mw(),
      cost.peak_power_mw.total(), cost.area_mm2.total());
  std::printf("simulation: %d images in %.2f s wall (%.1f images/s), programming excluded\n", images, sim_s,
              images / std::max(sim_s, 1e-9));
  if (data.labelled) {
    int correct = 0;
    for (int k = 0; k < images; ++k) {
      Eigen::Index a;
      r.logits[k].maxCoeff(&a);
      correct += a == data.test.labels[k];
    }
    j["accuracy"] = static_cast<double>(correct) / images;
    std::printf("accuracy %.2f %% on %d images\n", 100.0 * correct / images, images);
  }
  if (args.has("--json")) write_json(args.get("--json"), j);
  if (args.has("--csv")) {
    OutputFile csv(args.get("--csv"));
    const Table t({{"layer", 0},
                   {"k_h", 0},
                   {"k_w", 0},
                   {"c_in", 0},
                   {"c_out", 0},
                   {"rows", 0},
                   {"cols", 0},
                   {"crossbars", 0},
                   {"iterations", 0},
                   {"cycles", 0},
                   {"latency_us", 0},
                   {"adcs", 0},
                   {"dacs", 0},
                   {"energy_uj", 0},
                   {"area_mm2", 0}});
    t.csv_header(csv.stream());
    for (const auto& l : j["layers"])
      t.csv_row(csv.stream(),
                {l["name"].get<std::string>(), l["kernel"][0].get<long long>(), l["kernel"][1].get<long long>(),
                 l["kernel"][2].get<long long>(), l["kernel"][3].get<long long>(), l["rows"].get<long long>(),
                 l["cols"].get<long long>(), l["crossbars"].get<long long>(), l["iterations"].get<long long>(),
                 l["cycles"].get<long long>(), l["latency_us"].get<double>(), l["adcs"].get<long long>(),
                 l["dacs"].get<long long>(), l["energy_uj"].get<double>(), l["area_mm2"].get<double>()});
    csv.commit();
  }
  return 0;
}

}  // namespace

namespace {
const CommandRegistrar kRegister{
    "simulate", cmd_simulate,
    "simulate (--model M.onnx | --preset resnet20) [--dataset cifar10 --images N] [--timing ideal|detailed]\n"
    "         [--vcd out.vcd] [--config F] [--set k=v]... [--json F] [--csv F]\n"
    "      SystemC/TLM-2.0 accelerator: iterations, latency, throughput, energy, power, area, accuracy"};
}  // namespace

}  // namespace xbarsim
