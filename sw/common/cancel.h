#pragma once
/// Cooperative cancellation of long computations (solving, programming, forward passes),
/// independent of who asks for it (the Python binding turns Ctrl-C into a stop; the CLI installs
/// nothing).
///
/// A caller installs a CancelScope on its thread with a check function. The long loops call
/// check_cancel() between blocks, rows, vectors and batches: a thread-local load and a branch
/// when no scope is installed; with one, the installing (owner) thread calls the check at most
/// once per interval (a clock read otherwise), and any thread throws Cancelled once a check has
/// asked to stop. parallel_for carries the scope to its worker threads and keeps checking on the
/// owner thread while it waits for them. Cancelled derives from neither InputError nor
/// SolverError, so it passes every context-adding rethrow unchanged; what was being built when it
/// is thrown (a programmed layer, a cached matrix) is discarded, never half kept.
#include <atomic>
#include <chrono>
#include <functional>
#include <stdexcept>
#include <thread>

namespace xbarsim {

/// Thrown by check_cancel() once the installed scope's check asked to stop.
struct Cancelled : std::runtime_error {
  Cancelled() : std::runtime_error("cancelled") {}
};

class CancelScope {
 public:
  /// Returns true to stop. Called only on the thread that constructs the scope.
  using Check = std::function<bool()>;
  /// Installs itself as the current thread's scope (until destroyed; scopes nest).
  explicit CancelScope(Check check, std::chrono::milliseconds interval = std::chrono::milliseconds(100));
  ~CancelScope();
  CancelScope(const CancelScope&) = delete;
  CancelScope& operator=(const CancelScope&) = delete;

  /// The scope installed on this thread (or adopted by it), nullptr when none.
  static CancelScope* current() { return current_ref(); }
  /// Throws Cancelled when a stop was asked; on the owner thread, calls the check when due.
  void poll() {
    if (stop_.load(std::memory_order_relaxed)) throw Cancelled();
    if (std::this_thread::get_id() == owner_) poll_owner();
  }
  bool owned_here() const { return std::this_thread::get_id() == owner_; }
  std::chrono::milliseconds interval() const { return interval_; }
  bool stop_requested() const { return stop_.load(std::memory_order_relaxed); }

  /// Makes `scope` the current one of a worker thread for its lifetime (restoring the previous).
  class Adopt {
   public:
    explicit Adopt(CancelScope* scope) : previous_(current_ref()) { current_ref() = scope; }
    ~Adopt() { current_ref() = previous_; }
    Adopt(const Adopt&) = delete;
    Adopt& operator=(const Adopt&) = delete;

   private:
    CancelScope* previous_;
  };

 private:
  static CancelScope*& current_ref();
  void poll_owner();

  Check check_;
  std::chrono::milliseconds interval_;
  std::chrono::steady_clock::time_point next_;
  std::thread::id owner_;
  std::atomic<bool> stop_{false};
  CancelScope* previous_;
};

/// Throws Cancelled when the current thread's scope asked to stop (see CancelScope).
inline void check_cancel() {
  if (CancelScope* s = CancelScope::current()) s->poll();
}

}  // namespace xbarsim
