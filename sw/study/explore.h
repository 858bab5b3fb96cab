#pragma once
/// Design-space exploration as library functions (xbarsim explore): the points of a space,
/// the identity of a point (for resuming), the resumable result journal and the Pareto front.
/// The runner that evaluates a point and simulates its platform is platform/app/cmd_explore.cpp.
#include <nlohmann/json.hpp>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "sw/common/config.h"
#include "sw/study/journal.h"
#include "sw/study/sweep.h"

namespace xbarsim {

/// A Pareto objective; accuracy is maximised, the others minimised.
enum class Objective { Accuracy, Energy, Area, Latency, Power };
std::string to_string(Objective o);

/// Section `explore.`.
struct ExploreSpec {
  std::string model, dataset;
  enum class Combine { Product, Zip } combine = Combine::Product;
  std::vector<Objective> objectives;
  std::string color_by;  ///< a swept key, or "" (the first swept key)
  /// explore.accuracy: false runs every point's platform timing only (no programming, no
  /// evaluation, no dataset): cost and timing in seconds, without accuracy.
  bool accuracy = true;
  /// explore.min_accuracy: points below this crossbar accuracy (a fraction) are never on the
  /// front; negative = auto (half the software accuracy).
  double min_accuracy = -1;
  std::string note;  ///< what parsing changed, for the user (an objective left out)
};
/// Parses explore.* and checks that the space sweeps nothing an exploration keeps fixed (the
/// model, the images, the data and preprocessing: explore.*, eval.*, data.*, preprocessing.*).
ExploreSpec parse_explore_spec(const ConfigTree& cfg);

/// The points of the space: the cartesian product of every list (sweep_points), or with
/// combine = zip point k takes the k-th value of every list (all lists equally long).
std::vector<SweepPoint> explore_points(const ConfigTree& cfg, ExploreSpec::Combine combine);

/// FNV-1a, 64 bit: the hash behind the journals' keys (point_key, file_id).
class Fnv1a {
 public:
  void add(const char* bytes, size_t n) {
    for (size_t i = 0; i < n; ++i) {
      h_ ^= static_cast<unsigned char>(bytes[i]);
      h_ *= 1099511628211ULL;
    }
  }
  void add(const std::string& s) { add(s.data(), s.size()); }
  /// 16 lowercase hex digits.
  std::string hex() const;

 private:
  uint64_t h_ = 1469598103934665603ULL;
};

/// A file's identity by its content (Fnv1a::hex of its bytes); the hash of no bytes when it
/// cannot be read.
std::string file_id(const std::string& path);

/// A point's identity: a hash of its whole effective configuration except what does not change
/// its results (solver.threads, explore.objectives / color_by / combine, limits.*, and the keys
/// `also_ignored`; an entry ending in '.' is a whole section), with the values of numeric keys
/// (ConfigTree::is_numeric) in canonical_value form. A journal row counts as done for a point
/// only when its key matches.
std::string point_key(const ConfigTree& point_cfg, const std::vector<std::string>& also_ignored = {});

/// Whether point_key leaves `key` out whatever the caller (solver.threads, explore.objectives /
/// color_by / combine, limits.*): a list over such a key gives points that are one point.
bool point_key_ignores(const std::string& key);

/// A point of an exploration's identity: point_key without explore.model and explore.dataset,
/// with the model known by its content (`model_id`, file_id of its file: a moved copy matches,
/// a changed file not) and the dataset by name, as eval_run_key does.
std::string explore_point_key(const ConfigTree& point_cfg, const std::string& model_id, const std::string& dataset);

/// The keys a point's crossbars are read out with after they are programmed, or that do not
/// reach the crossbars at all (an entry ending in '.' is a whole section): the ADCs
/// (converters.adc_bits, adc_range, adc_margin, adc_offset_subtraction, adc_columns_per_adc), the
/// component library, the architecture, the platform and xbar-study's section. Explore programs
/// the points that differ only in these (and in whether mitigation.method calibrates) once, and
/// reads the others out of those crossbars (CrossbarBackend::set_readout).
const std::vector<std::string>& readout_keys();

/// A point's programming identity: point_key without readout_keys, mitigation.method known by
/// its conversion only (conversion and conversion+calibration program alike), with the model and
/// dataset as in explore_point_key. Points with equal keys program equal crossbars.
std::string programming_key(const ConfigTree& point_cfg, const std::string& model_id, const std::string& dataset);

/// The points one of `ranks` MPI ranks runs, in order: `pending` (indices into the space, with
/// `group_of` their programming_key by index) ordered group by group (the groups in the order of
/// their first point, each group's points in space order) and cut into `ranks` contiguous shares
/// whose sizes differ by at most one. A group is programmed once per rank it reaches: at most
/// groups + ranks - 1 programmings in all, whatever the ranks.
std::vector<size_t> explore_share(const std::vector<size_t>& pending, const std::vector<std::string>& group_of,
                                  int rank, int ranks);

/// A number as one text per value. For a real key: the shortest text that reads back as the
/// same double ("3.0", "3e0" and "3" are "3"; "0.40" is "0.4"; "1000", "1000.0" and "1e3" are
/// "1e+03"). For an `integer` key (ConfigTree::is_integer): an integer text exactly, whatever
/// its size, and a whole number written as a decimal below 2^53 as that integer ("8.0" and
/// "8e0" are "8", "1e6" is "1000000", as get_int reads them). Any other text unchanged.
std::string canonical_value(const std::string& text, bool integer);

/// The value of `o` for a result row, as a cost to minimise (accuracy negated); NaN when the
/// row lacks it (a failed point).
double objective_cost(const nlohmann::json& row, Objective o);

/// Which rows are on the Pareto front of `costs` (one vector per row, every entry minimised):
/// no other row is at least as good in every objective and better in one. Rows with a NaN
/// cost are never on the front and dominate nothing; equal rows are both on it.
std::vector<bool> pareto_front(const std::vector<std::vector<double>>& costs);
/// The accuracy floor of the front for these explore rows: spec.min_accuracy, or with auto half
/// the largest software_accuracy among them (0 when none has one: timing-only rows).
double accuracy_floor(const ExploreSpec& spec, const nlohmann::json& rows);

/// The kind of explore's results file (--out): a row per finished point, with its key and
/// status.
JournalKind explore_journal_kind();

/// Why a row of the results file cannot be a point's result ("" when it can): the fields a
/// row of its status has, with their types and ranges (a hand-edited or foreign line is not
/// shown as a result, and the point runs again).
std::string explore_row_problem(const nlohmann::json& row);

}  // namespace xbarsim
