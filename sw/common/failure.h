#pragma once
/// What kind of failure an exception is, and how it is rendered, decided in one place: main's
/// message and exit code, a child process's report to its parent (run_in_child) and explore's
/// failed rows all go through Failure, so they classify and word a failure the same way.
#include <exception>
#include <new>
#include <stdexcept>
#include <string>

#include "sw/common/errors.h"

namespace xbarsim {

struct Failure {
  enum class Kind { Input, Solver, OutOfMemory, Internal };
  Kind kind = Kind::Internal;
  std::string message;  ///< the exception's text (empty for out of memory)

  /// The process exit code: 2 input (and a problem too large for the memory), 3 solver, 4 internal.
  int exit_code() const {
    switch (kind) {
      case Kind::Input:
      case Kind::OutOfMemory:
        return 2;
      case Kind::Solver:
        return 3;
      case Kind::Internal:
        return 4;
    }
    return 4;
  }
  /// One line for the user: "error: ...", "solver error: ...", "error: out of memory: ...",
  /// "internal error: ...".
  std::string text() const {
    switch (kind) {
      case Kind::Input:
        return "error: " + message;
      case Kind::Solver:
        return "solver error: " + message;
      case Kind::OutOfMemory:
        return "error: out of memory: the problem does not fit in this machine's memory (use smaller crossbars, "
               "fewer vectors or images, or fewer sweep points)";
      case Kind::Internal:
        return "internal error: " + message;
    }
    return "internal error: " + message;
  }
  /// The same without "error: " for input errors (a failed explore row's reason).
  std::string reason() const { return kind == Kind::Input ? message : text(); }

  /// The kind's name in a child process's report ("input", "solver", "out_of_memory", "internal").
  std::string kind_name() const {
    switch (kind) {
      case Kind::Input:
        return "input";
      case Kind::Solver:
        return "solver";
      case Kind::OutOfMemory:
        return "out_of_memory";
      case Kind::Internal:
        return "internal";
    }
    return "internal";
  }
  /// The failure kind_name() names (Internal for a name it does not know).
  static Failure from_kind_name(const std::string& name, std::string message) {
    for (Kind k : {Kind::Input, Kind::Solver, Kind::OutOfMemory, Kind::Internal})
      if (Failure{k, ""}.kind_name() == name) return {k, std::move(message)};
    return {Kind::Internal, std::move(message)};
  }
  /// Throws the exception this failure was made from (its kind and message), e.g. a child
  /// process's failure in the parent.
  [[noreturn]] void rethrow() const {
    switch (kind) {
      case Kind::Input:
        throw InputError(message);
      case Kind::Solver:
        throw SolverError(message);
      case Kind::OutOfMemory:
        throw std::bad_alloc();
      case Kind::Internal:
        throw std::runtime_error(message);
    }
    throw std::runtime_error(message);
  }
};

/// Classifies the exception in flight; call it only inside a catch block.
inline Failure current_failure() {
  try {
    throw;
  } catch (const InputError& e) {
    return {Failure::Kind::Input, e.what()};
  } catch (const SolverError& e) {
    return {Failure::Kind::Solver, e.what()};
  } catch (const std::bad_alloc&) {
    return {Failure::Kind::OutOfMemory, ""};
  } catch (const std::exception& e) {
    return {Failure::Kind::Internal, e.what()};
  }
}

}  // namespace xbarsim
