// xbarsim eval: argument parsing and rendering of a whole-network evaluation
// (sw/study/eval_study.h).
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <memory>

#include "sw/app/app_common.h"
#include "sw/app/model_source.h"
#include "sw/app/table.h"
#include "sw/common/quantity_text.h"
#include "sw/common/ranks.h"
#include "sw/study/eval_study.h"
#include "sw/study/explore.h"
#include "sw/study/journal.h"
#include "sw/study/sweep.h"

namespace xbarsim {

namespace {

void print_layers(const EvalResult& r) {
  std::vector<std::string> names;
  for (const auto& l : r.layers) names.push_back(l.name);
  const Table t({{"layer", fit_width("layer", names)},
                 {"rows", 6},
                 {"cols", 5},
                 {"xbars", 6},
                 {"mean_rel_error", 14, 6},
                 {"worst_rel_error", 15, 6}});
  std::printf("\n");
  t.print_header(stdout);
  for (const auto& l : r.layers)
    t.print_row(stdout, {l.name, l.inventory.rows, l.inventory.cols, l.inventory.crossbars, l.mean_relative_error,
                         l.worst_relative_error});
}

int cmd_eval(int argc, char** argv) {
  const CliArgs args(argc, argv, 0, {"--model", "--dataset", "--images", "--offset", "--report", "--journal"});
  std::vector<std::string> sets = args.sets();
  if (args.has("--images")) sets.push_back("eval.images=" + args.get("--images"));
  if (args.has("--offset")) sets.push_back("eval.offset=" + args.get("--offset"));
  const ConfigTree base = ConfigTree::load(args.get("--config"), sets);
  // Every key is checked before any file is read.
  const EvalSpec spec = parse_eval_spec(base);
  const auto points = sweep_points(base);
  const std::vector<EvalPoint> designs = check_sweep<EvalPoint>(base, points, parse_eval_point);
  Model model = load_onnx_model(find_model_file(args.require("--model"), base));
  apply_preprocessing_overrides(base, model.pre, model.input.c);
  for (const EvalPoint& d : designs) require_fit(model, d.hw);  // every point, before any runs
  if (const std::string w = preprocessing_warning(model, base); !w.empty() && Ranks::root())
    std::fprintf(stderr, "xbarsim eval: warning: %s\n", w.c_str());
  const EvalData data = load_eval_data(model, args.get("--dataset"), resolve_data_dir(base), spec);
  if (!data.note.empty() && Ranks::root()) std::fprintf(stderr, "xbarsim eval: %s\n", data.note.c_str());
  for (const Dataset* d : {&data.test, &data.calib}) {
    const bool calib = d == &data.calib;
    if (calib && !d->from_calib_array) continue;  // the test images again
    const std::string w = dataset_range_warning(*d, model.pre, calib ? "the calibration images" : "the images");
    if (!w.empty() && Ranks::root()) std::fprintf(stderr, "xbarsim eval: warning: %s\n", w.c_str());
  }
  check_outputs(args, {"--json", "--csv", "--report", "--journal"});  // every file it reads is known now

  // --journal: finished images are recorded as they finish; those already there are reused.
  std::unique_ptr<ResultJournal> journal_file;
  std::vector<EvalJournal> journals(points.size());
  std::vector<JournalLine> journal_rows;
  if (args.has("--journal")) {
    journal_file = std::make_unique<ResultJournal>(args.get("--journal"), eval_journal_kind());
    if (Ranks::root()) journal_file->repair();
    Ranks::barrier();
    int skipped = 0;
    journal_rows = journal_file->read(&skipped);
    Ranks::barrier();  // everyone has read the journal before anyone appends to it
    if (skipped && Ranks::root())
      std::fprintf(stderr, "xbarsim eval: %d unreadable lines of %s ignored\n", skipped, journal_file->path().c_str());
    const std::string model_id = file_id(model.path);
    for (size_t run = 0; run < points.size(); ++run)
      journals[run] = {journal_file.get(), eval_run_key(sweep_config(base, points[run]), model_id, data.test.name),
                       spec.offset, &journal_rows};
    // Lines of another model, dataset or setting stay in the journal; say so, or a changed key
    // (a different value of any key) would silently evaluate everything again.
    const auto foreign = std::count_if(journal_rows.begin(), journal_rows.end(), [&](const JournalLine& line) {
      const std::string key = line.row.value("key", std::string());
      return std::none_of(journals.begin(), journals.end(), [&](const EvalJournal& j) { return j.key == key; });
    });
    if (foreign && Ranks::root())
      std::fprintf(stderr,
                   "xbarsim eval: %ld lines of %s are of another model, dataset or configuration; kept, not reused\n",
                   static_cast<long>(foreign), journal_file->path().c_str());
  }

  // Under MPI every rank evaluates its share of the images; rank 0 reduces, prints and writes.
  const bool root = Ranks::root();
  ImageShard shard;
  if (Ranks::size() > 1) shard = {Ranks::rank(), Ranks::size(), Ranks::gather};
  std::unique_ptr<SweepOutputs> out;
  if (root)
    out = std::make_unique<SweepOutputs>(
        args, points.front(), "layer,name,rows,cols,crossbars,adcs,dacs,mean_relative_error,worst_relative_error");
  if (out)
    out->set_report("eval", base,
                    std::filesystem::path(model.path).lexically_normal().string() + " on " +
                        count_text(data.test.count(), data.test.name + " image"));
  const std::vector<std::string> labels = sweep_labels(points);
  const Table table({{"run", fit_width("run", labels)},
                     {"images", 7},
                     {"software", 8, 4},
                     {"crossbar", 8, 4},
                     {"drop", 7, 4},
                     {"drop_95%_interval", 18},
                     {"xbars", 8},
                     {"oor", 7},
                     {"img/s", 9, 1}});
  WarningSummary warnings;
  if (root) table.print_header(stdout);
  // Crossbars programmed for one point serve the next when it differs only in their readout or
  // the time they are read at (programs_alike: a sweep over device.time_s programs once).
  std::unique_ptr<CrossbarBackend> programmed;
  for (size_t run = 0; run < points.size(); ++run) {
    const std::string& label = labels[run];
    ProgressBar prog(static_cast<int>(model.linear.size()), "programming " + label);
    ProgressBar eval_bar((data.test.count() - shard.index + shard.count - 1) / shard.count, "evaluating  " + label);
    const auto t0 = std::chrono::steady_clock::now();
    if (programmed && programs_alike(programmed->config(), designs[run].ac))
      programmed->set_readout(designs[run].ac, [&](int d, int) { prog.update(d); });
    else
      programmed = std::make_unique<CrossbarBackend>(program_crossbars(
          model, designs[run], spec, data.calib, [&](int d, int) { prog.update(d); }));
    prog.finish();
    const double program_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    const EvalResult r = run_eval(model, designs[run], data.test, *programmed, program_s,
                                  [&](int d, int n) { eval_bar.update(d, n); }, shard,
                                  journal_file ? &journals[run] : nullptr);
    eval_bar.finish();
    // A later point that shares this one's key (it differs only where an image's outcome cannot,
    // e.g. platform.clock_mhz) reuses the lines just written.
    if (journal_file && std::any_of(journals.begin() + run + 1, journals.end(),
                                    [&](const EvalJournal& j) { return j.key == journals[run].key; })) {
      Ranks::barrier();  // every rank has appended its images
      journal_rows = journal_file->read();
    }
    if (!root) continue;
    if (r.images_from_journal)
      std::fprintf(stderr, "xbarsim eval: %s: %d of %d images from %s\n", label.c_str(), r.images_from_journal,
                   r.images, journal_file->path().c_str());
    if (!r.note.empty()) std::fprintf(stderr, "xbarsim eval: %s\n", r.note.c_str());
    for (const std::string& w : r.warnings()) warnings.add(points.size() > 1 ? label : "", w);
    nlohmann::json j = r.to_json();
    j["preprocessing"] = {{"scale", model.pre.scale}, {"mean", model.pre.mean}, {"std", model.pre.std}};
    long long oor = j["out_of_range_cells"];
    const auto ci = r.paired.drop_ci95();
    table.print_row(stdout,
                    {label, static_cast<long long>(r.images), r.software_accuracy, r.crossbar_accuracy,
                     r.paired.drop(), drop_interval_text(ci.first, ci.second), r.cost.crossbars, oor,
                     r.images_from_journal == r.images ? Table::Cell("-")  // nothing evaluated
                                                       : Table::Cell(j["images_per_s"].get<double>())});
    if (points.size() == 1) print_layers(r);
    if (out->csv().enabled())
      for (size_t l = 0; l < r.layers.size(); ++l) {
        const EvalLayer& el = r.layers[l];
        out->csv().row(static_cast<int>(run), points[run])
            << "," << l << "," << el.name << "," << el.inventory.rows << "," << el.inventory.cols << ","
            << el.inventory.crossbars << "," << el.inventory.adcs << "," << el.inventory.dacs << ","
            << el.mean_relative_error << "," << el.worst_relative_error << "\n";
      }
    out->add(std::move(j), points[run]);
  }
  if (root) {
    std::printf("\n%s\n", kFractionsNote);
    warnings.print(stdout);
  }
  if (out) out->finish();
  return 0;
}

}  // namespace

namespace {
const CommandRegistrar kRegister{
    "eval", cmd_eval,
    "eval --model M.onnx [--dataset cifar10|mnist|FILE.npz] [--images N] [--offset K] [--config F] [--set k=v]...\n"
    "     [--json F] [--csv F] [--report F.html] [--journal F.jsonl]\n"
    "      accuracy on crossbars vs software, per-layer error propagation; list values sweep;\n"
    "      under mpirun the images are shared among the ranks; --journal records every finished\n"
    "      image, and a rerun with it evaluates only the images not there yet (same result)",
    true};
}  // namespace

}  // namespace xbarsim
