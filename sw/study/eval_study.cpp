#include "sw/study/eval_study.h"

#include "sw/analog/error_metrics.h"
#include "sw/common/errors.h"
#include "sw/common/input_file.h"
#include "sw/study/explore.h"
#include "sw/study/journal.h"

#include <algorithm>
#include <atomic>
#include <exception>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <stdexcept>
#include <mutex>

namespace xbarsim {

EvalSpec parse_eval_spec(const ConfigTree& cfg) {
  EvalSpec s;
  s.images = cfg.get_string("eval.images") == "all" ? -1 : cfg.get_int32("eval.images");
  s.offset = cfg.get_int32("eval.offset");
  s.calibration_images = cfg.get_int32("eval.calibration_images");
  s.calibration_samples = cfg.get_int32("eval.calibration_samples");
  return s;
}

namespace {

std::string shape_text(const Shape& s) {
  return std::to_string(s.c) + "x" + std::to_string(s.h) + "x" + std::to_string(s.w);
}

}  // namespace

void check_dataset_fits(const Model& model, const Dataset& d, const std::string& dataset, const std::string& split) {
  // Which array (or file) of the dataset this split came from, for the message.
  std::string where;
  if (is_npz_dataset(dataset)) {
    const bool own = split == "calib" && d.name == dataset && d.from_calib_array;
    where = "'" + dataset + "', array '" + (own ? "calib_images" : "images") + "'";
  } else {
    where = "the " + dataset + " " + (split == "calib" ? "calibration" : "test") + " images";
  }
  if (!(d.shape == model.input))
    throw InputError(where + ": the images are " + shape_text(d.shape) + " but the model expects " +
                     shape_text(model.input));
  if (split == "calib") return;  // calibration labels are never read
  const int classes = model.values.at(model.output).size();
  for (int k = 0; k < d.count(); ++k)
    if (d.labels[k] < 0 || d.labels[k] >= classes) {
      const std::string labels = is_npz_dataset(dataset) ? "'" + dataset + "', array 'labels'" : where;
      throw InputError(labels + ": label " + std::to_string(d.labels[k]) + " of image " +
                       std::to_string(d.first + k) + " is outside the model's " + std::to_string(classes) +
                       " classes (0.." + std::to_string(classes - 1) + ")");
    }
}

EvalData load_eval_data(const Model& model, std::string dataset, const std::string& data_dir, const EvalSpec& spec) {
  if (dataset.empty()) dataset = model.dataset;
  if (dataset.empty()) throw InputError("the model names no dataset in its metadata: give --dataset");
  EvalData d;
  int count = spec.images;
  const bool mnist = dataset == "mnist";
  if (mnist) {
    const int limit = kMnistCalibrationStart - spec.offset;
    if (limit <= 0) throw InputError("MNIST test images from 9000 on are the calibration set (see README)");
    if (count < 0 || count > limit) count = limit;
  }
  d.test = load_dataset(dataset, data_dir, "test", spec.offset, count);
  std::string calib_note;
  d.calib = is_npz_dataset(dataset) ? load_npz_dataset(dataset, "calib", 0, spec.calibration_images, &calib_note)
                                    : load_dataset(dataset, data_dir, "calib", 0, spec.calibration_images);
  // Fewer images than asked for (the end of the test set, MNIST's calibration images) is said,
  // never silent.
  const int n = d.test.count();
  const std::string range = "images " + std::to_string(spec.offset) + ".." + std::to_string(spec.offset + n - 1);
  if (spec.images > n)
    d.note =
        (mnist ? "MNIST test images 9000-9999 are the calibration set" : "the " + dataset + " test set ends there") +
        ": using " + range + " (" + std::to_string(n) + " of the " + std::to_string(spec.images) + " images asked for)";
  else if (mnist && spec.images < 0)
    d.note = "MNIST test images 9000-9999 are the calibration set: using " + range;
  if (!calib_note.empty()) d.note += std::string(d.note.empty() ? "" : "; ") + calib_note;
  if (d.calib.count() < spec.calibration_images)
    d.note += std::string(d.note.empty() ? "" : "; ") + "calibrating on " + std::to_string(d.calib.count()) +
              " of the " + std::to_string(spec.calibration_images) +
              " images eval.calibration_images asks for (all the " + dataset + " calibration set has)";
  check_dataset_fits(model, d.test, dataset, "test");
  check_dataset_fits(model, d.calib, dataset, "calib");
  return d;
}

EvalPoint parse_eval_point(const ConfigTree& cfg) {
  EvalPoint p;
  p.ac = parse_analog_config(cfg);
  if (p.ac.mapping.scheme == MappingScheme::Sparse)
    throw InputError(
        "configuration key 'mapping.scheme': eval computes the dense mapping; 'sparse' (Toeplitz) is "
        "costed by overhead and simulate");
  p.hw = make_hardware_context(cfg, p.ac);
  return p;
}

namespace {

/// The largest relative error a journal line may hold: far above any run's (errors are relative
/// to the layer's calibration range), and small enough that a layer's sum over a test set stays
/// finite (1e308 per image would add up to inf).
constexpr double kMaxJournalError = 1e100;

/// Per image and layer error tallies and correct counts, evaluated in parallel; reduced in
/// image order by the caller, so the figures do not depend on the number of threads.
struct ImageTallies {
  std::vector<ErrorTally> layer;  // images x L
  std::vector<char> sw_correct, xb_correct;
  std::vector<int32_t> sw_class, xb_class;  // the predicted classes (-1: a journal line without them)

  ImageTallies(int images, int L)
      : layer(static_cast<size_t>(images) * L),
        sw_correct(images, 0),
        xb_correct(images, 0),
        sw_class(images, -1),
        xb_class(images, -1) {}
};

/// Fills `t` with the journal's images of this run; returns which images it had.
std::vector<char> read_journal(const EvalJournal& j, const Model& model, ImageTallies& t, int images) {
  const int L = static_cast<int>(model.linear.size());
  std::vector<char> have(images, 0);
  if (!j.rows) return have;
  std::vector<const JournalLine*> line_of(images, nullptr);
  const std::string where = j.file ? j.file->describe() : std::string("the eval journal");
  for (const JournalLine& line : *j.rows) {
    const nlohmann::json& row = line.row;
    if (row.value("key", std::string()) != j.key) continue;
    const auto bad = [&](const std::string& why) {
      return InputError(where + ", line " + std::to_string(line.number) + ": a line of this run (key " + j.key + ") " +
                        why + ": " + excerpt(row.dump(), 120) + "; delete the line");
    };
    if (!row.contains("image") || !row["image"].is_number_integer() || !row.contains("layers") ||
        !row["layers"].is_array() || static_cast<int>(row["layers"].size()) != L || !row.contains("sw") ||
        !row.contains("xb") || !row["sw"].is_number_integer() || !row["xb"].is_number_integer() ||
        (row["sw"] != 0 && row["sw"] != 1) || (row["xb"] != 0 && row["xb"] != 1))
      throw bad("is malformed");
    const long long k = row["image"].get<long long>() - j.offset;
    if (k < 0 || k >= images) continue;  // outside this run's range of images
    if (line_of[k]) {
      if (line_of[k]->row == row) continue;  // the same result twice (two runs finished the image)
      throw bad("contradicts line " + std::to_string(line_of[k]->number) + " for image " +
                std::to_string(row["image"].get<long long>()));
    }
    line_of[k] = &line;
    t.sw_correct[k] = row["sw"].get<int>() != 0;
    t.xb_correct[k] = row["xb"].get<int>() != 0;
    // Journals written before the classes were recorded lack them: the image keeps -1.
    if (row.contains("sw_class") && row["sw_class"].is_number_integer()) t.sw_class[k] = row["sw_class"].get<int32_t>();
    if (row.contains("xb_class") && row["xb_class"].is_number_integer()) t.xb_class[k] = row["xb_class"].get<int32_t>();
    for (int l = 0; l < L; ++l) {
      const auto& e = row["layers"][l];
      // A layer's tally is over its output values (a fixed count); its errors are finite, at
      // least 0, and their sum is at most count x worst.
      const long long outputs = static_cast<long long>(model.linear[l].out.size());
      if (!e.is_array() || e.size() != 3 || !e[0].is_number() || !e[1].is_number() || !e[2].is_number_integer())
        throw bad("is malformed");
      const double sum = e[0].get<double>(), worst = e[1].get<double>();
      if (e[2].get<long long>() != outputs)
        throw bad("counts " + e[2].dump() + " outputs of layer " + model.linear[l].name + ", which has " +
                  std::to_string(outputs));
      if (!(worst >= 0 && worst <= kMaxJournalError && sum >= 0 && sum <= worst * outputs * (1 + 1e-9)))
        throw bad("has errors no run can give for layer " + model.linear[l].name);
      ErrorTally& et = t.layer[static_cast<size_t>(k) * L + l];
      et.sum = sum;
      et.worst = worst;
      et.count = outputs;
    }
    have[k] = 1;
  }
  return have;
}

/// The journal line of image `k` (its tallies exactly: JSON numbers round-trip doubles).
std::string journal_line(const EvalJournal& j, const ImageTallies& t, int k, int L) {
  nlohmann::json layers = nlohmann::json::array();
  for (int l = 0; l < L; ++l) {
    const ErrorTally& et = t.layer[static_cast<size_t>(k) * L + l];
    layers.push_back({et.sum, et.worst, et.count});
  }
  return nlohmann::json{{"key", j.key},
                        {"image", j.offset + k},
                        {"sw", static_cast<int>(t.sw_correct[k])},
                        {"xb", static_cast<int>(t.xb_correct[k])},
                        {"sw_class", t.sw_class[k]},
                        {"xb_class", t.xb_class[k]},
                        {"layers", layers}}
             .dump() +
         "\n";
}

ImageTallies evaluate_images(const Model& model, const CrossbarBackend& xb, const Dataset& test, int images,
                             int threads, const ImageShard& shard, const std::function<void(int, int)>& progress,
                             const EvalJournal* journal, int& from_journal) {
  const int L = static_cast<int>(model.linear.size());
  ImageTallies t(images, L);
  // Each layer's errors are relative to its output range over the calibration images.
  std::vector<double> output_range(L);
  for (int l = 0; l < L; ++l) output_range[l] = layer_output_range(xb.statistics(l).out_lo, xb.statistics(l).out_hi);
  const std::vector<char> have = journal ? read_journal(*journal, model, t, images) : std::vector<char>(images, 0);
  from_journal = static_cast<int>(std::count(have.begin(), have.end(), 1));
  std::mutex mu;
  int done = 0, mine = 0;  // images of this share still to evaluate
  for (int k = shard.index; k < images; k += shard.count) mine += !have[k];
  // Finished images' journal lines, written about once a second (and at the end).
  std::string pending;
  auto last_write = std::chrono::steady_clock::now();
  const ResultJournal* file = journal ? journal->file : nullptr;
  // An image that fails ends the run with the lowest such image, whatever the threads: after a
  // failure at image f every thread still evaluates its images below f (a failure among them
  // becomes the one reported), and none above.
  std::atomic<int> first_failed{images};
  std::exception_ptr failure;
  // Images in parallel; inside an image, linear layers run serially.
  try {
    parallel_for(threads, threads, [&](int th) {
      SoftwareBackend sw(model);
      LayerTrace sw_trace, xb_trace;
      sw_trace.record_inputs = xb_trace.record_inputs = false;
      std::vector<float> x(model.input.size());
      for (int k = shard.index + th * shard.count; k < images && k < first_failed; k += threads * shard.count) {
        if (have[k]) continue;
        test.preprocess(k, model.pre, x.data());
        Eigen::Index a, b;
        run_image(model, x.data(), sw, &sw_trace).maxCoeff(&a);
        try {
          CrossbarBackend::set_image(static_cast<uint64_t>(test.first + k));
          run_image(model, x.data(), xb, &xb_trace).maxCoeff(&b);
        } catch (...) {
          std::lock_guard<std::mutex> lock(mu);
          if (k < first_failed) {
            first_failed = k;
            failure = current_exception_with_context(test.name + " image " + std::to_string(test.first + k));
          }
          return;
        }
        t.sw_correct[k] = a == test.labels[k];
        t.xb_correct[k] = b == test.labels[k];
        t.sw_class[k] = static_cast<int32_t>(a);
        t.xb_class[k] = static_cast<int32_t>(b);
        for (int l = 0; l < L; ++l)
          t.layer[static_cast<size_t>(k) * L + l] =
              layer_error(xb_trace.outputs[l], sw_trace.outputs[l], output_range[l]);
        std::lock_guard<std::mutex> lock(mu);
        if (file) {
          pending += journal_line(*journal, t, k, L);
          const auto now = std::chrono::steady_clock::now();
          if (now - last_write >= std::chrono::seconds(1)) {
            file->append_lines(pending);
            pending.clear();
            last_write = now;
          }
        }
        if (progress) progress(++done, mine);
      }
    });
  } catch (...) {
    if (file) file->append_lines(pending);  // keep what finished before the error
    throw;
  }
  if (file) file->append_lines(pending);
  if (failure) std::rethrow_exception(failure);
  return t;
}

/// Brings every share's tallies to share 0: each sends its arrays whole (the images of
/// other shares are zero) and share 0 takes image k from share k % count.
void gather_tallies(ImageTallies& t, int images, int L, const ImageShard& shard) {
  // Every array of the tallies, packed in this order.
  auto each_array = [](ImageTallies& x, const auto& f) {
    f(x.layer);
    f(x.sw_correct);
    f(x.xb_correct);
    f(x.sw_class);
    f(x.xb_class);
  };
  std::string mine;
  each_array(t, [&](const auto& v) { mine.append(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(v[0])); });
  const std::vector<std::string> all = shard.gather(mine);
  if (shard.index != 0) return;
  if (static_cast<int>(all.size()) != shard.count) throw std::runtime_error("gather returned the wrong share count");
  for (int s = 1; s < shard.count; ++s) {
    if (all[s].size() != mine.size()) throw std::runtime_error("a share's tallies have the wrong size");
    ImageTallies o(images, L);
    size_t at = 0;
    each_array(o, [&](auto& v) {
      std::memcpy(v.data(), all[s].data() + at, v.size() * sizeof(v[0]));
      at += v.size() * sizeof(v[0]);
    });
    for (int k = s; k < images; k += shard.count) {
      t.sw_correct[k] = o.sw_correct[k];
      t.xb_correct[k] = o.xb_correct[k];
      t.sw_class[k] = o.sw_class[k];
      t.xb_class[k] = o.xb_class[k];
      for (int l = 0; l < L; ++l) t.layer[static_cast<size_t>(k) * L + l] = o.layer[static_cast<size_t>(k) * L + l];
    }
  }
}

}  // namespace

CrossbarBackend program_crossbars(const Model& model, const EvalPoint& point, const EvalSpec& spec,
                                  const Dataset& calib, const std::function<void(int, int)>& progress) {
  // Every calibration vector is one of the kept rows: at least calibration.samples of them (as
  // the Python layers keep max(eval.calibration_samples, calibration.samples)).
  CrossbarBackend xb(model, point.ac);
  xb.program(calib, std::max(spec.calibration_samples, point.ac.calibration.samples), progress);
  return xb;
}

JournalKind eval_journal_kind() {
  return {"eval journal", "--journal", [](const nlohmann::json& row) {
            return row.contains("key") && row["key"].is_string() && row.contains("image") &&
                   row["image"].is_number_integer();
          }};
}

std::string eval_run_key(const ConfigTree& run_cfg, const std::string& model_id, const std::string& dataset) {
  // The image range, and the sections that cannot change an image's outcome: the platform's
  // timing, xbar-study's synthetic crossbar, explore's space.
  // "errors layer-range": the per-layer error metric its lines hold (journals of the earlier
  // per-channel metric are another run's, not reused).
  return point_key(run_cfg, {"eval.images", "eval.offset", "platform.", "study.", "explore."}) + " model " + model_id +
         " " + dataset + " errors layer-range";
}

EvalResult run_eval(const Model& model, const EvalPoint& point, const EvalSpec& spec, const Dataset& test,
                    const Dataset& calib, const EvalProgress& progress, const ImageShard& shard,
                    const EvalJournal* journal) {
  const auto t0 = std::chrono::steady_clock::now();
  const CrossbarBackend xb = program_crossbars(model, point, spec, calib, progress.programming);
  const double program_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return run_eval(model, point, test, xb, program_s, progress.evaluating, shard, journal);
}

EvalResult run_eval(const Model& model, const EvalPoint& point, const Dataset& test, const CrossbarBackend& xb,
                    double program_time_s, const std::function<void(int, int)>& evaluating, const ImageShard& shard,
                    const EvalJournal* journal) {
  const AnalogConfig& ac = point.ac;
  require_fit(model, point.hw);  // as simulate: a machine the network does not fit is refused
  EvalResult r;
  r.ac = &point.ac;
  r.model = model.path;
  r.dataset = test.name;
  const auto t1 = std::chrono::steady_clock::now();
  r.images = test.count();
  const int threads = std::max(1, std::min(resolve_threads(ac.solver.threads), r.images));
  ImageTallies t =
      evaluate_images(model, xb, test, r.images, threads, shard, evaluating, journal, r.images_from_journal);
  const int L = static_cast<int>(model.linear.size());
  if (shard.count > 1) gather_tallies(t, r.images, L, shard);
  r.program_time_s = program_time_s;
  r.evaluate_time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t1).count();
  int swc = 0, xbc = 0;
  for (int k = 0; k < r.images; ++k) {
    swc += t.sw_correct[k];
    xbc += t.xb_correct[k];
  }
  r.software_accuracy = static_cast<double>(swc) / r.images;
  r.crossbar_accuracy = static_cast<double>(xbc) / r.images;
  r.paired = paired_accuracy(t.sw_correct, t.xb_correct);
  const double clock_ns = point.hw.platform.clock_ns();
  double edram_read_bytes = 0;  // on a machine: the layers' input shifts over their tile's bus
  std::vector<bool> signed_inputs;
  const std::vector<bool> reads_image = linear_reads_image(model);
  for (int l = 0; l < L; ++l) {
    EvalLayer el;
    el.layer = &model.linear[l];
    el.name = model.linear[l].name;
    el.inventory = point.hw.inventory(model.linear[l], MappingScheme::Dense, xb.statistics(l).signed_inputs, reads_image[l]);
    ErrorTally sum;
    for (int k = 0; k < r.images; ++k) sum += t.layer[static_cast<size_t>(k) * L + l];
    el.mean_relative_error = sum.mean();
    el.worst_relative_error = sum.worst;
    el.input_full_scale = xb.statistics(l).x_max;
    el.input_max = xb.statistics(l).input_max;
    el.input_clipped = xb.statistics(l).input_clipped;
    el.ranges = xb.layer(l).range_summary();
    el.signed_inputs = xb.statistics(l).signed_inputs;
    el.compensation_reads = xb.layer(l).compensation_reads();
    for (const auto& rep : xb.layer(l).reports()) {
      el.out_of_range_cells += rep.out_of_range_cells;
      el.stuck_cells += rep.stuck_cells;
      el.spare_columns_used += rep.spare_columns_used;
      el.cells += static_cast<long long>(rep.block.rows) * rep.physical_cols;
      el.min_column_gain = std::min(el.min_column_gain, rep.min_column_gain);
    }
    const ActionCounts a = layer_actions_per_image(el.inventory, dense_shifted_entries(model.linear[l]));
    add_layer_cost(r.cost, point.hw, el.inventory, a);
    edram_read_bytes += a.buffer_read_bytes;
    signed_inputs.push_back(el.signed_inputs);
    r.cost.time_ns += el.inventory.reads() * point.hw.platform.read_cycles(el.inventory.reads_image) * clock_ns;
    r.layers.push_back(el);
  }
  if (point.hw.arch.machine) {  // the chip, and the mapped network's traffic on it
    const MachineReport mr = machine_report(model, point.hw, signed_inputs);
    add_machine_cost(r.cost, point.hw, machine_actions(model, point.hw, mr.mapping, edram_read_bytes));
  } else {
    add_platform_cost(r.cost, point.hw, platform_actions(model, point.hw.platform.activation_bytes));
  }
  return r;
}

PairedAccuracy paired_accuracy(const std::vector<char>& software_correct, const std::vector<char>& crossbar_correct) {
  if (software_correct.size() != crossbar_correct.size())
    throw std::logic_error("paired_accuracy: the two lists of images differ in length");
  PairedAccuracy p;
  p.images = static_cast<int>(software_correct.size());
  for (size_t k = 0; k < software_correct.size(); ++k) {
    p.only_software += software_correct[k] && !crossbar_correct[k];
    p.only_crossbar += !software_correct[k] && crossbar_correct[k];
  }
  return p;
}

std::pair<double, double> PairedAccuracy::drop_ci95() const {
  if (images == 0) return {0.0, 0.0};
  // 0.5 added to each of the four cells: n + 2 images, b + 0.5 and c + 0.5 discordant; the
  // interval is clipped to the possible drops, [-1, 1].
  const double n = images + 2.0, b = only_software + 0.5, c = only_crossbar + 0.5;
  const double d = (b - c) / n;
  const double half = 1.959963984540054 * std::sqrt(std::max(0.0, (b + c) - (b - c) * (b - c) / n)) / n;
  return {std::max(-1.0, d - half), std::min(1.0, d + half)};
}

std::vector<std::string> EvalResult::warnings() const {
  std::vector<std::string> w;
  for (const auto& l : layers) {
    if (l.cells == 0 || l.out_of_range_cells <= kClippedCellsWarning * l.cells) continue;
    char pct[32];
    std::snprintf(pct, sizeof pct, "%.0f", 100.0 * l.out_of_range_cells / l.cells);
    w.push_back("layer " + l.name + ": the conversion wanted a conductance outside [g_min, g_max] for " +
                std::to_string(l.out_of_range_cells) + " of its " + std::to_string(l.cells) + " cells (" + pct +
                " %), which were clipped and are not compensated; fewer mapping.max_rows, more mapping.g_headroom "
                "or mapping.negative: differential keeps them in range");
  }
  // After the clipped cells, which are one of their causes.
  for (const auto& l : layers)
    if (l.mean_relative_error > kLayerErrorWarning) w.push_back(layer_error_warning(l.name, l.mean_relative_error));
  return w;
}

nlohmann::json EvalResult::design_json() const {
  auto bits = [](int b) { return b ? nlohmann::json(b) : nlohmann::json("none"); };
  auto size = [](int s) { return s ? nlohmann::json(s) : nlohmann::json("unbounded"); };
  return {{"method", ac->mitigation.name()},
          {"dac_bits", bits(ac->converters.dac_bits)},
          {"adc_bits", bits(ac->converters.adc_bits)},
          {"input_bits", bits(ac->converters.input_bits)},
          {"image_bits", bits(ac->converters.image_bits)},
          {"cell_bits", bits(ac->mapping.cell_bits)},
          {"weight_bits", bits(ac->mapping.weight_bits)},
          {"adc_range", to_string(ac->converters.adc_range)},
          {"max_rows", size(ac->mapping.max_rows)},
          {"max_cols", size(ac->mapping.max_cols)}};
}

long long EvalResult::out_of_range_cells() const {
  long long n = 0;
  for (const auto& l : layers) n += l.out_of_range_cells;
  return n;
}

std::pair<double, double> EvalResult::network_error() const {
  double mean = 0, worst = 0;
  for (const auto& l : layers) {
    mean += l.mean_relative_error / layers.size();
    worst = std::max(worst, l.worst_relative_error);
  }
  return {mean, worst};
}

nlohmann::json EvalResult::to_json() const {
  nlohmann::json j = design_json();
  j["model"] = model;
  j["dataset"] = dataset;
  j["images"] = images;
  j["software_accuracy"] = software_accuracy;
  j["crossbar_accuracy"] = crossbar_accuracy;
  const auto ci = paired.drop_ci95();
  j["accuracy_drop"] = paired.drop();
  j["accuracy_drop_ci95"] = {ci.first, ci.second};
  j["images_only_software_correct"] = paired.only_software;
  j["images_only_crossbar_correct"] = paired.only_crossbar;
  j["negative"] = ac->mapping.differential() ? "differential" : "shift";
  const RangingSpec& rs = ac->ranging;
  j["ranging"] = {{"weights", to_string(rs.weights)},
                  {"weight_percentile", rs.weight_percentile},
                  {"weight_scale", to_string(rs.weight_scale)},
                  {"inputs", to_string(rs.inputs)},
                  {"input_percentile", rs.input_percentile},
                  {"adc", to_string(rs.adc)},
                  {"adc_percentile", rs.adc_percentile},
                  {"adc_scope", to_string(rs.adc_scope)},
                  {"bias_correction", rs.bias_correction}};
  long long clipped_weights = 0;
  for (const auto& l : layers) clipped_weights += l.ranges.clipped_weights;
  j["clipped_weights"] = clipped_weights;
  j["device_model"] = ac->device.model;
  j["device_time_s"] = ac->device.time_s;
  j["device_compensation"] = to_string(ac->device.compensation);
  j["program_sigma_us"] = ac->device.program_sigma_s * 1e6;
  j["memristor_model"] = to_string(ac->xbar.memristor.model);
  if (ac->xbar.memristor.model == MemristorModel::Sinh) j["memristor_k_per_v"] = ac->xbar.memristor.k_per_v;
  j["dac_predistortion"] = ac->converters.dac_predistortion;
  j["transistor_model"] = to_string(ac->xbar.transistor.model);
  if (!note.empty()) j["note"] = note;
  j["program_time_s"] = program_time_s;
  j["evaluate_time_s"] = evaluate_time_s;
  j["images_from_journal"] = images_from_journal;
  j["images_per_s"] = (images - images_from_journal) / std::max(1e-9, evaluate_time_s);
  j["layers"] = nlohmann::json::array();
  for (const auto& l : layers) {
    const LinearLayer& L = *l.layer;
    j["layers"].push_back({{"name", l.name},
                           {"kernel", {L.k_h, L.k_w, L.c_in, L.c_out}},
                           {"rows", L.rows()},
                           {"cols", L.c_out},
                           {"crossbars", l.inventory.crossbars},
                           {"adcs", l.inventory.adcs},
                           {"dacs", l.inventory.dacs},
                           {"iterations", l.inventory.iterations},
                           {"input_full_scale", l.input_full_scale},
                           {"input_max", l.input_max},
                           {"input_clipped", l.input_clipped},
                           {"weight_clip", l.ranges.weight_clip},
                           {"clipped_weights", l.ranges.clipped_weights},
                           {"adc_clip", l.ranges.adc_clip},
                           {"adc_full_scale_ua", l.ranges.adc_full_scale_a * 1e6},
                           {"output_offset_rms", l.ranges.output_offset_rms},
                           {"signed_inputs", l.signed_inputs},
                           {"out_of_range_cells", l.out_of_range_cells},
                           {"stuck_cells", l.stuck_cells},
                           {"spare_columns_used", l.spare_columns_used},
                           {"compensation_reads", l.compensation_reads},
                           {"min_column_gain", l.min_column_gain},
                           {"mean_relative_error", l.mean_relative_error},
                           {"worst_relative_error", l.worst_relative_error}});
  }
  j["out_of_range_cells"] = out_of_range_cells();
  j["warnings"] = warnings();
  j.update(cost.to_json());
  // Eval's time per image is not simulate's: the linear layers' crossbar reads back to back,
  // one clock each, nothing else (no transfers, digital stages or waiting). Its average power
  // is named for it, so that no command prints a different number for simulate's avg_power_mw.
  j["ideal_time_ns_per_image"] = j["time_ns_per_image"];
  j["ideal_avg_power_mw"] = j["avg_power_mw"];
  j.erase("time_ns_per_image");
  j.erase("avg_power_mw");
  j["energy_note"] =
      "closed-form action counts per image; leakage over the ideal time (ideal_time_ns_per_image: one clock per "
      "crossbar read, the layers back to back, no transfers or digital stages); ideal_avg_power_mw = energy / that "
      "time, higher than simulate's avg_power_mw (energy / the simulated time per image)";
  return j;
}

}  // namespace xbarsim
