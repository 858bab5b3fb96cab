/// xbarsim: circuit-accurate simulator for resistive-crossbar CNN accelerators.
#include <cstring>
#include <iostream>
#include <new>
#include <string>

#include "sw/app/app_common.h"
#include "sw/common/errors.h"

namespace {

void usage(std::ostream& os) {
  os << "usage: xbarsim <command> [options]\n\ncommands:\n";
  for (const auto& c : xbarsim::command_registry()) os << "  " << c.usage << "\n";
  os << "\nCommon options: --config FILE (YAML; every key is documented in configs/default.yaml),\n"
        "--set dotted.key=value (repeatable), --json FILE, --csv FILE.\n";
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2 || !std::strcmp(argv[1], "--help") || !std::strcmp(argv[1], "-h") || !std::strcmp(argv[1], "help")) {
    usage(argc < 2 ? std::cerr : std::cout);
    return argc < 2 ? 2 : 0;
  }
  for (const auto& c : xbarsim::command_registry()) {
    if (c.name != argv[1]) continue;
    try {
      return c.run(argc - 2, argv + 2);
    } catch (const xbarsim::InputError& e) {
      std::cerr << "xbarsim " << c.name << ": error: " << e.what() << "\n";
      return 2;
    } catch (const xbarsim::SolverError& e) {
      std::cerr << "xbarsim " << c.name << ": solver error: " << e.what() << "\n";
      return 3;
    } catch (const std::bad_alloc&) {
      std::cerr << "xbarsim " << c.name
                << ": error: out of memory: the requested problem does not fit in this machine's memory "
                   "(use smaller crossbars, fewer vectors or images, or fewer sweep points)\n";
      return 2;
    } catch (const std::exception& e) {
      std::cerr << "xbarsim " << c.name << ": internal error: " << e.what() << "\n";
      return 4;
    }
  }
  std::cerr << "xbarsim: unknown command '" << argv[1] << "'\n\n";
  usage(std::cerr);
  return 2;
}
