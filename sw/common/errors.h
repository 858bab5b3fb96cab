#pragma once
#include <exception>
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

/// `text` for a message: at most `max_chars` characters, the rest replaced by "... (N
/// characters)" (a 100 MB value is not echoed whole).
inline std::string excerpt(const std::string& text, size_t max_chars = 60) {
  if (text.size() <= max_chars) return text;
  return text.substr(0, max_chars) + "... (" + std::to_string(text.size()) + " characters)";
}

/// Rethrows the InputError or SolverError in flight with `context` before its message ("layer
/// conv1: crossbar 2 of 4 ...: input vector 1: ..."), keeping its kind; any other exception
/// unchanged. Call it only inside a catch block.
[[noreturn]] inline void rethrow_with_context(const std::string& context) {
  try {
    throw;
  } catch (const SolverError& e) {
    throw SolverError(context + ": " + e.what());
  } catch (const InputError& e) {
    throw InputError(context + ": " + e.what());
  }
}

/// The exception in flight with `context` added as rethrow_with_context adds it, kept for later
/// (a worker thread's failure, rethrown once the work is joined). Call it only inside a catch block.
inline std::exception_ptr current_exception_with_context(const std::string& context) {
  try {
    rethrow_with_context(context);
  } catch (...) {
    return std::current_exception();
  }
}

}  // namespace xbarsim
