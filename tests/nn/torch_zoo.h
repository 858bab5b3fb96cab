#pragma once
// torchvision topologies exported by the tests themselves (tests/nn/torch_zoo.py with Debian's
// python3-torch and python3-torchvision); tests skip with a message where these are absent.
#include <cstdlib>
#include <string>

namespace xbarsim_test {

/// The Python that has torch and torchvision (Debian's, not a user's virtual environment); ""
/// when there is none.
inline std::string torch_python() {
  for (const char* py : {"/usr/bin/python3", "python3"}) {
    const std::string cmd = std::string(py) + " -c 'import torch, torchvision' > /dev/null 2>&1";
    if (std::system(cmd.c_str()) == 0) return py;
  }
  return "";
}

/// Exports `names` (space-separated torchvision model names) at `size` x `size` into the
/// directory `dir` (created): NAME.onnx, NAME.input.npy, NAME.logits.npy. False when it failed
/// (its output is in dir/export.log).
inline bool export_zoo(const std::string& py, const std::string& dir, int size, const std::string& names) {
  const std::string cmd = "mkdir -p '" + dir + "' && " + py + " '" + XBARSIM_SOURCE_DIR +
                          "/tests/nn/torch_zoo.py' '" + dir + "' " + std::to_string(size) + " " + names + " > '" +
                          dir + "/export.log' 2>&1";
  return std::system(cmd.c_str()) == 0;
}

}  // namespace xbarsim_test
