#pragma once
// Shared helpers for the libFuzzer harnesses: one fixed temp path per process and harness,
// so a long run does not litter /tmp, and the file is rewritten for every input.
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

/// A broken invariant of a reader's result: says which one on stderr, then aborts, which
/// libFuzzer records as a crash.
#define XBARSIM_FUZZ_CHECK(cond)                                                          \
  do {                                                                                    \
    if (!(cond)) {                                                                        \
      std::fprintf(stderr, "%s:%d: invariant violated: %s\n", __FILE__, __LINE__, #cond); \
      std::abort();                                                                       \
    }                                                                                     \
  } while (0)

namespace xbarsim_fuzz {

/// "/tmp/xbarsim_fuzz_<tag>_<pid>" (computed once per process and tag).
inline std::string temp_path(const char* tag) {
  return "/tmp/xbarsim_fuzz_" + std::string(tag) + "_" + std::to_string(static_cast<long>(getpid()));
}

/// Writes exactly `size` bytes to `path`; aborts on I/O failure (an infrastructure problem,
/// not a finding in xbarsim).
inline void write_file(const std::string& path, const uint8_t* data, size_t size) {
  FILE* f = std::fopen(path.c_str(), "wb");
  if (!f) {
    std::perror(path.c_str());
    std::abort();
  }
  if (size && std::fwrite(data, 1, size, f) != size) {
    std::perror(path.c_str());
    std::abort();
  }
  std::fclose(f);
}

}  // namespace xbarsim_fuzz
