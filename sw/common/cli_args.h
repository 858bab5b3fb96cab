#pragma once
/// Minimal command-line parser shared by all subcommands: `--flag value`, `--flag=value`,
/// boolean switches, and the repeatable `--set key=value`.
#include <map>
#include <set>
#include <string>
#include <vector>

namespace xbarsim {

class CliArgs {
 public:
  /// Parses argv[first..argc). `value_flags` take one value; `switches` take none.
  /// `--set`, `--config`, `--json`, `--csv` are always accepted. Unknown flags, and a flag given
  /// twice (which of the two would count?), throw InputError; `--set` repeats.
  CliArgs(int argc, char** argv, int first, const std::set<std::string>& value_flags,
          const std::set<std::string>& switches = {});

  bool has(const std::string& flag) const;
  std::string get(const std::string& flag, const std::string& fallback = "") const;
  /// Throws InputError "missing required option --flag".
  std::string require(const std::string& flag) const;
  const std::vector<std::string>& sets() const { return sets_; }
  /// Every flag given with a value (flag -> value).
  const std::map<std::string, std::string>& values() const { return values_; }

 private:
  std::map<std::string, std::string> values_;
  std::vector<std::string> sets_;
};

}  // namespace xbarsim
