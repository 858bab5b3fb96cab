/// xbarsim: circuit-accurate simulator for resistive-crossbar CNN accelerators.
#include <cstring>
#include <iostream>
#include <string>

#include "sw/app/app_common.h"
#include "sw/common/errors.h"

namespace {

struct Subcommand {
  const char* name;
  xbarsim::Command run;
  const char* help;
};

const Subcommand kCommands[] = {
    {"solve", xbarsim::cmd_solve,
     "solve --conductances G.csv --inputs V.csv [--out I.csv] [--config FILE] [--set k=v]... [--json F]\n"
     "      column currents of one crossbar (m x n) for each input vector"},
    {"netlist", xbarsim::cmd_netlist,
     "netlist --conductances G.csv --inputs V.csv --out NET.cir [--config FILE] [--set k=v]...\n"
     "      the equivalent SPICE netlist (ngspice -b NET.cir prints the column currents)"},
};

void usage(std::ostream& os) {
  os << "usage: xbarsim <command> [options]\n\ncommands:\n";
  for (const auto& c : kCommands) os << "  " << c.help << "\n";
  os << "\nCommon options: --config FILE (YAML, see configs/default.yaml), --set dotted.key=value\n"
        "(repeatable), --json FILE, --csv FILE.\n";
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2 || !std::strcmp(argv[1], "--help") || !std::strcmp(argv[1], "-h") ||
      !std::strcmp(argv[1], "help")) {
    usage(argc < 2 ? std::cerr : std::cout);
    return argc < 2 ? 2 : 0;
  }
  for (const auto& c : kCommands) {
    if (argv[1] != std::string(c.name)) continue;
    try {
      return c.run(argc - 2, argv + 2);
    } catch (const xbarsim::InputError& e) {
      std::cerr << "xbarsim " << c.name << ": error: " << e.what() << "\n";
      return 2;
    } catch (const xbarsim::SolverError& e) {
      std::cerr << "xbarsim " << c.name << ": solver error: " << e.what() << "\n";
      return 3;
    } catch (const std::exception& e) {
      std::cerr << "xbarsim " << c.name << ": internal error: " << e.what() << "\n";
      return 4;
    }
  }
  std::cerr << "xbarsim: unknown command '" << argv[1] << "'\n\n";
  usage(std::cerr);
  return 2;
}
