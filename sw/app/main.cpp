/// xbarsim: circuit-accurate simulator for resistive-crossbar CNN accelerators.
#include <chrono>
#include <cstring>
#include <iostream>
#include <new>
#include <string>
#include <thread>

#include "sw/app/app_common.h"
#include "sw/common/errors.h"
#include "sw/common/failure.h"
#include "sw/common/ranks.h"

namespace {

bool is_help(const char* arg) { return !std::strcmp(arg, "--help") || !std::strcmp(arg, "-h"); }

/// The whole usage, or one command's (`only`).
void usage(std::ostream& os, const xbarsim::CommandInfo* only = nullptr) {
  os << "usage: xbarsim " << (only ? only->name : "<command>") << " [options]\n\n" << (only ? "" : "commands:\n");
  for (const auto& c : xbarsim::command_registry())
    if (!only || &c == only) os << "  " << c.usage << "\n";
  os << "\nCommon options: --config FILE (YAML; every key is documented in configs/default.yaml),\n"
        "--set dotted.key=value (repeatable), --json FILE, --csv FILE.\n"
        "Under mpirun (when built with MPI), explore, eval and xbar-study share the work among the ranks.\n";
}

const xbarsim::CommandInfo* find_command(const char* name) {
  for (const auto& c : xbarsim::command_registry())
    if (c.name == name) return &c;
  return nullptr;
}

/// Runs one subcommand; its errors become one message and an exit code (Failure).
int run_command(const xbarsim::CommandInfo& c, int argc, char** argv) {
  try {
    if (xbarsim::Ranks::size() > 1 && !c.shards)
      throw xbarsim::InputError(c.name +
                                " does not share its work among MPI ranks (explore, eval and xbar-study do): "
                                "run it without mpirun, or with one rank");
    return c.run(argc - 2, argv + 2);
  } catch (const std::exception&) {
    const xbarsim::Failure f = xbarsim::current_failure();
    if (xbarsim::Ranks::size() > 1 && !xbarsim::Ranks::root()) {
      // Most errors (configuration, files) happen on every rank alike: rank 0 reports them and
      // ends the job, so the other ranks wait a moment before they speak, and print only an
      // error of their own (one that rank 0 did not have), with their rank.
      std::this_thread::sleep_for(std::chrono::seconds(3));
      std::cerr << "xbarsim " << c.name << " [rank " << xbarsim::Ranks::rank() << "]: " << f.text() << std::endl;
    } else {
      std::cerr << "xbarsim " << c.name << ": " << f.text() << std::endl;
    }
    return f.exit_code();
  }
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2 || is_help(argv[1]) || !std::strcmp(argv[1], "help")) {
    // xbarsim help CMD: that command's usage.
    const xbarsim::CommandInfo* c = argc > 2 ? find_command(argv[2]) : nullptr;
    if (argc > 2 && !c) {
      std::cerr << "xbarsim: unknown command '" << argv[2] << "'\n\n";
      usage(std::cerr);
      return 2;
    }
    usage(argc < 2 ? std::cerr : std::cout, c);
    return argc < 2 ? 2 : 0;
  }
  // xbarsim CMD [...] --help: as an option, not as the value of one (--json -h writes to "-h").
  if (const xbarsim::CommandInfo* c = find_command(argv[1]))
    for (int i = 2; i < argc; ++i)
      if (is_help(argv[i]) && (i == 2 || std::strncmp(argv[i - 1], "--", 2) != 0)) {
        usage(std::cout, c);
        return 0;
      }
  try {
    xbarsim::Ranks::init(&argc, &argv);
  } catch (const xbarsim::InputError& e) {
    std::cerr << "xbarsim: error: " << e.what() << "\n";
    return 2;
  }
  if (const xbarsim::CommandInfo* c = find_command(argv[1])) {
    const int code = run_command(*c, argc, argv);
    // One rank's error ends the whole MPI job, so the other ranks never wait for it.
    if (code != 0 && xbarsim::Ranks::size() > 1) xbarsim::Ranks::abort(code);
    xbarsim::Ranks::finalize();
    return code;
  }
  xbarsim::Ranks::finalize();
  std::cerr << "xbarsim: unknown command '" << argv[1] << "'\n\n";
  usage(std::cerr);
  return 2;
}
