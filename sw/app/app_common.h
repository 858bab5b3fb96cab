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
