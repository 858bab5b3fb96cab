#pragma once
/// SystemC elaborates once per process, so a test executable runs one simulating case per
/// process (ctest runs each case alone); a second case in the same process skips, saying why.
#include <gtest/gtest.h>

namespace xbarsim_test {
inline bool& elaborated() {
  static bool done = false;
  return done;
}
}  // namespace xbarsim_test

#define ONE_SIMULATION_PER_PROCESS()                                                                           \
  if (xbarsim_test::elaborated()) GTEST_SKIP() << "SystemC elaborates once per process; ctest runs each case alone"; \
  xbarsim_test::elaborated() = true
