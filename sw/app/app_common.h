#pragma once
/// Helpers shared by the xbarsim subcommands.
#include <nlohmann/json.hpp>
#include <string>

#include "sw/common/cli_args.h"
#include "sw/common/config.h"

namespace xbarsim {

/// Configuration from --config (optional) and the --set overrides.
ConfigTree load_config(const CliArgs& args);

/// Writes a JSON report (pretty-printed) to `path`; throws InputError if it cannot.
void write_json(const std::string& path, const nlohmann::json& j);

/// Signature of a subcommand entry point: arguments after the subcommand name.
using Command = int (*)(int argc, char** argv);

int cmd_solve(int argc, char** argv);
int cmd_netlist(int argc, char** argv);

}  // namespace xbarsim
