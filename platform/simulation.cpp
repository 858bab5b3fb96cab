// One run of the SystemC/TLM-2.0 accelerator on a network (platform/simulation.h).
#include "platform/simulation.h"

#include <sys/wait.h>
#include <unistd.h>

#include <systemc>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <memory>
#include <numeric>
#include <optional>

#include "platform/Pipeline.h"
#include "sw/circuit/crossbar_params.h"
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

/// The typed report of a run from the simulation's counters: per layer, per digital stage,
/// the network's cost and timing.
SimulationReport report(const Model& model, const HardwareContext& hw, const PipelineResult& r,
                        const std::vector<int>& replication, const std::vector<bool>& signed_inputs,
                        const Pipeline& pipe, const MachineReport* machine) {
  const PlatformConfig& pc = hw.platform;
  const std::vector<bool> reads_image = linear_reads_image(model);
  const double images = std::max<size_t>(r.image_out_ns.size(), 1), clk = pc.clock_ns();
  SimulationReport out;
  CostReport& cost = out.cost;
  long long iterations = 0;
  double macs = 0;
  PlatformActions platform;  // counted by the simulation
  MachineActions on_machine;  // on a machine: its tile buses, mesh, digital units and off-chip links
  double unit_busy[kStages] = {}, unit_lanes_ns = 0;  // the tiles' units over every copy
  // The pipeline's period as the closed forms give it: the slowest stage's estimate (a
  // digital stage's operations at its rate), or the interconnect's bytes, per image.
  double estimated_period_ns = 0;
  for (size_t stage = 0; stage < r.stages.size(); ++stage) {
    const StageStats& st = r.stages[stage];
    if (st.linear < 0) {
      SimulatedDigitalStage d;
      d.name = st.name;
      d.stage = static_cast<long long>(stage);
      d.operation = *digital_op_name(st.kind) ? digital_op_name(st.kind) : "data movement";
      d.tile = st.tile;
      d.operations = st.digital_ops / images;
      d.busy_us = st.busy_ns / images * 1e-3;
      d.stall_us = st.stall_ns / images * 1e-3;
      d.starved_us = st.starved_ns / images * 1e-3;
      out.digital_stages.push_back(std::move(d));
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
      a /= images;  // the tile counts units' actions only: its bus, digital and memory counts are 0
    }
    add_layer_cost(cost, hw, v, a);
    on_machine.edram_read_bytes += a.buffer_read_bytes;  // on a machine they cross its tile's bus
    macs += static_cast<double>(L.rows()) * L.c_out * L.iterations();
    iterations += v.iterations;
    const double busy = st.busy_ns / images;
    SimulatedLayer o;
    static_cast<LayerShape&>(o) = LayerShape::of(L);
    o.stage = static_cast<long long>(stage);
    o.rows = L.rows();
    o.cols = L.c_out;
    o.crossbars = v.crossbars;
    o.replication = replication[st.linear];
    o.adcs = v.adcs;
    o.dacs = v.dacs;
    o.iterations = v.iterations;
    o.cycles = std::llround(busy / clk);
    o.busy_us = busy * 1e-3;
    o.stall_us = st.stall_ns / images * 1e-3;
    o.starved_us = st.starved_ns / images * 1e-3;
    o.buffer_bytes = st.buffer_bytes;
    o.buffer_peak_bytes = st.buffer_peak_bytes;
    o.energy_uj = hw.arch.core().layer_energy_pj(hw, v, a).total() * 1e-6;
    o.area_mm2 = hw.arch.core().layer_area_mm2(hw, v);
    // The mapper's estimate beside the simulated busy time, and the tile's units.
    if (!st.bound_by.empty()) {
      const double lanes_ns = static_cast<double>(st.replication) * std::max(r.makespan_ns(), 1e-9);
      for (int u = 0; u < kStages; ++u) {
        o.unit_utilization[unit_name(static_cast<Stage>(u))] = st.unit_busy_ns[u] / lanes_ns;
        unit_busy[u] += st.unit_busy_ns[u];
      }
      unit_lanes_ns += lanes_ns;
      o.bound_by = st.bound_by;
      const double est = machine  ? machine->mapping.layers[static_cast<size_t>(st.linear)].compute_ns
                         : sparse ? sparse_estimated_ns(sparse_iteration_ns(unreplicated, pc), pc)
                                  : estimated_compute_ns(unreplicated, &L, &hw.mapping, pc, replication[st.linear]);
      o.estimated_busy_us = est * 1e-3;
      o.busy_over_estimate = est > 0 ? busy / est : 0.0;
      estimated_period_ns = std::max(estimated_period_ns, est);
    }
    out.layers.push_back(std::move(o));
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
  if (unfilled)
    out.warnings.push_back(
        "one image never fills a pipelined schedule: the throughput is the bottleneck stage's rate (1 / its busy "
        "time per image), not the spacing of simulated outputs (1 / latency would say " +
        std::to_string(std::llround(1e9 / std::max(r.latency_ns(), 1e-9))) +
        " images/s); simulate 2 or more images (--images) to measure it");
  out.iterations_total = iterations;
  out.cycles_total = std::llround(r.latency_ns() / clk);
  out.latency_us = r.latency_ns() * 1e-3;
  out.makespan_us = r.makespan_ns() * 1e-3;
  out.throughput_images_per_s = throughput;
  out.throughput_from = unfilled ? "bottleneck stage (one image)" : "simulated outputs";
  // The simulated period (1 / throughput) against the closed forms' slowest stage: above 1 where
  // the stages wait for one another (fill, contention, back-pressure) more than the estimate
  // knows; below 1 only within temporal decoupling's bound (platform.quantum_ns).
  out.estimated_period_us = estimated_period_ns * 1e-3;
  out.period_over_estimate = throughput > 0 && estimated_period_ns > 0 ? 1e9 / throughput / estimated_period_ns : 0.0;
  out.tiles = std::accumulate(replication.begin(), replication.end(), 0);
  // Efficiency: 2 operations per MAC; peak with every crossbar reading (a machine), achieved
  // on the network at the simulated throughput.
  const double energy_uj = cost.energy_uj().total();
  out.macs_per_image = macs;
  out.achieved_gops = 2 * macs * throughput * 1e-9;
  out.achieved_tops_per_w = energy_uj > 0 ? 2 * macs / (energy_uj * 1e-6) * 1e-12 : 0.0;
  out.achieved_gops_per_mm2 = 2 * macs * throughput * 1e-9 / std::max(cost.area_mm2.total(), 1e-12);
  if (bus_bound)
    out.bottleneck = SimulationReport::Bottleneck{"interconnect (platform.bus_lanes)", bus_ns / images * 1e-3, {}};
  else if (slow)
    out.bottleneck = SimulationReport::Bottleneck{
        slow->name, slow->busy_ns / images * 1e-3,
        !slow->bound_by.empty() ? slow->bound_by : std::string(digital_op_name(slow->kind))};
  for (int u = 0; u < kStages; ++u)
    out.unit_utilization[unit_name(static_cast<Stage>(u))] = unit_lanes_ns > 0 ? unit_busy[u] / unit_lanes_ns : 0.0;
  if (machine) {
    out.architecture = machine->name;
    SimulationReport::Machine m;
    m.peak_gops = machine->peak_gops;
    m.placement = machine->mapping.to_json();
    m.noc_bytes_per_image = r.bus_bytes / images;
    m.router_bytes_per_image = r.router_bytes / images;
    m.local_bytes_per_image = r.local_bytes / images;
    m.contention_us_per_image = r.noc_contention_ns / images * 1e-3;
    m.link_utilization = r.makespan_ns() > 0 ? r.bus_busy_ns / (r.noc_links * r.makespan_ns()) : 0.0;
    out.machine = std::move(m);
  } else {
    out.architecture = "layer-sized";
    out.bus = SimulationReport::Bus{platform.actions.bus_bytes,
                                    r.makespan_ns() > 0 ? r.bus_busy_ns / (r.makespan_ns() * pc.bus_lanes) : 0.0,
                                    bus_ns / images * 1e-3};
  }
  return out;
}

/// Optional values as the report writes them: null when absent.
template <typename T>
nlohmann::json or_null(const std::optional<T>& v) {
  return v ? nlohmann::json(*v) : nlohmann::json();
}
template <typename T>
std::optional<T> optional_of(const nlohmann::json& j, const char* key) {
  const auto it = j.find(key);
  if (it == j.end() || it->is_null()) return std::nullopt;
  return it->get<T>();
}

}  // namespace

std::vector<PipelineStage> SimulationReport::pipeline_stages() const {
  std::vector<std::pair<long long, PipelineStage>> order;  // (place in the pipeline, stage)
  for (const SimulatedLayer& l : layers) order.push_back({l.stage, {l.name, "linear", l.busy_us, l.stall_us}});
  for (const SimulatedDigitalStage& d : digital_stages)
    order.push_back({d.stage, {d.name, "digital", d.busy_us, d.stall_us}});
  std::stable_sort(order.begin(), order.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  std::vector<PipelineStage> out;
  for (auto& s : order) out.push_back(std::move(s.second));
  // The shared bus carries every stage's outputs: a stage of its own, which may bound the run.
  if (!out.empty() && bus)
    out.push_back({"interconnect (platform.bus_lanes)", "interconnect", bus->interconnect_busy_us_per_image, 0.0});
  return out;
}

nlohmann::json SimulationReport::Bottleneck::to_json() const {
  nlohmann::json j = {{"stage", stage}, {"busy_us_per_image", busy_us_per_image}};
  if (unit) j["unit"] = *unit;
  return j;
}

nlohmann::json SimulationReport::to_json() const {
  nlohmann::json j = cost.to_json();
  j["warnings"] = warnings;
  j["iterations_total"] = iterations_total;
  j["cycles_total"] = cycles_total;
  j["latency_us"] = latency_us;
  j["makespan_us"] = makespan_us;
  j["throughput_images_per_s"] = throughput_images_per_s;
  j["throughput_from"] = throughput_from;
  j["estimated_period_us"] = estimated_period_us;
  j["period_over_estimate"] = period_over_estimate;
  j["tiles"] = tiles;
  if (bus) {
    j["bus_bytes_per_image"] = bus->bytes_per_image;
    j["bus_utilization"] = bus->utilization;
    j["interconnect_busy_us_per_image"] = bus->interconnect_busy_us_per_image;
  }
  j["macs_per_image"] = macs_per_image;
  j["achieved_gops"] = achieved_gops;
  j["achieved_tops_per_w"] = achieved_tops_per_w;
  j["achieved_gops_per_mm2"] = achieved_gops_per_mm2;
  if (bottleneck) j["bottleneck"] = bottleneck->to_json();
  j["unit_utilization"] = unit_utilization;
  j["architecture"] = architecture;
  if (machine) {
    j["peak_gops"] = machine->peak_gops;
    j["placement"] = machine->placement;
    j["noc"] = {{"bytes_per_image", machine->noc_bytes_per_image},
                {"router_bytes_per_image", machine->router_bytes_per_image},
                {"local_bytes_per_image", machine->local_bytes_per_image},
                {"contention_us_per_image", machine->contention_us_per_image},
                {"link_utilization", machine->link_utilization}};
  }
  j["layers"] = nlohmann::json::array();
  for (const SimulatedLayer& l : layers)
    j["layers"].push_back({{"name", l.name},
                           {"stage", l.stage},
                           {"kernel", {l.k_h, l.k_w, l.c_in, l.c_out}},
                           {"rows", l.rows},
                           {"cols", l.cols},
                           {"crossbars", l.crossbars},
                           {"replication", l.replication},
                           {"adcs", l.adcs},
                           {"dacs", l.dacs},
                           {"iterations", l.iterations},
                           {"cycles", l.cycles},
                           {"busy_us", l.busy_us},
                           {"estimated_busy_us", or_null(l.estimated_busy_us)},
                           {"busy_over_estimate", or_null(l.busy_over_estimate)},
                           {"bound_by", or_null(l.bound_by)},
                           {"unit_utilization", l.unit_utilization.empty() ? nlohmann::json::object()
                                                                           : nlohmann::json(l.unit_utilization)},
                           {"stall_us", l.stall_us},
                           {"starved_us", l.starved_us},
                           {"buffer_bytes", l.buffer_bytes},
                           {"buffer_peak_bytes", l.buffer_peak_bytes},
                           {"energy_uj", l.energy_uj},
                           {"area_mm2", l.area_mm2.total()},
                           {"area_breakdown_mm2", l.area_mm2.to_json()}});
  j["digital_stages"] = nlohmann::json::array();
  for (const SimulatedDigitalStage& d : digital_stages)
    j["digital_stages"].push_back({{"name", d.name},
                                   {"stage", d.stage},
                                   {"operation", d.operation},
                                   {"tile", d.tile},
                                   {"operations", d.operations},
                                   {"busy_us", d.busy_us},
                                   {"stall_us", d.stall_us},
                                   {"starved_us", d.starved_us}});
  j["model"] = model;
  j["clock_mhz"] = clock_mhz;
  j["timing"] = timing;
  j["schedule"] = schedule;
  j["mapping"] = mapping;
  j["images"] = images;
  j["mode"] = mode;
  j["preprocessing"] = {{"scale", preprocessing.scale}, {"mean", preprocessing.mean}, {"std", preprocessing.std}};
  j["quantum_ns"] = quantum_ns;
  j["stages"] = stages;
  if (protocol_check)
    j["protocol_check"] = {{"transactions", protocol_check->transactions},
                           {"violations", protocol_check->violations},
                           {"first_violations", protocol_check->first_violations}};
  j["component_library"] = component_library;
  j["simulation_wall_time_s"] = wall_time_s;
  j["simulated_images_per_wall_s"] = images_per_wall_s;
  if (accuracy) j["accuracy"] = *accuracy;
  if (software_accuracy) j["software_accuracy"] = *software_accuracy;
  return j;
}

SimulationReport SimulationReport::from_json(const nlohmann::json& j) {
  SimulationReport r;
  r.cost = CostReport::from_json(j);
  r.warnings = j.at("warnings").get<std::vector<std::string>>();
  r.iterations_total = j.at("iterations_total").get<long long>();
  r.cycles_total = j.at("cycles_total").get<long long>();
  r.latency_us = j.at("latency_us").get<double>();
  r.makespan_us = j.at("makespan_us").get<double>();
  r.throughput_images_per_s = j.at("throughput_images_per_s").get<double>();
  r.throughput_from = j.at("throughput_from").get<std::string>();
  r.estimated_period_us = j.at("estimated_period_us").get<double>();
  r.period_over_estimate = j.at("period_over_estimate").get<double>();
  r.tiles = j.at("tiles").get<int>();
  if (j.contains("bus_bytes_per_image"))
    r.bus = Bus{j.at("bus_bytes_per_image").get<double>(), j.at("bus_utilization").get<double>(),
                j.at("interconnect_busy_us_per_image").get<double>()};
  r.macs_per_image = j.at("macs_per_image").get<double>();
  r.achieved_gops = j.at("achieved_gops").get<double>();
  r.achieved_tops_per_w = j.at("achieved_tops_per_w").get<double>();
  r.achieved_gops_per_mm2 = j.at("achieved_gops_per_mm2").get<double>();
  if (j.contains("bottleneck")) {
    const nlohmann::json& b = j["bottleneck"];
    r.bottleneck = Bottleneck{b.at("stage").get<std::string>(), b.at("busy_us_per_image").get<double>(),
                              optional_of<std::string>(b, "unit")};
  }
  r.unit_utilization = j.at("unit_utilization").get<std::map<std::string, double>>();
  r.architecture = j.at("architecture").get<std::string>();
  if (j.contains("noc")) {
    const nlohmann::json& n = j["noc"];
    r.machine = Machine{j.at("peak_gops").get<double>(),
                        j.at("placement"),
                        n.at("bytes_per_image").get<double>(),
                        n.at("router_bytes_per_image").get<double>(),
                        n.at("local_bytes_per_image").get<double>(),
                        n.at("contention_us_per_image").get<double>(),
                        n.at("link_utilization").get<double>()};
  }
  for (const nlohmann::json& l : j.at("layers")) {
    SimulatedLayer o;
    o.name = l.at("name").get<std::string>();
    o.stage = l.at("stage").get<long long>();
    const std::vector<int> k = l.at("kernel").get<std::vector<int>>();
    o.k_h = k.at(0), o.k_w = k.at(1), o.c_in = k.at(2), o.c_out = k.at(3);
    o.rows = l.at("rows").get<long long>();
    o.cols = l.at("cols").get<long long>();
    o.crossbars = l.at("crossbars").get<long long>();
    o.replication = l.at("replication").get<int>();
    o.adcs = l.at("adcs").get<long long>();
    o.dacs = l.at("dacs").get<long long>();
    o.iterations = l.at("iterations").get<long long>();
    o.cycles = l.at("cycles").get<long long>();
    o.busy_us = l.at("busy_us").get<double>();
    o.estimated_busy_us = optional_of<double>(l, "estimated_busy_us");
    o.busy_over_estimate = optional_of<double>(l, "busy_over_estimate");
    o.bound_by = optional_of<std::string>(l, "bound_by");
    o.unit_utilization = l.at("unit_utilization").get<std::map<std::string, double>>();
    o.stall_us = l.at("stall_us").get<double>();
    o.starved_us = l.at("starved_us").get<double>();
    o.buffer_bytes = l.at("buffer_bytes").get<long long>();
    o.buffer_peak_bytes = l.at("buffer_peak_bytes").get<long long>();
    o.energy_uj = l.at("energy_uj").get<double>();
    o.area_mm2 = ComponentBreakdown::from_json(l.at("area_breakdown_mm2"));
    r.layers.push_back(std::move(o));
  }
  for (const nlohmann::json& d : j.at("digital_stages"))
    r.digital_stages.push_back({d.at("name").get<std::string>(), d.at("operation").get<std::string>(),
                                d.at("stage").get<long long>(), d.at("tile").get<int>(),
                                d.at("operations").get<double>(), d.at("busy_us").get<double>(),
                                d.at("stall_us").get<double>(), d.at("starved_us").get<double>()});
  r.model = j.at("model").get<std::string>();
  r.clock_mhz = j.at("clock_mhz").get<double>();
  r.timing = j.at("timing").get<std::string>();
  r.schedule = j.at("schedule").get<std::string>();
  r.mapping = j.at("mapping").get<std::string>();
  r.images = j.at("images").get<int>();
  r.mode = j.at("mode").get<std::string>();
  const nlohmann::json& pre = j.at("preprocessing");
  r.preprocessing.scale = pre.at("scale").get<double>();
  r.preprocessing.mean = pre.at("mean").get<std::vector<double>>();
  r.preprocessing.std = pre.at("std").get<std::vector<double>>();
  r.quantum_ns = j.at("quantum_ns").get<double>();
  r.stages = j.at("stages").get<int>();
  if (j.contains("protocol_check")) {
    const nlohmann::json& p = j["protocol_check"];
    r.protocol_check = ProtocolCheck{p.at("transactions").get<long long>(), p.at("violations").get<long long>(),
                                     p.at("first_violations").get<std::vector<std::string>>()};
  }
  r.component_library = j.at("component_library").get<std::string>();
  r.wall_time_s = j.at("simulation_wall_time_s").get<double>();
  r.images_per_wall_s = j.at("simulated_images_per_wall_s").get<double>();
  r.accuracy = optional_of<double>(j, "accuracy");
  r.software_accuracy = optional_of<double>(j, "software_accuracy");
  return r;
}

SimulationReport simulate_model(const ConfigTree& cfg, const Model& model, const SimulationData& data,
                                const std::string& vcd, const SimulationProgress& progress,
                                const CrossbarBackend* given) {
  const AnalogConfig ac = parse_analog_config(cfg);
  const HardwareContext hw = make_hardware_context(cfg, ac);
  // The images the data holds (a dataset may have fewer than platform.images; its note says so).
  PlatformConfig pc = hw.platform;
  if (!pc.timing_only) pc.images = data.test.count();
  pc.threads = resolve_threads(cfg.get_int32("solver.threads"));
  if (!ac.xbar.is_linear() && !pc.timing_only && progress.note)
    progress.note(
        "nonlinear devices: every crossbar input vector is a nonlinear circuit solve (batched Newton, about 0.6 ms "
        "per 144x64 vector per core; ResNet-20 takes seconds per image)");
  require_fit(model, hw);  // before the crossbars are programmed
  std::unique_ptr<CrossbarBackend> own;
  if (!given && pc.timing_only) {  // the crossbars' layout only: nothing to program
    own = std::make_unique<CrossbarBackend>(model, ac);
    own->structure_only();
  } else if (!given) {
    own = std::make_unique<CrossbarBackend>(model, ac);
    // As eval: at least calibration.samples rows kept, so both program the same crossbars.
    own->program(data.calib, std::max(cfg.get_int32("eval.calibration_samples"), ac.calibration.samples),
                 progress.programming);
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
  const int images = pc.images;
  Pipeline pipe(
      "accelerator", model, programmed, pc, replication,
      [&](int k, float* x) { data.test.preprocess(k, model.pre, x); },
      [&](int d) {
        if (progress.simulating) progress.simulating(d, images);
      },
      sparse, plan.get());
  if (!vcd.empty()) pipe.trace(vcd, pc.vcd_images);
  sc_core::sc_start();
  if (progress.simulating) progress.simulating(images, images);
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
  SimulationReport j = report(model, run_hw, r, replication, signed_inputs, pipe, machine ? &*machine : nullptr);
  j.model = model.path;
  j.clock_mhz = pc.clock_mhz;
  j.timing = pc.detailed ? "detailed" : "ideal";
  j.schedule = pc.pipelined ? "pipelined" : "sequential";
  j.mapping = hw.mapping.scheme == MappingScheme::Sparse ? "sparse" : "dense";
  j.images = pc.images;
  j.mode = pc.timing_only ? "timing-only" : "timing-and-values";
  j.preprocessing = model.pre;
  j.quantum_ns = pc.quantum_ns;
  j.stages = static_cast<int>(r.stages.size());
  if (pc.check_protocol) {
    const size_t shown = std::min<size_t>(r.protocol_violations.size(), 20);
    j.protocol_check = SimulationReport::ProtocolCheck{
        r.protocol_transactions, static_cast<long long>(r.protocol_violations.size()),
        std::vector<std::string>(r.protocol_violations.begin(), r.protocol_violations.begin() + shown)};
  }
  j.component_library = hw.lib.source;
  j.wall_time_s = wall_s;
  j.images_per_wall_s = pc.images / std::max(wall_s, 1e-9);
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
    j.accuracy = static_cast<double>(correct) / r.logits.size();
    j.software_accuracy = static_cast<double>(software_correct) / r.logits.size();
  }
  return j;
}

SimulationReport run_in_child(const std::function<SimulationReport()>& run) {
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
      out = run().to_json();
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
  return SimulationReport::from_json(j);
}

}  // namespace xbarsim
