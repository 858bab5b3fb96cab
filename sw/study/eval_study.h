#pragma once
/// eval as a library function: a whole network on crossbars against software, with
/// per-layer error propagation and the design's cost from the shared inventory.
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "sw/inference/crossbar_backend.h"
#include "sw/study/hardware.h"

namespace xbarsim {

/// Section `eval.`.
struct EvalSpec {
  int images = -1;  ///< -1 = all
  int offset = 0;
  int calibration_images = 200;
  int calibration_samples = 2048;
};
EvalSpec parse_eval_spec(const ConfigTree& cfg);

/// The test and calibration images of an evaluation. MNIST ships no calibration split here,
/// so test images 9000.. calibrate and are never evaluated (`note` says so).
struct EvalData {
  Dataset test, calib;
  std::string note;
};
/// Loads `dataset` (the model's metadata when empty) from `data_dir` for `model`.
/// Throws InputError naming the file and array when the images of `d` (the `split` "test" or
/// "calib" of `dataset`) are not of the model's input shape, or when a test label is outside the
/// model's classes (the first bad label and its image).
void check_dataset_fits(const Model& model, const Dataset& d, const std::string& dataset, const std::string& split);
EvalData load_eval_data(const Model& model, std::string dataset, const std::string& data_dir, const EvalSpec& spec);

/// One design point of an evaluation: the analog configuration and its hardware.
struct EvalPoint {
  AnalogConfig ac;
  HardwareContext hw;
};
EvalPoint parse_eval_point(const ConfigTree& cfg);

struct EvalLayer {
  std::string name;
  const LinearLayer* layer = nullptr;
  LayerInventory inventory;
  /// Over the evaluated images' outputs of the layer: |crossbar - software| / the layer's output
  /// range over the calibration images (layer_error, sw/analog/error_metrics.h).
  double mean_relative_error = 0, worst_relative_error = 0;
  double input_full_scale = 0, min_column_gain = 1;
  bool signed_inputs = false;
  long long out_of_range_cells = 0;
  long long stuck_cells = 0;         ///< cells stuck at g_min or g_max (device.stuck_at_*), after spares
  long long spare_columns_used = 0;  ///< columns replaced by spare columns (device.spare_columns)
  long long compensation_reads = 0;  ///< reads drift compensation made at device.time_s (per crossbar, summed)
  long long cells = 0;  ///< programmed cells of the layer's crossbars (physical columns included)
  double input_max = 0;      ///< largest |input| over the calibration images (input_full_scale clips below it)
  double input_clipped = 0;  ///< fraction of the sampled calibration inputs above input_full_scale
  AnalogLayer::RangeSummary ranges;  ///< weight, ADC and output-offset ranging
};

/// A layer whose conversion clipped more than this fraction of its cells is named in a warning:
/// the conversion cannot compensate clipped cells, so its error grows with their number.
constexpr double kClippedCellsWarning = 0.10;

/// Software against crossbars on the same images (a paired comparison): how many images only
/// one of them classifies correctly. The accuracy drop (software minus crossbar) and its 95 %
/// interval come from these discordant counts (Agresti & Min 2005: the Wald interval of a
/// difference of matched proportions with 0.5 added to each cell of the 2x2 table), so a
/// subset of a test set says how far from software the full set can plausibly be.
struct PairedAccuracy {
  int images = 0;
  int only_software = 0;  ///< images software classifies correctly and the crossbars do not
  int only_crossbar = 0;  ///< the other way round
  /// Software minus crossbar accuracy (fraction).
  double drop() const { return images ? static_cast<double>(only_software - only_crossbar) / images : 0.0; }
  /// 95 % interval [lo, hi] of the drop (fraction).
  std::pair<double, double> drop_ci95() const;
};
PairedAccuracy paired_accuracy(const std::vector<char>& software_correct, const std::vector<char>& crossbar_correct);

struct EvalResult {
  std::string model, dataset, note;
  int images = 0;
  int images_from_journal = 0;  ///< of `images`, read from the journal instead of evaluated
  double software_accuracy = 0, crossbar_accuracy = 0;
  PairedAccuracy paired;
  double program_time_s = 0, evaluate_time_s = 0;
  std::vector<EvalLayer> layers;
  CostReport cost;  ///< per image: closed-form action counts, leakage over ideal timing
  const AnalogConfig* ac = nullptr;
  nlohmann::json to_json() const;
  /// The design's converter and mapping settings as to_json writes them (method, the bits,
  /// adc_range, max_rows, max_cols): explore's rows carry the same fields.
  nlohmann::json design_json() const;
  /// Cells the conversion wanted outside [g_min, g_max], over the layers.
  long long out_of_range_cells() const;
  /// The network's relative error: the layers' mean errors averaged, their worst errors' maximum.
  std::pair<double, double> network_error() const;
  /// One sentence per layer with more than kClippedCellsWarning of its cells clipped, then one
  /// per layer whose mean error passes kLayerErrorWarning (sw/analog/error_metrics.h).
  std::vector<std::string> warnings() const;
};

/// The share of the images one process evaluates (MPI ranks): images k with k % count == index.
/// `gather` is collective: every share's bytes, in share order, at share 0 (Ranks::gather).
/// Share 0 reduces the tallies in image order, so its result equals one process's, bit for bit.
struct ImageShard {
  int index = 0, count = 1;
  std::function<std::vector<std::string>(const std::string&)> gather;
};

class ResultJournal;  // sw/study/journal.h
struct JournalKind;
struct JournalLine;

/// A resumable evaluation (eval --journal): every finished image is one line of the journal
/// under the run's key (appended about once a second); an image whose line is there already is
/// not evaluated again, and the result equals an uninterrupted run's, bit for bit.
struct EvalJournal {
  const ResultJournal* file = nullptr;  ///< where finished images are appended (null: nowhere)
  std::string key;                      ///< eval_run_key of the run
  int offset = 0;                       ///< dataset index of test image 0 (eval.offset)
  const std::vector<JournalLine>* rows = nullptr;  ///< the journal's lines, read before the run
                                                   ///< (any key; not owned)
};
/// The kind of eval's journal (--journal): a line per finished image, with its key and index.
/// A line of a run is checked when the run reads it: its image's outcome and per-layer error
/// tallies must be ones the run could have written (InputError naming the line otherwise), and
/// two different lines for one image are refused.
JournalKind eval_journal_kind();
/// A run's identity in a journal: its whole effective configuration except the image range
/// (eval.images, eval.offset: an image is identified by its dataset index), the sections that
/// cannot change an image's outcome (platform, study, explore) and what point_key ignores, with
/// the model (file_id of its file: a moved copy matches, a re-exported one not) and the dataset.
std::string eval_run_key(const ConfigTree& run_cfg, const std::string& model_id, const std::string& dataset);

/// Progress callbacks: (done, total) for programming (layers) and evaluation (images).
struct EvalProgress {
  std::function<void(int, int)> programming, evaluating;
};

/// Programs the crossbars of `point` on `calib` (run_eval's first step; explore shares them
/// with its platform simulation).
CrossbarBackend program_crossbars(const Model& model, const EvalPoint& point, const EvalSpec& spec,
                                  const Dataset& calib, const std::function<void(int, int)>& progress = nullptr);

/// Evaluates `test` (this process's share of it); the result is complete on share 0 only.
EvalResult run_eval(const Model& model, const EvalPoint& point, const EvalSpec& spec, const Dataset& test,
                    const Dataset& calib, const EvalProgress& progress = {}, const ImageShard& shard = {},
                    const EvalJournal* journal = nullptr);
/// The same on crossbars program_crossbars made for `point`; `program_time_s` is reported.
EvalResult run_eval(const Model& model, const EvalPoint& point, const Dataset& test, const CrossbarBackend& xb,
                    double program_time_s,
                    const std::function<void(int, int)>& evaluating = nullptr, const ImageShard& shard = {},
                    const EvalJournal* journal = nullptr);

}  // namespace xbarsim
