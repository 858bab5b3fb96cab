// xbarsim simulate: the SystemC/TLM-2.0 accelerator (platform/Pipeline.h) running a network.
// Argument parsing and rendering; timing, stalls and throughput come from the simulation,
// counts from the shared inventory, energy from the actions the processes counted.
#include <cstdio>
#include <optional>

#include "platform/simulation.h"
#include "sw/app/app_common.h"
#include "sw/app/model_source.h"
#include "sw/app/table.h"
#include "sw/common/errors.h"
#include "sw/common/input_file.h"
#include "sw/common/seed.h"
#include "sw/common/quantity_text.h"
#include "sw/study/chip_peak.h"
#include "sw/study/eval_study.h"
#include "sw/study/hardware.h"
#include "sw/study/sweep.h"

namespace xbarsim {

namespace {

/// `images` test images of `dataset` (eval's split and calibration images), or random images
/// from data.synthetic_seed when `dataset` is empty.
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

/// The per-layer table of a run, from its report.
void print_layers(const SimulationReport& r) {
  std::vector<std::string> names;
  for (const SimulatedLayer& l : r.layers) names.push_back(l.name);
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
  table.print_header(stdout);
  for (const SimulatedLayer& l : r.layers)
    table.print_row(stdout, {l.name, l.kernel_text(), l.crossbars, static_cast<long long>(l.replication), l.adcs,
                             l.dacs, l.iterations, l.busy_us, l.estimated_busy_us.value_or(0.0), l.bound_by.value_or("-"), l.stall_us,
                             l.starved_us, l.buffer_bytes, l.energy_uj});
}

/// One simulation in this process: the model and images of the arguments; `vcd`: its trace
/// file or "". `print`: progress bars and the per-layer table (a sweep's points print a row).
SimulationReport simulate_once(const CliArgs& args, const ConfigTree& cfg, bool print, const std::string& vcd) {
  Model model = model_from_args(args, cfg);
  apply_preprocessing_overrides(cfg, model.pre, model.input.c);
  if (const std::string w = preprocessing_warning(model, cfg); !w.empty() && args.has("--dataset"))
    std::fprintf(stderr, "xbarsim simulate: warning: %s\n", w.c_str());
  const PlatformConfig pc = make_hardware_context(cfg, parse_analog_config(cfg)).platform;
  if (pc.timing_only && args.has("--dataset"))
    throw InputError(
        "--dataset with platform.timing_only (--timing-only): a timing-only run computes no values, so "
        "it has no use for images; give the count with --images");
  const SimulationData data =
      pc.timing_only ? SimulationData{} : simulation_data(args.get("--dataset"), cfg, model, pc.images);
  // Each bar starts with its first report and ends with its last (a timing-only run programs nothing).
  std::optional<ProgressBar> programming, simulating;
  const auto bar = [](std::optional<ProgressBar>& b, const char* label, int done, int total) {
    if (!b) b.emplace(total, label);
    b->update(done, total);
    if (done == total) b->finish();
  };
  SimulationProgress progress;
  progress.programming = [&](int d, int total) { bar(programming, "programming", d, total); };
  progress.simulating = [&](int d, int total) { bar(simulating, "simulating ", d, total); };
  progress.note = [](const std::string& n) { std::fprintf(stderr, "xbarsim simulate: %s\n", n.c_str()); };
  const SimulationReport r = simulate_model(cfg, model, data, vcd, progress);
  if (print) print_layers(r);
  for (const std::string& w : r.warnings) std::fprintf(stderr, "xbarsim simulate: warning: %s\n", w.c_str());
  return r;
}

/// Registers the files a point will read, before anything is written (sw/common/input_file.h):
/// its model and its dataset's files.
void register_point_inputs(const CliArgs& args, const ConfigTree& cfg) {
  if (args.has("--model")) register_input(find_model_file(args.get("--model"), cfg), "the model");
  if (!args.has("--dataset")) return;
  const std::string dir = resolve_data_dir(cfg);
  for (const char* split : {"test", "calib"})
    for (const std::string& f : dataset_files(args.get("--dataset"), dir, split)) register_input(f, "the dataset file");
}

void print_summary(const SimulationReport& r) {
  std::printf(
      "\n%s on %s, %s timing, %s schedule, %s: %lld iterations/image, latency %.3f us, makespan %.3f us, "
      "%s images/s\nenergy %.3f uJ/image, average power %s (energy / simulated time per image), peak power %s, "
      "area %.4f mm2, %.3f TOPS/W achieved\n",
      r.model.c_str(), r.architecture.c_str(), r.timing.c_str(), r.schedule.c_str(),
      count_text(r.images, "image").c_str(), r.iterations_total, r.latency_us, r.makespan_us,
      compact_number(r.throughput_images_per_s).c_str(), r.energy_uj_per_image(), power_text(r.avg_power_mw()).c_str(),
      power_text(r.peak_power_mw()).c_str(), r.area_mm2(), r.achieved_tops_per_w);
  if (r.bottleneck)
    std::printf("bottleneck: %s, busy %.3f us per image%s%s\n", r.bottleneck->stage.c_str(),
                r.bottleneck->busy_us_per_image, r.bottleneck->unit.value_or("").empty() ? "" : ", bound by its ",
                r.bottleneck->unit.value_or("").c_str());
  std::printf("simulation (%s): %.2f s wall (%.1f images/s), programming excluded\n", r.mode.c_str(), r.wall_time_s,
              r.images_per_wall_s);
  if (r.accuracy) {
    std::printf("accuracy on %s: crossbars %.4f", count_text(r.images, "image").c_str(), *r.accuracy);
    if (r.software_accuracy) std::printf(", software %.4f", *r.software_accuracy);
    std::printf(" (fractions, as in the JSON)\n");
  }
}

/// The CSV columns after the point's: the figures of the header below.
void csv_figures(std::ostream& os, const SimulationReport& r) {
  for (double x : {r.latency_us, r.makespan_us, r.throughput_images_per_s, r.energy_uj_per_image(), r.avg_power_mw(),
                   r.peak_power_mw(), r.area_mm2()})
    os << "," << nlohmann::json(x).dump();  // shortest text that reads back as the same double
  os << "\n";
}

/// Without a model: the machine's peak figures at each point's precision (a machine of neuron
/// cores: counts x named components and solved physics, sw/study/chip_peak.h).
int simulate_peak(const CliArgs& args, const ConfigTree& base, const std::vector<SweepPoint>& points) {
  for (const char* opt : {"--dataset", "--images", "--vcd", "--vcd-images", "--timing"})
    if (args.has(opt))
      throw InputError(std::string(opt) + " needs a network (--model or --preset); without one simulate reports the "
                       "machine's peak figures");
  check_outputs(args, {"--json", "--csv", "--report"}, {});
  std::vector<ChipPeak> peaks;
  for (const SweepPoint& p : points) {
    const ConfigTree cfg = sweep_config(base, p);
    const AnalogConfig ac = parse_analog_config(cfg);
    peaks.push_back(chip_peak(make_hardware_context(cfg, ac)));
  }
  SweepOutputs out(args, points.front(), "input_bits,output_bits,peak_tops,peak_tops_per_w,area_mm2");
  out.set_report("simulate", base, "the peak figures of " + peaks.front().architecture);
  std::printf("%s: %lld cores, peak figures (every core reading back to back)\n", peaks.front().architecture.c_str(),
              peaks.front().cores);
  std::printf("%4s %4s %7s %9s %9s %9s %10s %10s %10s %9s\n", "in", "out", "phases", "read_us", "TOPS", "TOPS/W",
              "WL_fJ/op", "neuron", "pulses", "area_mm2");
  for (size_t k = 0; k < points.size(); ++k) {
    const ChipPeak& c = peaks[k];
    auto part = [&](const char* name) {
      const auto it = c.fj_per_op.find(name);
      return it == c.fj_per_op.end() ? 0.0 : it->second;
    };
    std::printf("%4d %4d %7d %9.3f %9.4f %9.3f %10.3f %10.3f %10.3f %9.2f\n", c.input_bits, c.output_bits,
                c.steps.phases, c.steps.time_ns * 1e-3, c.tops, c.tops_per_w, part("wordline"), part("neuron"),
                part("input_pulses"), c.core_area_mm2 * static_cast<double>(c.cores));
    if (out.csv().enabled())
      out.csv().row(static_cast<int>(k), points[k])
          << "," << c.input_bits << "," << c.output_bits << "," << nlohmann::json(c.tops).dump() << ","
          << nlohmann::json(c.tops_per_w).dump() << "," << nlohmann::json(c.core_area_mm2 * c.cores).dump() << "\n";
    out.add(c.to_json(), points[k]);
  }
  const ChipPeak& c = peaks.front();
  std::printf("core %.4f mm2:", c.core_area_mm2);
  for (const auto& [part, share] : c.area_share)
    if (share > 0) std::printf(" %s %.1f %%", part.c_str(), 100 * share);
  std::printf("\n(energy per operation by part: WL = word-line switching, neuron = its components and leakage, "
              "pulses = the solved input pulses; 2 operations per MAC)\n");
  out.finish();
  return 0;
}

int cmd_simulate(int argc, char** argv) {
  const CliArgs args(argc, argv, 0,
                     {"--model", "--preset", "--dataset", "--images", "--timing", "--vcd", "--vcd-images", "--report"},
                     {"--timing-only"});
  const std::string vcd = args.get("--vcd");
  std::vector<std::string> sets = args.sets();
  if (args.has("--images")) sets.push_back("platform.images=" + args.get("--images"));
  if (args.has("--timing")) sets.push_back("platform.timing=" + args.get("--timing"));
  if (args.has("--vcd-images")) sets.push_back("platform.vcd_images=" + args.get("--vcd-images"));
  if (args.has("--timing-only")) sets.push_back("platform.timing_only=true");
  const ConfigTree base = ConfigTree::load(args.get("--config"), sets);
  const auto points = sweep_points(base);
  if (!args.has("--model") && !args.has("--preset")) return simulate_peak(args, base, points);
  check_sweep<HardwareContext>(base, points, [](const ConfigTree& cfg) {  // every point before any runs
    return make_hardware_context(cfg, parse_analog_config(cfg));
  });
  for (const SweepPoint& p : points) register_point_inputs(args, sweep_config(base, p));
  // A sweep traces each point into a file of its own: F-0.vcd, F-1.vcd, ...
  std::vector<std::pair<std::string, std::string>> vcds;
  const std::string vcd_stem = vcd.size() > 4 ? vcd.substr(0, vcd.size() - 4) : vcd;
  for (size_t k = 0; args.has("--vcd") && k < points.size(); ++k)
    vcds.emplace_back("--vcd", points.size() == 1 ? vcd : vcd_stem + "-" + std::to_string(k) + ".vcd");
  check_outputs(args, {"--json", "--csv", "--report"}, vcds);
  if (args.has("--vcd") && (vcd.size() < 5 || vcd.compare(vcd.size() - 4, 4, ".vcd") != 0))
    throw InputError("--vcd '" + vcd + "': the trace file name must end in .vcd (SystemC adds the suffix)");
  SweepOutputs out(args, points.front(),
                   "latency_us,makespan_us,throughput_images_per_s,energy_uj_per_image,avg_power_mw,peak_power_mw,"
                   "area_mm2");
  out.set_report("simulate", base,
                 (args.has("--model") ? args.get("--model") : "preset " + args.get("--preset")) +
                     (args.has("--dataset") ? " on " + args.get("--dataset") : std::string()));
  if (points.size() == 1) {
    const SimulationReport r = simulate_once(args, base, true, vcd);
    print_summary(r);
    if (out.csv().enabled()) csv_figures(out.csv().row(0, points[0]), r);
    out.add(r.to_json(), points[0]);
    out.finish();
    return 0;
  }
  const std::vector<std::string> labels = sweep_labels(points);
  const Table table({{"run", fit_width("run", labels)},
                     {"latency_us", 11, 3},
                     {"img/s", 10, 1},
                     {"energy_uJ", 10, 3},
                     {"avg_power", 11},
                     {"peak_power", 11},
                     {"area_mm2", 9, 4}});
  table.print_header(stdout);
  for (size_t k = 0; k < points.size(); ++k) {
    const ConfigTree cfg = sweep_config(base, points[k]);
    const std::string point_vcd = vcds.empty() ? std::string() : vcds[k].second;
    const SimulationReport r = run_in_child([&] { return simulate_once(args, cfg, false, point_vcd); });
    if (!point_vcd.empty())
      std::fprintf(stderr, "xbarsim simulate: %s traced into %s\n", labels[k].c_str(), point_vcd.c_str());
    table.print_row(stdout, {labels[k], r.latency_us, r.throughput_images_per_s, r.energy_uj_per_image(),
                             power_text(r.avg_power_mw()), power_text(r.peak_power_mw()), r.area_mm2()});
    if (out.csv().enabled()) csv_figures(out.csv().row(static_cast<int>(k), points[k]), r);
    out.add(r.to_json(), points[k]);
  }
  std::printf("\npower: in mW below 10 W, in W from 10 W up (the CSV and JSON: mW)\n");
  out.finish();
  return 0;
}

}  // namespace

namespace {
const CommandRegistrar kRegister{
    "simulate", cmd_simulate,
    "simulate (--model M.onnx | --preset resnet20) [--dataset cifar10 --images N] [--timing ideal|detailed]\n"
    "         [--timing-only] [--vcd out.vcd [--vcd-images K]] [--config F] [--set k=v]... [--json F]\n"
    "         [--csv F] [--report F.html]\n"
    "      SystemC/TLM-2.0 accelerator: latency, makespan, throughput, stalls, energy, power, area, accuracy;\n"
    "      list values sweep (one process per point); --timing-only: no values, no dataset, the same timing and cost"};
}  // namespace

}  // namespace xbarsim
