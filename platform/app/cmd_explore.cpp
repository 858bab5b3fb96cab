// xbarsim explore: a design space run point by point — accuracy and per-layer error from the
// evaluation, cost and timing from the SystemC platform — with the Pareto front over the
// chosen objectives. Resumable (a journal of finished points) and sharded over MPI ranks.
#include <chrono>
#include <filesystem>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <memory>
#include <set>
#include <stdexcept>

#include "platform/simulation.h"
#include "sw/app/app_common.h"
#include "sw/app/model_source.h"
#include "sw/app/table.h"
#include "sw/common/quantity_text.h"
#include "sw/common/errors.h"
#include "sw/common/ranks.h"
#include "sw/common/seed.h"
#include "sw/report/html_report.h"
#include "sw/study/eval_study.h"
#include "sw/study/explore.h"

namespace xbarsim {

namespace {

/// One point of the space: its values, its configuration, its identity and its programming's
/// (programming_key: the points of one group program equal crossbars).
struct SpacePoint {
  SweepPoint values;
  ConfigTree cfg;
  std::string key, label, group;
};

/// The crossbars of the group being run: programmed for its first point, read out with each
/// other point's configuration (CrossbarBackend::set_readout). One group's at a time.
struct ProgrammedGroup {
  std::string group;
  std::unique_ptr<CrossbarBackend> xb;
};

/// What a row takes from the platform's report: the point's figures and, per layer, its own.
nlohmann::json platform_fields(const SimulationReport& pf) {
  const CostReport& c = pf.cost;
  nlohmann::json row = {{"energy_uj_per_image", pf.energy_uj_per_image()},
                        {"area_mm2", pf.area_mm2()},
                        {"latency_us", pf.latency_us},
                        {"throughput_images_per_s", pf.throughput_images_per_s},
                        {"avg_power_mw", pf.avg_power_mw()},
                        {"peak_power_mw", pf.peak_power_mw()},
                        {"time_ns_per_image", c.time_ns},
                        {"energy_breakdown_uj", c.energy_uj().to_json()},
                        {"area_breakdown_mm2", c.area_mm2.to_json()},
                        {"peak_power_breakdown_mw", c.peak_power_mw.to_json()},
                        {"crossbars", c.crossbars},
                        {"adcs", c.adcs},
                        {"dacs", c.dacs},
                        {"tiles", pf.tiles},
                        {"iterations_total", pf.iterations_total}};
  row["stages"] = nlohmann::json::array();
  for (const PipelineStage& s : pf.pipeline_stages())
    row["stages"].push_back({{"name", s.name}, {"kind", s.kind}, {"busy_us", s.busy_us}, {"stall_us", s.stall_us}});
  if (pf.bottleneck) row["bottleneck"] = pf.bottleneck->to_json();
  row["simulation_wall_time_s"] = pf.wall_time_s;  // how this run went (not a result)
  return row;
}
nlohmann::json layer_platform_fields(const SimulatedLayer& l) {
  return {{"busy_us", l.busy_us},
          {"stall_us", l.stall_us},
          {"cycles", l.cycles},
          {"energy_uj", l.energy_uj},
          {"area_mm2", l.area_mm2.total()}};
}

/// The row of a finished point: the evaluation's accuracy and per-layer error, the platform's
/// energy, area, latency and per-layer busy/stall.
nlohmann::json result_row(const EvalResult& ev, const SimulationReport& pf) {
  nlohmann::json row = platform_fields(pf);
  row["status"] = "ok";
  row["accuracy"] = ev.crossbar_accuracy;
  row["software_accuracy"] = ev.software_accuracy;
  const auto ci = ev.paired.drop_ci95();
  row["accuracy_drop"] = ev.paired.drop();
  row["accuracy_drop_ci95"] = {ci.first, ci.second};
  row["images_only_software_correct"] = ev.paired.only_software;
  row["images_only_crossbar_correct"] = ev.paired.only_crossbar;
  row["warnings"] = ev.warnings();
  nlohmann::json layers = nlohmann::json::array();
  for (size_t l = 0; l < ev.layers.size(); ++l) {
    const EvalLayer& e = ev.layers[l];
    nlohmann::json L = {{"name", e.name},
                        {"mean_relative_error", e.mean_relative_error},
                        {"worst_relative_error", e.worst_relative_error}};
    if (l < pf.layers.size() && pf.layers[l].name == e.name) L.update(layer_platform_fields(pf.layers[l]));
    layers.push_back(L);
  }
  const auto [mean, worst] = ev.network_error();
  row["mean_relative_error"] = mean;
  row["worst_relative_error"] = worst;
  row.update(ev.design_json());
  row["out_of_range_cells"] = ev.out_of_range_cells();
  row["layers"] = layers;
  // How this run went (not results: they differ between runs and ranks).
  row["program_time_s"] = ev.program_time_s;
  row["evaluate_time_s"] = ev.evaluate_time_s;
  return row;
}

/// The row of a point run without accuracy (explore.accuracy false): the platform's cost and
/// timing, timing only.
nlohmann::json timing_row(const SimulationReport& pf) {
  nlohmann::json row = platform_fields(pf);
  row["status"] = "ok";
  row["mode"] = "timing-only";
  nlohmann::json layers = nlohmann::json::array();
  for (const SimulatedLayer& l : pf.layers) {
    nlohmann::json L = {{"name", l.name}};
    L.update(layer_platform_fields(l));
    layers.push_back(L);
  }
  row["warnings"] = nlohmann::json::array();
  row["layers"] = layers;
  return row;
}

/// The platform's notes and warnings on stderr, as simulate says them (no progress bars: the
/// point's own say where it is).
SimulationProgress platform_notes() {
  SimulationProgress p;
  p.note = [](const std::string& n) { std::fprintf(stderr, "xbarsim explore: platform: %s\n", n.c_str()); };
  return p;
}
const SimulationReport& told(const SimulationReport& pf) {
  for (const std::string& w : pf.warnings) std::fprintf(stderr, "xbarsim explore: platform: warning: %s\n", w.c_str());
  return pf;
}

/// Evaluates one point and simulates its platform (or, without accuracy, only simulates its
/// timing); a point that fails is a row with a reason. The crossbars of the point's group are
/// programmed once: a point of the group `programmed` holds is read out of them.
nlohmann::json run_point(const SpacePoint& p, const Model& model, const EvalData& data, const EvalSpec& spec,
                         const std::string& progress_label, bool accuracy, ProgrammedGroup& programmed) {
  const SimulationProgress notes = platform_notes();
  try {
    if (!accuracy) {
      ConfigTree cfg = p.cfg;
      cfg.set("platform.timing_only", "true");
      return timing_row(told(run_in_child([&] { return simulate_model(cfg, model, SimulationData{}, "", notes); })));
    }
    const EvalPoint design = parse_eval_point(p.cfg);
    require_fit(model, design.hw);  // as simulate and eval, before the crossbars are programmed
    // The crossbars are programmed once, on the evaluation's calibration images, for both the
    // platform (in a child process, which inherits them) and the evaluation.
    // programs_alike checks the typed configurations: a key missing from readout_keys costs a
    // programming, never a wrong result.
    const bool reuse =
        programmed.xb && programmed.group == p.group && programs_alike(programmed.xb->config(), design.ac);
    const auto t0 = std::chrono::steady_clock::now();
    ProgressBar prog(static_cast<int>(model.linear.size()), (reuse ? "reading out " : "programming ") + progress_label);
    if (reuse) {
      programmed.xb->set_readout(design.ac, [&](int d, int) { prog.update(d); });
    } else {
      programmed.xb.reset();  // one group's crossbars at a time
      programmed.xb = std::make_unique<CrossbarBackend>(
          program_crossbars(model, design, spec, data.calib, [&](int d, int) { prog.update(d); }));
      programmed.group = p.group;
    }
    prog.finish();
    const CrossbarBackend& xb = *programmed.xb;
    const double program_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    // The platform (it rejects an unschedulable design before the long evaluation) runs on
    // seeded random images: timing and counted actions do not depend on the pixel values.
    SimulationData sim;
    sim.test = random_dataset(model.input, design.hw.platform.images,
                              derive_seed(static_cast<uint64_t>(p.cfg.get_int("data.synthetic_seed")), {1}));
    sim.calib = data.calib;
    const SimulationReport pf = told(run_in_child([&] { return simulate_model(p.cfg, model, sim, "", notes, &xb); }));
    ProgressBar bar(data.test.count(), "evaluating  " + progress_label);
    const EvalResult r = run_eval(model, design, data.test, xb, program_s, [&](int d, int) { bar.update(d); });
    bar.finish();
    nlohmann::json row = result_row(r, pf);
    row["reused_programming"] = reuse;
    return row;
  } catch (const std::exception&) {
    const Failure f = current_failure();
    if (f.kind == Failure::Kind::Internal) throw;
    return {{"status", "failed"}, {"reason", f.reason()}};
  }
}

/// A CSV field in double quotes (reasons contain commas).
std::string quoted(const std::string& s) {
  std::string q = "\"";
  for (char c : s) q += c == '"' ? std::string("\"\"") : std::string(1, c == '\n' ? ' ' : c);
  return q + "\"";
}

double num(const nlohmann::json& row, const char* k) {
  const auto it = row.find(k);
  return it != row.end() && it->is_number() ? it->get<double>() : std::nan("");
}

/// The drop's 95 % interval in points, as eval prints it.
std::string interval(const nlohmann::json& row) {
  const auto it = row.find("accuracy_drop_ci95");
  if (it == row.end() || !it->is_array() || it->size() != 2) return "-";
  return drop_interval_text((*it)[0].get<double>(), (*it)[1].get<double>());
}

/// The row of a journal line as a result: the fields that vary between runs (timing), the place
/// in a space (index) and how the point was written (label, point: 8 and 8.0 are one point) left
/// out, so two lines of one point compare by their results.
nlohmann::json result_part(nlohmann::json row) {
  for (const char* k :
       {"program_time_s", "evaluate_time_s", "simulation_wall_time_s", "reused_programming", "index", "label", "point"})
    row.erase(k);
  return row;
}

int cmd_explore(int argc, char** argv) {
  const CliArgs args(argc, argv, 0, {"--model", "--dataset", "--images", "--out", "--report"});
  const std::string out_path = args.require("--out");
  std::vector<std::string> sets = args.sets();
  if (args.has("--model")) sets.push_back("explore.model=" + args.get("--model"));
  if (args.has("--dataset")) sets.push_back("explore.dataset=" + args.get("--dataset"));
  if (args.has("--images")) sets.push_back("eval.images=" + args.get("--images"));
  const ConfigTree base = ConfigTree::load(args.get("--config"), sets);
  const ExploreSpec spec = parse_explore_spec(base);
  const EvalSpec eval_spec = parse_eval_spec(base);
  if (spec.model.empty()) throw InputError("no model: give --model or explore.model");
  for (const std::string& key : base.sweep_keys())
    if (point_key_ignores(key))
      throw InputError("configuration key '" + key +
                       "' cannot be a list in an exploration: it does not change a point's results, so its values "
                       "would be one point run several times (give one value)");
  const std::vector<SweepPoint> values = explore_points(base, spec.combine);
  // Every point is checked before any runs: a value outside its range is an input error, as in
  // eval and simulate, not a failed row.
  check_sweep<EvalPoint>(base, values, parse_eval_point);

  Model model = load_onnx_model(find_model_file(spec.model, base));
  apply_preprocessing_overrides(base, model.pre, model.input.c);
  if (!spec.note.empty() && Ranks::root()) std::fprintf(stderr, "xbarsim explore: %s\n", spec.note.c_str());
  if (!spec.accuracy && args.has("--dataset"))
    throw InputError("--dataset with explore.accuracy false: the points run timing only and read no images");
  EvalData data;  // explore.accuracy false: no images (the journal's keys say "timing-only")
  data.test.name = "timing-only";
  if (spec.accuracy) data = load_eval_data(model, spec.dataset, resolve_data_dir(base), eval_spec);
  if (!data.note.empty() && Ranks::root()) std::fprintf(stderr, "xbarsim explore: %s\n", data.note.c_str());
  check_outputs(args, {"--out", "--json", "--csv", "--report"});  // every file it reads is known now

  const std::string model_id = file_id(model.path);
  std::vector<SpacePoint> space;
  space.reserve(values.size());
  std::map<std::string, size_t> point_of_key;
  for (const SweepPoint& v : values) {
    SpacePoint p{v, sweep_config(base, v), "", sweep_label(v), ""};
    p.key = explore_point_key(p.cfg, model_id, data.test.name);
    p.group = programming_key(p.cfg, model_id, data.test.name);
    const auto seen = point_of_key.emplace(p.key, space.size());
    if (!seen.second)
      throw InputError("points '" + space[seen.first->second].label + "' and '" + p.label +
                       "' are one design (their values are equal as numbers): list each value once");
    space.push_back(std::move(p));
  }
  const std::string color = spec.color_by.empty() && !base.sweep_keys().empty() ? base.sweep_keys()[0] : spec.color_by;

  // Points already in the journal are done; the rest are shared round-robin among the ranks.
  const ResultJournal journal(out_path, explore_journal_kind());
  if (Ranks::root()) journal.repair();
  Ranks::barrier();
  // A line of this space's point counts when it is a result (explore_row_problem); two lines
  // with different results for one point are a contradiction the user must resolve.
  const auto read_done = [&](bool speak) {
    std::map<std::string, JournalLine> done;
    int skipped = 0;
    for (JournalLine& line : journal.read(&skipped)) {
      const std::string key = line.row["key"];
      if (!point_of_key.count(key)) continue;
      const std::string problem = explore_row_problem(line.row);
      if (!problem.empty()) {
        if (speak)
          std::fprintf(stderr, "xbarsim explore: %s, line %d: %s; the point runs again\n", out_path.c_str(),
                       line.number, problem.c_str());
        continue;
      }
      const auto it = done.find(key);
      if (it == done.end()) {
        done.emplace(key, std::move(line));
      } else if (result_part(it->second.row) != result_part(line.row)) {
        throw InputError(journal.describe() + ": lines " + std::to_string(it->second.number) + " and " +
                         std::to_string(line.number) + " give different results for point '" +
                         space[point_of_key[key]].label + "'; delete one of them");
      }
    }
    if (speak && skipped)
      std::fprintf(stderr, "xbarsim explore: %d unreadable lines of %s ignored\n", skipped, out_path.c_str());
    return done;
  };
  std::map<std::string, JournalLine> done = read_done(Ranks::root());
  Ranks::barrier();  // everyone has read the journal before anyone appends to it
  std::vector<size_t> pending;
  for (size_t k = 0; k < space.size(); ++k)
    if (!done.count(space[k].key)) pending.push_back(k);
  std::vector<std::string> group_of;
  for (const SpacePoint& p : space) group_of.push_back(p.group);
  if (Ranks::root()) {
    std::fprintf(stderr, "xbarsim explore: %zu points, %zu already in %s, %zu to run", space.size(),
                 space.size() - pending.size(), out_path.c_str(), pending.size());
    if (Ranks::size() > 1) std::fprintf(stderr, " on %d ranks", Ranks::size());
    size_t programmings = 0;  // a group's per rank it reaches
    for (int r = 0; r < Ranks::size(); ++r) {
      std::set<std::string> groups;
      for (size_t k : explore_share(pending, group_of, r, Ranks::size())) groups.insert(group_of[k]);
      programmings += groups.size();
    }
    if (spec.accuracy && programmings < pending.size())
      std::fprintf(stderr, "; %zu crossbar programming%s, the other points only read out (ADCs, calibration)",
                   programmings, programmings == 1 ? "" : "s");
    std::fprintf(stderr, "\n");
  }
  // Each rank runs a contiguous share of the points ordered group by group, so that a group is
  // programmed once per rank it reaches (results do not depend on it: a point read out of
  // another's crossbars equals one programmed for it, bit for bit).
  const std::vector<size_t> share = explore_share(pending, group_of, Ranks::rank(), Ranks::size());
  ProgrammedGroup programmed;
  for (size_t i = 0; i < share.size(); ++i) {
    const SpacePoint& p = space[share[i]];
    if (Ranks::root()) std::fprintf(stderr, "[%zu/%zu] %s\n", i + 1, share.size(), p.label.c_str());
    nlohmann::json row = run_point(p, model, data, eval_spec, p.label, spec.accuracy, programmed);
    row["key"] = p.key;
    row["index"] = share[i];
    row["label"] = p.label;
    row["point"] = point_json(p.values);
    const std::string problem = explore_row_problem(row);
    if (!problem.empty()) throw std::logic_error("explore wrote a row it would not read back: " + problem);
    journal.append(row);
  }
  Ranks::barrier();
  if (!Ranks::root()) return 0;

  // Rank 0: every point of the space from the journal, in space order, and the front.
  done = read_done(false);
  nlohmann::json rows = nlohmann::json::array();
  for (size_t k = 0; k < space.size(); ++k) {
    const auto it = done.find(space[k].key);
    if (it == done.end()) throw InputError("point '" + space[k].label + "' is missing from " + out_path);
    nlohmann::json row = it->second.row;
    row["index"] = k;  // its place in this space (the journal may come from a reordered one)
    rows.push_back(std::move(row));
  }
  // A point below the accuracy floor (a collapsed design) has no cost: never on the front.
  const double floor = spec.accuracy ? accuracy_floor(spec, rows) : 0;
  std::vector<std::vector<double>> costs;
  int below_floor = 0;
  for (const auto& row : rows) {
    std::vector<double> c;
    const bool below = row.contains("accuracy") && row["accuracy"].is_number() && row["accuracy"].get<double>() < floor;
    below_floor += below;
    for (Objective o : spec.objectives)
      c.push_back(below ? std::numeric_limits<double>::quiet_NaN() : objective_cost(row, o));
    costs.push_back(c);
  }
  const std::vector<bool> front = pareto_front(costs);
  nlohmann::json front_labels = nlohmann::json::array();
  for (size_t k = 0; k < rows.size(); ++k) {
    rows[k]["front"] = static_cast<bool>(front[k]);
    if (front[k]) front_labels.push_back(rows[k]["label"]);
  }

  std::vector<std::string> labels;
  for (const auto& row : rows) labels.push_back(row["label"].get<std::string>());
  const Table table({{"point", fit_width("point", labels)},
                     {"status", -7},
                     {"accuracy", 8, 4},
                     {"drop", 7, 4},
                     {"drop_95%_interval", 18},
                     {"energy_uJ", 10, 3},
                     {"area_mm2", 9, 4},
                     {"latency_us", 11, 2},
                     {"front", -5}});
  table.print_header(stdout);
  int failed = 0;
  WarningSummary warnings;
  for (const auto& row : rows) {
    const bool ok = row["status"] == "ok";
    const bool acc = ok && row.contains("accuracy");
    failed += !ok;
    const std::string dash = "-";
    table.print_row(
        stdout,
        {row["label"].get<std::string>(), row["status"].get<std::string>(),
         acc ? Table::Cell(num(row, "accuracy")) : dash, acc ? Table::Cell(num(row, "accuracy_drop")) : dash,
         acc ? Table::Cell(interval(row)) : dash, ok ? Table::Cell(num(row, "energy_uj_per_image")) : dash,
         ok ? Table::Cell(num(row, "area_mm2")) : dash, ok ? Table::Cell(num(row, "latency_us")) : dash,
         std::string(row["front"].get<bool>() ? "*" : "")});
    if (!ok) std::printf("    reason: %s\n", row["reason"].get<std::string>().c_str());
    for (const auto& w : row.value("warnings", nlohmann::json::array()))
      warnings.add(row["label"].get<std::string>(), w.get<std::string>());
  }
  std::string objectives;
  for (Objective o : spec.objectives) objectives += (objectives.empty() ? "" : ", ") + to_string(o);
  std::printf("\n%zu points (%d failed); Pareto front over %s: %zu point%s (*)", rows.size(), failed,
              objectives.c_str(), front_labels.size(), front_labels.size() == 1 ? "" : "s");
  if (spec.accuracy && floor > 0)
    std::printf("; %d point%s below the accuracy floor %.4f (explore.min_accuracy) kept off it", below_floor,
                below_floor == 1 ? "" : "s", floor);
  std::printf("\n%s\n", kFractionsNote);
  warnings.print(stdout);

  if (args.has("--csv")) {
    SweepCsv csv(args.get("--csv"), space.front().values,
                 "status,accuracy,software_accuracy,mean_relative_error,worst_relative_error,energy_uj_per_image,"
                 "area_mm2,latency_us,throughput_images_per_s,avg_power_mw,accuracy_drop,accuracy_drop_ci95_low,"
                 "accuracy_drop_ci95_high,front,reason,warnings");
    for (size_t k = 0; k < rows.size(); ++k) {
      const auto& r = rows[k];
      auto& os = csv.row(static_cast<int>(k), space[k].values);
      os << "," << r["status"].get<std::string>();
      for (const char* f :
           {"accuracy", "software_accuracy", "mean_relative_error", "worst_relative_error", "energy_uj_per_image",
            "area_mm2", "latency_us", "throughput_images_per_s", "avg_power_mw", "accuracy_drop"}) {
        os << ",";
        if (r.contains(f)) os << r[f];
      }
      for (int e = 0; e < 2; ++e) {
        os << ",";
        if (r.contains("accuracy_drop_ci95")) os << r["accuracy_drop_ci95"][e];
      }
      std::string warnings;
      for (const auto& w : r.value("warnings", nlohmann::json::array()))
        warnings += (warnings.empty() ? "" : "; ") + w.get<std::string>();
      os << "," << (r["front"].get<bool>() ? 1 : 0) << "," << quoted(r.value("reason", "")) << "," << quoted(warnings)
         << "\n";
    }
    csv.commit();
  }
  nlohmann::json j;
  j["command"] = "explore";
  j["model"] = model.path;
  j["dataset"] = data.test.name;
  j["images"] = data.test.count();
  j["accuracy"] = spec.accuracy;
  j["combine"] = spec.combine == ExploreSpec::Combine::Zip ? "zip" : "product";
  j["swept_keys"] = base.sweep_keys();
  j["objectives"] = nlohmann::json::array();
  for (Objective o : spec.objectives) j["objectives"].push_back(to_string(o));
  j["color_by"] = color;
  if (spec.accuracy) j["min_accuracy"] = floor;
  j["points"] = rows;
  j["front"] = front_labels;
  if (args.has("--json")) write_json(args.get("--json"), j);
  if (args.has("--report")) {
    ReportInput rep;
    rep.command = "explore";
    rep.title = "xbarsim explore: " + std::filesystem::path(model.path).lexically_normal().string() +
                (spec.accuracy ? " on " + count_text(data.test.count(), data.test.name + " image") + ", "
                               : " (timing only, no accuracy), ") +
                count_text(static_cast<long long>(rows.size()), "design point");
    rep.config_yaml = base.dump();
    rep.swept_keys = base.sweep_keys();
    rep.color_key = color;
    if (spec.accuracy) rep.min_accuracy = floor;
    for (Objective o : spec.objectives) rep.objectives.push_back(to_string(o));
    rep.rows = rows;
    write_html_report(args.get("--report"), rep);
  }
  return 0;
}

}  // namespace

namespace {
const CommandRegistrar kRegister{
    "explore", cmd_explore,
    "explore --config SPACE.yaml --out RESULTS.jsonl [--model M.onnx] [--dataset D] [--images N]\n"
    "        [--json F] [--csv F] [--report F.html]\n"
    "      design-space exploration: every point's accuracy and per-layer error (eval) and platform cost and\n"
    "      timing (simulate), the Pareto front over explore.objectives; resumable (finished points in --out\n"
    "      are skipped); under mpirun the points are shared among the ranks",
    true};
}  // namespace

}  // namespace xbarsim
