#pragma once
// Running the built xbarsim from a test: exit status and everything it printed.
#include <sys/stat.h>
#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <cstdlib>
#include <string>

namespace xbarsim_test {

struct Result {
  int code;  ///< exit status, or -1 when killed by a signal
  std::string out;
};

/// Runs `xbarsim args` (after the shell text `prefix`, e.g. a ulimit), stderr merged.
inline Result run_xbarsim(const std::string& args, const std::string& prefix = "") {
  const std::string cmd = prefix + std::string(XBARSIM_BINARY) + " " + args + " 2>&1";
  std::string out;
  FILE* p = popen(cmd.c_str(), "r");
  std::array<char, 4096> buf;
  while (fgets(buf.data(), buf.size(), p)) out += buf.data();
  const int st = pclose(p);
  return {WIFEXITED(st) ? WEXITSTATUS(st) : -1, out};
}

/// Whether the shared data directory ($XBARSIM_DATA_DIR, or ../shared/data) exists; tests
/// that need it skip otherwise.
inline bool have_data() {
  struct stat st;
  const char* env = std::getenv("XBARSIM_DATA_DIR");
  return stat(env ? env : "../shared/data", &st) == 0 ||
         stat((std::string(XBARSIM_SOURCE_DIR) + "/../shared/data").c_str(), &st) == 0;
}

}  // namespace xbarsim_test
