#pragma once
/// Helpers shared by the xbarsim subcommands, and the subcommand registry.
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "sw/common/cli_args.h"
#include "sw/common/config.h"

namespace xbarsim {

/// Configuration from --config (optional) and the --set overrides.
ConfigTree load_config(const CliArgs& args);

/// Writes a JSON report (pretty-printed) to `path`; throws InputError if it cannot.
void write_json(const std::string& path, const nlohmann::json& j);

/// Sweeps: every combination (cartesian product) of the values of the keys given as lists;
/// one empty combination when nothing sweeps.
std::vector<std::vector<std::pair<std::string, std::string>>> sweep_combinations(const ConfigTree& cfg);

/// Short label "key=value ..." of a combination (last key component only), or "default".
std::string sweep_label(const std::vector<std::pair<std::string, std::string>>& combo);

/// A progress bar on stderr, drawn only when stderr is a terminal; rate-limited.
class ProgressBar {
 public:
  ProgressBar(int total, std::string label);
  ~ProgressBar();
  void update(int done);
  void finish();

 private:
  int total_;
  std::string label_;
  bool tty_;
  double start_, last_ = -1;
  bool finished_ = false;
};

/// A subcommand entry point: receives the arguments after the subcommand name.
using CommandFn = int (*)(int argc, char** argv);

struct CommandInfo {
  std::string name;
  CommandFn run;
  std::string usage;  ///< one-line synopsis plus a short description
};

/// All registered subcommands, sorted by registration order.
std::vector<CommandInfo>& command_registry();

/// Registers a subcommand at static-initialisation time. Use in the command's .cpp
/// (compiled into the xbarsim executable): `static CommandRegistrar reg{"name", fn, "usage"};`
struct CommandRegistrar {
  CommandRegistrar(const char* name, CommandFn fn, const char* usage) {
    command_registry().push_back({name, fn, usage});
  }
};

}  // namespace xbarsim
