#pragma once
#include <gtest/gtest.h>

#include <string>

#include "sw/common/config.h"
#include "sw/nn/dataset.h"

/// The shared data directory, or "" (the test then skips with a message).
inline std::string shared_data_dir() {
  try {
    return xbarsim::resolve_data_dir(xbarsim::ConfigTree());
  } catch (const xbarsim::InputError&) {
    return "";
  }
}

#define REQUIRE_SHARED_DATA(dir)                                              \
  const std::string dir = shared_data_dir();                                  \
  if (dir.empty())                                                            \
  GTEST_SKIP() << "shared data directory not found (set XBARSIM_DATA_DIR or " \
                  "place ../shared/data beside the repository); test skipped"
