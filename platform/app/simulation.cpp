// One run of the SystemC/TLM-2.0 accelerator on a network (platform/app/simulation.h).
#include "platform/app/simulation.h"

#include <sys/wait.h>
#include <unistd.h>

#include <systemc>

#include <cerrno>
#include <chrono>
#include <memory>
#include <cstdio>
#include <fstream>
#include <numeric>

#include "platform/Pipeline.h"
#include "sw/app/app_common.h"
#include "sw/app/table.h"
#include "sw/common/errors.h"
#include "sw/common/seed.h"
#include "sw/study/eval_study.h"
#include "sw/study/hardware.h"

namespace xbarsim {

namespace {

/// Units of one layer times its replication (the buffer holds one copy of the activations).
LayerInventory replicated(LayerInventory v, int r) {
  for (auto f : {&LayerInventory::crossbars, &LayerInventory::dacs, &LayerInventory::adcs,
                 &LayerInventory::accumulators, &LayerInventory::cells_present, &LayerInventory::shift_register_entries,
                 &LayerInventory::sample_holds, &LayerInventory::output_register_bytes})
    v.*f *= r;
  return v;
}

std::string kernel_name(const LinearLayer& L) {
  return std::to_string(L.k_h) + "x" + std::to_string(L.k_w) + "x" + std::to_string(L.c_in) + "x" +
         std::to_string(L.c_out);
}

/// Per-layer JSON and the network's cost from the simulation's counters.
nlohmann::json report(const Model& model, const HardwareContext& hw, const PipelineResult& r,
                      const std::vector<int>& replication, const std::vector<bool>& signed_inputs, const Pipeline& pipe,
                      bool print) {
  const PlatformConfig& pc = hw.platform;
  const double images = std::max<size_t>(r.logits.size(), 1), clk = pc.clock_ns();
  const Table table({{"layer", -30},
                     {"kernel", -12},
                     {"xbars", 6},
                     {"rep", 4},
                     {"ADCs", 6},
                     {"DACs", 6},
                     {"iters", 7},
                     {"busy_us", 9, 3},
                     {"stall_us", 9, 3},
                     {"buf_B", 8},
                     {"energy_uJ", 10, 4}});
  if (print) table.print_header(stdout);
  nlohmann::json layers = nlohmann::json::array();
  CostReport cost;
  long long iterations = 0;
  int digital_units = 0;
  ActionCounts platform;
  for (const StageStats& st : r.stages) {
    if (st.linear < 0) {
      if (st.digital_ops > 0) ++digital_units;
      platform.digital_ops += st.digital_ops / images;
      continue;
    }
    const LinearLayer& L = model.linear[st.linear];
    const bool sparse = hw.mapping.scheme == MappingScheme::Sparse;
    const LayerInventory v =
        replicated(hw.inventory(L, hw.mapping.scheme, signed_inputs[st.linear]), sparse ? 1 : replication[st.linear]);
    ActionCounts a;
    if (sparse) {
      a = layer_actions_per_image(v, 0);  // counted from the Toeplitz inventory (one iteration)
    } else {
      a = pipe.tile(st.linear).actions();
      for (double* x : {&a.dac_conversions, &a.adc_conversions, &a.cell_reads, &a.accumulates, &a.shifts, &a.samples,
                        &a.shift_adds, &a.buffer_read_bytes, &a.buffer_write_bytes})
        *x /= images;
    }
    add_layer_cost(cost, hw, v, a);
    const double e_uj = hw.cost.dynamic_energy_pj(a).total() * 1e-6;
    iterations += v.iterations;
    const double busy = st.busy_ns / images, stall = st.stall_ns / images;
    layers.push_back({{"name", L.name},
                      {"kernel", {L.k_h, L.k_w, L.c_in, L.c_out}},
                      {"rows", L.rows()},
                      {"cols", L.c_out},
                      {"crossbars", v.crossbars},
                      {"replication", replication[st.linear]},
                      {"adcs", v.adcs},
                      {"dacs", v.dacs},
                      {"iterations", v.iterations},
                      {"cycles", std::llround(busy / clk)},
                      {"busy_us", busy * 1e-3},
                      {"stall_us", stall * 1e-3},
                      {"buffer_bytes", st.buffer_bytes},
                      {"buffer_peak_bytes", st.buffer_peak_bytes},
                      {"energy_uj", e_uj},
                      {"area_mm2", hw.cost.area_mm2(v).total()},
                      {"area_breakdown_mm2", hw.cost.area_mm2(v).to_json()}});
    if (print)
      table.print_row(stdout, {L.name, kernel_name(L), v.crossbars, (long long)replication[st.linear], v.adcs, v.dacs,
                               v.iterations, busy * 1e-3, stall * 1e-3, st.buffer_bytes, e_uj});
  }
  platform.bus_bytes = r.bus_bytes / images;
  platform.memory_bytes = r.memory_bytes / images;
  cost.dynamic_energy_uj += hw.cost.dynamic_energy_pj(platform) * 1e-6;
  cost.area_mm2 += hw.cost.platform_area_mm2(digital_units);
  cost.leakage_mw += hw.cost.platform_leakage_mw(digital_units);
  cost.time_ns = r.makespan_ns() / images;  // leakage runs for the whole run, shared by its images
  nlohmann::json j;
  j["iterations_total"] = iterations;
  j["cycles_total"] = std::llround(r.latency_ns() / clk);
  j["latency_us"] = r.latency_ns() * 1e-3;
  j["makespan_us"] = r.makespan_ns() * 1e-3;
  j["throughput_images_per_s"] = r.throughput_per_s();
  j["tiles"] = std::accumulate(replication.begin(), replication.end(), 0);
  j["bus_bytes_per_image"] = platform.bus_bytes;
  j["bus_utilization"] = r.makespan_ns() > 0 ? r.bus_busy_ns / (r.makespan_ns() * pc.bus_lanes) : 0.0;
  j.update(cost.to_json());
  j["layers"] = layers;
  return j;
}

}  // namespace

SimulationData simulation_data(const std::string& dataset, const ConfigTree& cfg, const Model& model, int images) {
  SimulationData d;
  if (!dataset.empty()) {
    // The same images as eval's (calibration split, MNIST's reserved calibration images).
    EvalSpec spec = parse_eval_spec(cfg);
    spec.images = images;
    spec.offset = 0;
    EvalData e = load_eval_data(model, dataset, resolve_data_dir(cfg), spec);
    if (!e.note.empty()) std::fprintf(stderr, "xbarsim simulate: %s\n", e.note.c_str());
    d.test = std::move(e.test);
    d.calib = std::move(e.calib);
    d.labelled = true;
  } else {
    const uint64_t seed = static_cast<uint64_t>(cfg.get_int("data.synthetic_seed"));
    d.test = random_dataset(model.input, images, derive_seed(seed, {1}));
    d.calib = random_dataset(model.input, 20, derive_seed(seed, {2}));
  }
  return d;
}

nlohmann::json simulate_model(const ConfigTree& cfg, const Model& model, const SimulationData& data,
                              const std::string& vcd, bool print, const CrossbarBackend* given) {
  const AnalogConfig ac = parse_analog_config(cfg);
  const HardwareContext hw = make_hardware_context(cfg, ac);
  // The images the data holds (a dataset may have fewer than platform.images; its note says so).
  PlatformConfig pc = hw.platform;
  pc.images = data.test.count();
  if (!ac.xbar.is_linear())
    std::fprintf(stderr,
                 "xbarsim simulate: nonlinear devices: every crossbar input vector is a nonlinear circuit solve "
                 "(batched Newton, about 0.6 ms per 144x64 vector per core; ResNet-20 takes seconds per image)\n");
  std::unique_ptr<CrossbarBackend> own;
  if (!given) {
    own = std::make_unique<CrossbarBackend>(model, ac);
    ProgressBar bar(static_cast<int>(model.linear.size()), "programming");
    own->program(data.calib, cfg.get_int32("eval.calibration_samples"), [&](int d, int) { bar.update(d); });
  }
  const CrossbarBackend& programmed = given ? *given : *own;
  const std::vector<int> replication = resolve_replication(model, programmed, pc);
  std::vector<bool> signed_inputs;  // as the programmed layers stream them
  for (size_t l = 0; l < model.linear.size(); ++l)
    signed_inputs.push_back(programmed.statistics(static_cast<int>(l)).signed_inputs);
  // Sparse (Toeplitz) layers: one iteration per image on their own crossbars and converters.
  std::vector<double> sparse_ns;
  if (hw.mapping.scheme == MappingScheme::Sparse)
    for (const LinearLayer& L : model.linear)
      sparse_ns.push_back(
          sparse_iteration_ns(hw.inventory(L, MappingScheme::Sparse, signed_inputs[sparse_ns.size()]), pc));
  const auto t0 = std::chrono::steady_clock::now();
  ProgressBar bar(data.test.count(), "simulating ");
  Pipeline pipe(
      "accelerator", model, programmed, pc, replication,
      [&](int k, float* x) { data.test.preprocess(k, model.pre, x); }, [&](int d) { bar.update(d); }, sparse_ns);
  if (!vcd.empty()) pipe.trace(vcd, pc.vcd_images);
  sc_core::sc_start();
  bar.finish();
  const double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const PipelineResult& r = pipe.result();
  if (!r.completed)
    throw InputError(
        "the simulation stopped with images in flight: a buffer (platform.buffer_bytes) is too small "
        "for the schedule (deadlock)");
  nlohmann::json j = report(model, hw, r, replication, signed_inputs, pipe, print);
  j["model"] = model.path;
  j["clock_mhz"] = pc.clock_mhz;
  j["timing"] = pc.detailed ? "detailed" : "ideal";
  j["schedule"] = pc.pipelined ? "pipelined" : "sequential";
  j["mapping"] = hw.mapping.scheme == MappingScheme::Sparse ? "sparse" : "dense";
  j["images"] = static_cast<int>(r.logits.size());
  j["component_library"] = hw.lib.source;
  j["simulation_wall_time_s"] = wall_s;
  j["simulated_images_per_wall_s"] = r.logits.size() / std::max(wall_s, 1e-9);
  if (data.labelled) {
    int correct = 0;
    for (size_t k = 0; k < r.logits.size(); ++k) {
      Eigen::Index a;
      r.logits[k].maxCoeff(&a);
      correct += a == data.test.labels[k];
    }
    j["accuracy"] = static_cast<double>(correct) / r.logits.size();
  }
  return j;
}

nlohmann::json run_in_child(const std::function<nlohmann::json()>& run) {
  char path[] = "/tmp/xbarsim_simulate_XXXXXX";
  const int fd = mkstemp(path);
  if (fd < 0) throw std::runtime_error("cannot create a temporary file in /tmp");
  close(fd);
  std::fflush(nullptr);
  const pid_t pid = fork();
  if (pid < 0) {
    std::remove(path);
    throw std::runtime_error("cannot start a child process (fork failed)");
  }
  if (pid == 0) {
    nlohmann::json out;
    try {
      out = run();
    } catch (const std::exception&) {
      const Failure f = current_failure();
      out = {{"error", f.message}, {"kind", f.kind_name()}};
    }
    std::ofstream(path) << out.dump();
    std::fflush(nullptr);
    _exit(0);  // no MPI or static destructors in the child: the parent owns them
  }
  int status = 0;
  while (waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  std::ifstream in(path);
  std::string text((std::istreambuf_iterator<char>(in)), {});
  std::remove(path);
  if (!WIFEXITED(status) || text.empty())
    throw std::runtime_error(WIFSIGNALED(status) ? "the simulation process was killed by signal " +
                                                       std::to_string(WTERMSIG(status))
                                                 : std::string("the simulation process wrote no result"));
  nlohmann::json j = nlohmann::json::parse(text);
  if (j.contains("error")) Failure::from_kind_name(j["kind"], j["error"]).rethrow();
  return j;
}

}  // namespace xbarsim
