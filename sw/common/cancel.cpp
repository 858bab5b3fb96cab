#include "sw/common/cancel.h"

namespace xbarsim {

CancelScope*& CancelScope::current_ref() {
  thread_local CancelScope* scope = nullptr;
  return scope;
}

CancelScope::CancelScope(Check check, std::chrono::milliseconds interval)
    : check_(std::move(check)),
      interval_(interval),
      next_(std::chrono::steady_clock::now() + interval),
      owner_(std::this_thread::get_id()),
      previous_(current_ref()) {
  current_ref() = this;
}

CancelScope::~CancelScope() { current_ref() = previous_; }

void CancelScope::poll_owner() {
  const auto now = std::chrono::steady_clock::now();
  if (now < next_) return;
  const bool stop = check_ && check_();
  next_ = std::chrono::steady_clock::now() + interval_;
  if (stop) {
    stop_.store(true, std::memory_order_relaxed);
    throw Cancelled();
  }
}

}  // namespace xbarsim
