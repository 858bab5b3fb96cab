#pragma once
#include <stdexcept>
#include <string>

namespace xbarsim {

/// Bad user input: configuration, files, command line. The message is shown as is.
class InputError : public std::runtime_error {
 public:
  explicit InputError(const std::string& what) : std::runtime_error(what) {}
};

/// A numerical method failed (e.g. Newton-Raphson did not converge). Never swallowed.
class SolverError : public std::runtime_error {
 public:
  explicit SolverError(const std::string& what) : std::runtime_error(what) {}
};

}  // namespace xbarsim
