#pragma once
/// What kind of failure an exception is, decided in one place: main's exit codes, a child
/// process's report to its parent and explore's failed rows all classify the same way.
#include <exception>
#include <new>
#include <string>

#include "sw/common/errors.h"

namespace xbarsim {

struct Failure {
  enum class Kind { Input, Solver, OutOfMemory, Internal } kind;
  std::string message;  ///< the exception's text (empty for out of memory: each caller words it)
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
