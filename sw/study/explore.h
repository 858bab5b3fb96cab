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

/// A decimal number as the shortest text that reads back as the same double ("3.0", "3e0" and
/// "3" are "3"; "0.40" is "0.4"); any other text unchanged.
std::string canonical_value(const std::string& text);

/// The value of `o` for a result row, as a cost to minimise (accuracy negated); NaN when the
/// row lacks it (a failed point).
double objective_cost(const nlohmann::json& row, Objective o);

/// Which rows are on the Pareto front of `costs` (one vector per row, every entry minimised):
/// no other row is at least as good in every objective and better in one. Rows with a NaN
/// cost are never on the front and dominate nothing; equal rows are both on it.
std::vector<bool> pareto_front(const std::vector<std::vector<double>>& costs);

/// The resumable record of an exploration: one JSON object per line, each appended whole
/// under an fcntl lock and flushed to disk as its point finishes, so a killed run loses only
/// the points in flight and several MPI ranks can append to one file.
class ResultJournal {
 public:
  /// Creates the file when it does not exist. Throws InputError when `path` is not a regular
  /// file (a journal is read back and appended to: /dev/null would lose it, /dev/zero never
  /// ends) or cannot be created.
  explicit ResultJournal(std::string path);
  /// Drops a last line cut short by a kill (call on one process, before anyone appends).
  void repair() const;
  /// Every complete line that parses as a JSON object with a "key"; others are counted in
  /// `skipped`.
  std::vector<nlohmann::json> read(int* skipped = nullptr) const;
  /// Appends one row as one line; throws InputError when the file cannot be written.
  void append(const nlohmann::json& row) const { append_lines(row.dump() + "\n"); }
  /// Appends whole lines ("...\n" each) in one write under the lock.
  void append_lines(const std::string& lines) const;
  const std::string& path() const { return path_; }

 private:
  std::string path_;
};

}  // namespace xbarsim
