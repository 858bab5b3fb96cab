#include "sw/app/app_common.h"

#include <fstream>

#include "sw/common/errors.h"

namespace xbarsim {

ConfigTree load_config(const CliArgs& args) { return ConfigTree::load(args.get("--config"), args.sets()); }

void write_json(const std::string& path, const nlohmann::json& j) {
  std::ofstream out(path);
  if (!out) throw InputError("cannot write '" + path + "'");
  out << j.dump(2) << "\n";
  if (!out) throw InputError("error while writing '" + path + "'");
}

}  // namespace xbarsim

namespace xbarsim {
std::vector<CommandInfo>& command_registry() {
  static std::vector<CommandInfo> registry;
  return registry;
}
}  // namespace xbarsim
