// One run of the SystemC/TLM-2.0 accelerator on a network (platform/simulation.h).
#include "platform/simulation.h"

#include <sys/wait.h>
#include <unistd.h>

#include <systemc>

#include <cerrno>
#include <chrono>
#include <memory>
#include <cstdio>
#include <fstream>
#include <numeric>
#include <optional>

#include "platform/Pipeline.h"
#include "sw/app/app_common.h"
#include "sw/app/table.h"
#include "sw/common/errors.h"
#include "sw/common/seed.h"
#include "sw/nn/network.h"
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
                      bool print, const MachineReport* machine) {
  const PlatformConfig& pc = hw.platform;
  const std::vector<bool> reads_image = linear_reads_image(model);
  const double images = std::max<size_t>(r.image_out_ns.size(), 1), clk = pc.clock_ns();
  std::vector<std::string> names;
  for (const StageStats& st : r.stages)
    if (st.linear >= 0) names.push_back(st.name);
  const Table table({{"layer", fit_width("layer", names)},
                     {"kernel", -12},
                     {"xbars", 6},
                     {"rep", 4},
                     {"ADCs", 6},
                     {"DACs", 6},
                     {"iters", 7},
                     {"busy_us", 9, 3},
                     {"est_us", 9, 3},
                     {"bound", -14},
                     {"stall_us", 9, 3},
                     {"starved_us", 10, 3},
                     {"buf_B", 8},
                     {"energy_uJ", 10, 4}});
  if (print) table.print_header(stdout);
  nlohmann::json layers = nlohmann::json::array();
  CostReport cost;
  long long iterations = 0;
  double macs = 0;
  PlatformActions platform;  // counted by the simulation
  MachineActions on_machine;  // on a machine: its tile buses, mesh, digital units and off-chip links
  double unit_busy[kStages] = {}, unit_lanes_ns = 0;  // the tiles' units over every copy
  // The pipeline's period as the closed forms give it: the slowest stage's estimate (a
  // digital stage's operations at its rate), or the interconnect's bytes, per image.
  double estimated_period_ns = 0;
  nlohmann::json digital = nlohmann::json::array();
  for (size_t stage = 0; stage < r.stages.size(); ++stage) {
    const StageStats& st = r.stages[stage];
    if (st.linear < 0) {
      digital.push_back({{"name", st.name},
                         {"stage", stage},
                         {"operation", *digital_op_name(st.kind) ? digital_op_name(st.kind) : "data movement"},
                         {"tile", st.tile},
                         {"operations", st.digital_ops / images},
                         {"busy_us", st.busy_ns / images * 1e-3},
                         {"stall_us", st.stall_ns / images * 1e-3},
                         {"starved_us", st.starved_ns / images * 1e-3}});
      if (st.digital_ops > 0) ++platform.digital_units;
      estimated_period_ns = std::max(estimated_period_ns, st.busy_ns / images);  // ops / rate: a closed form
      platform.actions.digital_ops += st.digital_ops / images;
      if (st.digital_ops > 0) on_machine.digital_ops.push_back({digital_op_name(st.kind), st.digital_ops / images});
      continue;
    }
    const LinearLayer& L = model.linear[st.linear];
    const bool sparse = hw.mapping.scheme == MappingScheme::Sparse;
    const LayerInventory unreplicated =
        hw.inventory(L, hw.mapping.scheme, signed_inputs[st.linear], reads_image[st.linear]);
    const LayerInventory v = replicated(unreplicated, sparse ? 1 : replication[st.linear]);
    ActionCounts a;
    if (sparse) {
      a = layer_actions_per_image(v, 0);  // counted from the Toeplitz inventory (one iteration)
    } else {
      a = pipe.tile(st.linear).actions();
      for (double* x : {&a.dac_conversions, &a.adc_conversions, &a.cell_reads, &a.accumulates, &a.shifts, &a.samples,
                        &a.shift_adds, &a.buffer_read_bytes, &a.buffer_write_bytes, &a.scale_multiplies})
        *x /= images;
    }
    add_layer_cost(cost, hw, v, a);
    on_machine.edram_read_bytes += a.buffer_read_bytes;  // on a machine they cross its tile's bus
    const double e_uj = hw.arch.core().layer_energy_pj(hw, v, a).total() * 1e-6;
    macs += static_cast<double>(L.rows()) * L.c_out * L.iterations();
    iterations += v.iterations;
    const ComponentBreakdown area = hw.arch.core().layer_area_mm2(hw, v);
    const double busy = st.busy_ns / images, stall = st.stall_ns / images;
    // The mapper's estimate beside the simulated busy time, and the tile's units.
    nlohmann::json units = nlohmann::json::object(), estimate_us, over_estimate, bound;
    double est = -1;  // a tile's busy time as the mapper estimates it (-1: not a tile's)
    if (!st.bound_by.empty()) {
      const double lanes_ns = static_cast<double>(st.replication) * std::max(r.makespan_ns(), 1e-9);
      for (int u = 0; u < kStages; ++u) {
        units[unit_name(static_cast<Stage>(u))] = st.unit_busy_ns[u] / lanes_ns;
        unit_busy[u] += st.unit_busy_ns[u];
      }
      unit_lanes_ns += lanes_ns;
      bound = st.bound_by;
      est = machine  ? machine->mapping.layers[static_cast<size_t>(st.linear)].compute_ns
            : sparse ? sparse_estimated_ns(sparse_iteration_ns(unreplicated, pc), pc)
                     : estimated_compute_ns(unreplicated, &L, &hw.mapping, pc, replication[st.linear]);
      estimate_us = est * 1e-3;
      over_estimate = est > 0 ? busy / est : 0.0;
      estimated_period_ns = std::max(estimated_period_ns, est);
    }
    layers.push_back({{"name", L.name},
                      {"stage", stage},
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
                      {"estimated_busy_us", estimate_us},
                      {"busy_over_estimate", over_estimate},
                      {"bound_by", bound},
                      {"unit_utilization", units},
                      {"stall_us", stall * 1e-3},
                      {"starved_us", st.starved_ns / images * 1e-3},
                      {"buffer_bytes", st.buffer_bytes},
                      {"buffer_peak_bytes", st.buffer_peak_bytes},
                      {"energy_uj", e_uj},
                      {"area_mm2", area.total()},
                      {"area_breakdown_mm2", area.to_json()}});
    if (print)
      table.print_row(
          stdout, {L.name, kernel_name(L), v.crossbars, (long long)replication[st.linear], v.adcs, v.dacs, v.iterations,
                   busy * 1e-3, est < 0 ? 0.0 : est * 1e-3, st.bound_by.empty() ? std::string("-") : st.bound_by,
                   stall * 1e-3,
                   st.starved_ns / images * 1e-3, st.buffer_bytes, e_uj});
  }
  platform.actions.bus_bytes = r.bus_bytes / images;
  platform.actions.memory_bytes = r.memory_bytes / images;
  if (machine) {
    // The whole chip is the machine's, used or not: its area, peak power and leakage; energy
    // from the actions, the mesh's routers per byte and router crossed, the off-chip links.
    on_machine.router_bytes = r.router_bytes / images;
    on_machine.memory_bytes = platform.actions.memory_bytes;
    add_machine_cost(cost, hw, on_machine);
  } else {
    add_platform_cost(cost, hw, platform);
  }
  cost.time_ns = r.makespan_ns() / images;  // leakage runs for the whole run, shared by its images
  // The bottleneck: the stage busy longest per image (with its stall, the time it held up).
  const StageStats* slow = nullptr;
  for (const StageStats& st : r.stages)
    if (!slow || st.busy_ns > slow->busy_ns) slow = &st;
  // The shared bus is the bottleneck when its lanes carry longer per image than that stage
  // computes (a machine's mesh: see noc.link_utilization).
  const double bus_ns = machine ? 0.0 : r.bus_busy_ns / std::max(pc.bus_lanes, 1);
  const bool bus_bound = slow && bus_ns > slow->busy_ns;
  const double bottleneck_ns = bus_bound ? bus_ns / images : slow ? slow->busy_ns / images : 0.0;
  // One image never fills a pipeline: the spacing of outputs (the measured steady state) needs
  // two, and 1 / latency would be the empty pipeline's rate (ResNet-20 on ISAAC-CE: 10 683
  // images/s for a steady 39 062). Then the steady state is the bottleneck stage's rate.
  const bool unfilled = pc.pipelined && r.image_out_ns.size() < 2 && bottleneck_ns > 0;
  const double throughput = unfilled ? 1e9 / bottleneck_ns : r.throughput_per_s();
  if (machine) estimated_period_ns = std::max(estimated_period_ns, machine->mapping.bottleneck_ns);
  estimated_period_ns = std::max(estimated_period_ns, bus_ns / images);
  nlohmann::json j;
  j["warnings"] = nlohmann::json::array();
  if (unfilled)
    j["warnings"].push_back(
        "one image never fills a pipelined schedule: the throughput is the bottleneck stage's rate (1 / its busy "
        "time per image), not the spacing of simulated outputs (1 / latency would say " +
        std::to_string(std::llround(1e9 / std::max(r.latency_ns(), 1e-9))) +
        " images/s); simulate 2 or more images (--images) to measure it");
  j["iterations_total"] = iterations;
  j["cycles_total"] = std::llround(r.latency_ns() / clk);
  j["latency_us"] = r.latency_ns() * 1e-3;
  j["makespan_us"] = r.makespan_ns() * 1e-3;
  j["throughput_images_per_s"] = throughput;
  j["throughput_from"] = unfilled ? "bottleneck stage (one image)" : "simulated outputs";
  // The simulated period (1 / throughput) against the closed forms' slowest stage: above 1 where
  // the stages wait for one another (fill, contention, back-pressure) more than the estimate
  // knows; below 1 only within temporal decoupling's bound (platform.quantum_ns).
  j["estimated_period_us"] = estimated_period_ns * 1e-3;
  j["period_over_estimate"] = throughput > 0 && estimated_period_ns > 0 ? 1e9 / throughput / estimated_period_ns : 0.0;
  j["tiles"] = std::accumulate(replication.begin(), replication.end(), 0);
  j["bus_bytes_per_image"] = platform.actions.bus_bytes;
  j["bus_utilization"] = r.makespan_ns() > 0 ? r.bus_busy_ns / (r.makespan_ns() * pc.bus_lanes) : 0.0;
  if (!machine) j["interconnect_busy_us_per_image"] = bus_ns / images * 1e-3;
  j.update(cost.to_json());
  // Efficiency: 2 operations per MAC; peak with every crossbar reading (a machine), achieved
  // on the network at the simulated throughput.
  const double energy_uj = cost.energy_uj().total();
  j["macs_per_image"] = macs;
  j["achieved_gops"] = 2 * macs * throughput * 1e-9;
  j["achieved_tops_per_w"] = energy_uj > 0 ? 2 * macs / (energy_uj * 1e-6) * 1e-12 : 0.0;
  j["achieved_gops_per_mm2"] = 2 * macs * throughput * 1e-9 / std::max(cost.area_mm2.total(), 1e-12);
  if (bus_bound)
    j["bottleneck"] = {{"stage", "interconnect (platform.bus_lanes)"}, {"busy_us_per_image", bus_ns / images * 1e-3}};
  else if (slow)
    j["bottleneck"] = {{"stage", slow->name},
                       {"busy_us_per_image", slow->busy_ns / images * 1e-3},
                       {"unit", !slow->bound_by.empty() ? slow->bound_by : std::string(digital_op_name(slow->kind))}};
  // How busy each kind of tile unit was over the run, every copy counted.
  nlohmann::json util = nlohmann::json::object();
  for (int u = 0; u < kStages; ++u)
    util[unit_name(static_cast<Stage>(u))] = unit_lanes_ns > 0 ? unit_busy[u] / unit_lanes_ns : 0.0;
  j["unit_utilization"] = util;
  if (machine) {
    j["architecture"] = machine->name;
    j["peak_gops"] = machine->peak_gops;
    j["placement"] = machine->mapping.to_json();
    j["noc"] = {{"bytes_per_image", r.bus_bytes / images},
                {"router_bytes_per_image", r.router_bytes / images},
                {"local_bytes_per_image", r.local_bytes / images},
                {"contention_us_per_image", r.noc_contention_ns / images * 1e-3},
                {"link_utilization", r.makespan_ns() > 0 ? r.bus_busy_ns / (r.noc_links * r.makespan_ns()) : 0.0}};
    j.erase("bus_bytes_per_image");
    j.erase("bus_utilization");
  } else {
    j["architecture"] = "layer-sized";
  }
  j["layers"] = layers;
  j["digital_stages"] = digital;
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
    if (const std::string w = dataset_range_warning(e.test, model.pre, "the images"); !w.empty())
      std::fprintf(stderr, "xbarsim simulate: warning: %s\n", w.c_str());
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

SimulationReport SimulationReport::from_json(const nlohmann::json& j) {
  SimulationReport r;
  r.model = j.at("model").get<std::string>();
  r.timing = j.at("timing").get<std::string>();
  r.schedule = j.at("schedule").get<std::string>();
  r.mode = j.at("mode").get<std::string>();
  r.architecture = j.at("architecture").get<std::string>();
  r.images = j.at("images").get<int>();
  r.iterations_total = j.at("iterations_total").get<long long>();
  r.latency_us = j.at("latency_us").get<double>();
  r.makespan_us = j.at("makespan_us").get<double>();
  r.throughput_images_per_s = j.at("throughput_images_per_s").get<double>();
  r.energy_uj_per_image = j.at("energy_uj_per_image").get<double>();
  r.avg_power_mw = j.at("avg_power_mw").get<double>();
  r.peak_power_mw = j.at("peak_power_mw").get<double>();
  r.area_mm2 = j.at("area_mm2").get<double>();
  r.achieved_tops_per_w = j.at("achieved_tops_per_w").get<double>();
  if (j.contains("bottleneck")) {
    r.bottleneck = j["bottleneck"].at("stage").get<std::string>();
    r.bottleneck_busy_us = j["bottleneck"].at("busy_us_per_image").get<double>();
    if (j["bottleneck"].contains("unit")) r.bottleneck_unit = j["bottleneck"]["unit"].get<std::string>();
  }
  r.wall_time_s = j.at("simulation_wall_time_s").get<double>();
  r.images_per_wall_s = j.at("simulated_images_per_wall_s").get<double>();
  if (j.contains("accuracy")) r.accuracy = j["accuracy"].get<double>();
  if (j.contains("software_accuracy")) r.software_accuracy = j["software_accuracy"].get<double>();
  r.json = j;
  return r;
}

SimulationReport simulate_model(const ConfigTree& cfg, const Model& model, const SimulationData& data,
                                const std::string& vcd, bool print, const CrossbarBackend* given) {
  const AnalogConfig ac = parse_analog_config(cfg);
  const HardwareContext hw = make_hardware_context(cfg, ac);
  // The images the data holds (a dataset may have fewer than platform.images; its note says so).
  PlatformConfig pc = hw.platform;
  if (!pc.timing_only) pc.images = data.test.count();
  pc.threads = resolve_threads(cfg.get_int32("solver.threads"));
  if (!ac.xbar.is_linear() && !pc.timing_only)
    std::fprintf(stderr,
                 "xbarsim simulate: nonlinear devices: every crossbar input vector is a nonlinear circuit solve "
                 "(batched Newton, about 0.6 ms per 144x64 vector per core; ResNet-20 takes seconds per image)\n");
  require_fit(model, hw);  // before the crossbars are programmed
  std::unique_ptr<CrossbarBackend> own;
  if (!given && pc.timing_only) {  // the crossbars' layout only: nothing to program
    own = std::make_unique<CrossbarBackend>(model, ac);
    own->structure_only();
  } else if (!given) {
    own = std::make_unique<CrossbarBackend>(model, ac);
    ProgressBar bar(static_cast<int>(model.linear.size()), "programming");
    // As eval: at least calibration.samples rows kept, so both program the same crossbars.
    own->program(data.calib, std::max(cfg.get_int32("eval.calibration_samples"), ac.calibration.samples),
                 [&](int d, int) { bar.update(d); });
  }
  const CrossbarBackend& programmed = given ? *given : *own;
  std::vector<bool> signed_inputs;  // as the programmed layers stream them
  const std::vector<bool> reads_image = linear_reads_image(model);
  for (size_t l = 0; l < model.linear.size(); ++l)
    signed_inputs.push_back(programmed.statistics(static_cast<int>(l)).signed_inputs);
  // On a machine: the mapper's placement and replication; its datapath reads once per read_ns.
  std::optional<MachineReport> machine;
  std::unique_ptr<MachinePlan> plan;
  if (hw.arch.machine) {
    if (hw.mapping.scheme == MappingScheme::Sparse)
      throw InputError("mapping.scheme: sparse is not simulated on a machine (architecture.machine " + hw.arch.name +
                       "): its IMAs hold dense layers");
    machine = machine_report(model, hw, signed_inputs);
    require_fit(machine->mapping, hw.arch);
    plan = std::make_unique<MachinePlan>(MachinePlan{hw.arch, machine->mapping});
    pc = machine_platform(pc, hw.arch);  // the tiles' timing, as the pipeline and the mapper take it
  }
  std::vector<int> replication;
  if (plan)
    for (const LayerPlacement& p : plan->mapping.layers) replication.push_back(p.replication);
  else
    replication = resolve_replication(model, programmed, pc);
  // Sparse (Toeplitz) layers: one iteration per image on their own crossbars and converters.
  std::vector<SparseIterationNs> sparse;
  if (hw.mapping.scheme == MappingScheme::Sparse)
    for (const LinearLayer& L : model.linear)
      sparse.push_back(sparse_iteration_ns(
          hw.inventory(L, MappingScheme::Sparse, signed_inputs[sparse.size()], reads_image[sparse.size()]), pc));
  const auto t0 = std::chrono::steady_clock::now();
  ProgressBar bar(pc.images, "simulating ");
  Pipeline pipe(
      "accelerator", model, programmed, pc, replication,
      [&](int k, float* x) { data.test.preprocess(k, model.pre, x); }, [&](int d) { bar.update(d); }, sparse,
      plan.get());
  if (!vcd.empty()) pipe.trace(vcd, pc.vcd_images);
  sc_core::sc_start();
  bar.finish();
  const double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const PipelineResult& r = pipe.result();
  if (!r.completed) {
    std::string blocked;
    for (size_t k = 0; k < r.blocked.size() && k < 6; ++k) blocked += (k ? "; " : ": ") + r.blocked[k];
    if (r.blocked.size() > 6) blocked += "; and " + std::to_string(r.blocked.size() - 6) + " more";
    throw InputError(
        "the simulation stopped with images in flight: a buffer (platform.buffer_bytes) is too small "
        "for the schedule (deadlock). Blocked" +
        blocked);
  }
  pipe.finish_trace();
  HardwareContext run_hw = hw;
  run_hw.platform = pc;
  nlohmann::json j = report(model, run_hw, r, replication, signed_inputs, pipe, print, machine ? &*machine : nullptr);
  j["model"] = model.path;
  j["clock_mhz"] = pc.clock_mhz;
  j["timing"] = pc.detailed ? "detailed" : "ideal";
  j["schedule"] = pc.pipelined ? "pipelined" : "sequential";
  j["mapping"] = hw.mapping.scheme == MappingScheme::Sparse ? "sparse" : "dense";
  j["images"] = pc.images;
  j["mode"] = pc.timing_only ? "timing-only" : "timing-and-values";
  j["preprocessing"] = {{"scale", model.pre.scale}, {"mean", model.pre.mean}, {"std", model.pre.std}};
  j["quantum_ns"] = pc.quantum_ns;
  j["stages"] = static_cast<int>(r.stages.size());
  if (pc.check_protocol) {
    const size_t shown = std::min<size_t>(r.protocol_violations.size(), 20);
    j["protocol_check"] = {{"transactions", r.protocol_transactions},
                           {"violations", r.protocol_violations.size()},
                           {"first_violations", std::vector<std::string>(r.protocol_violations.begin(),
                                                                         r.protocol_violations.begin() + shown)}};
  }
  j["component_library"] = hw.lib.source;
  j["simulation_wall_time_s"] = wall_s;
  j["simulated_images_per_wall_s"] = pc.images / std::max(wall_s, 1e-9);
  for (const auto& w : j["warnings"]) std::fprintf(stderr, "xbarsim simulate: warning: %s\n", w.get<std::string>().c_str());
  if (data.labelled && !pc.timing_only) {
    // The crossbars' accuracy, and the software network's on the same images beside it.
    const SoftwareBackend sw(model);
    std::vector<float> x(model.input.size());
    int correct = 0, software_correct = 0;
    for (size_t k = 0; k < r.logits.size(); ++k) {
      Eigen::Index a, b;
      r.logits[k].maxCoeff(&a);
      correct += a == data.test.labels[k];
      data.test.preprocess(static_cast<int>(k), model.pre, x.data());
      run_image(model, x.data(), sw).maxCoeff(&b);
      software_correct += b == data.test.labels[k];
    }
    j["accuracy"] = static_cast<double>(correct) / r.logits.size();
    j["software_accuracy"] = static_cast<double>(software_correct) / r.logits.size();
  }
  return SimulationReport::from_json(j);
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
    throw std::runtime_error(WIFSIGNALED(status)
                                 ? "the simulation process was killed by signal " + std::to_string(WTERMSIG(status))
                                 : std::string("the simulation process wrote no result"));
  nlohmann::json j = nlohmann::json::parse(text);
  if (j.contains("error")) Failure::from_kind_name(j["kind"], j["error"]).rethrow();
  return j;
}

}  // namespace xbarsim
