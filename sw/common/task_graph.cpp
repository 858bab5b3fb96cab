#include "sw/common/task_graph.h"

#include <algorithm>

namespace xbarsim {

bool& on_worker_thread() {
  thread_local bool flag = false;
  return flag;
}

TaskGraph::TaskGraph(int workers) {
  const int n = std::max(1, workers);
  threads_.reserve(static_cast<size_t>(n));
  for (int w = 0; w < n; ++w) threads_.emplace_back([this, w] { work(w); });
}

TaskGraph::~TaskGraph() {
  {
    std::lock_guard<std::mutex> lock(mu_);
    stop_ = true;
  }
  ready_cv_.notify_all();
  for (std::thread& t : threads_) t.join();
}

TaskGraph::Id TaskGraph::submit(Task task, const std::vector<Id>& after) {
  std::lock_guard<std::mutex> lock(mu_);
  const Id id = next_++;
  Node& node = nodes_[id];
  node.task = std::move(task);
  for (Id d : after) {
    auto it = d >= 0 ? nodes_.find(d) : nodes_.end();
    if (it == nodes_.end() || d == id) continue;  // finished (or not a task)
    it->second.dependents.push_back(id);
    ++node.waiting;
  }
  if (node.waiting == 0) {
    ready_.push(id);
    ready_cv_.notify_one();
  }
  return id;
}

bool TaskGraph::finished(Id id) const {
  std::lock_guard<std::mutex> lock(mu_);
  return id < next_ && nodes_.find(id) == nodes_.end();
}

void TaskGraph::wait(Id id) {
  std::unique_lock<std::mutex> lock(mu_);
  done_cv_.wait(lock, [&] { return id >= next_ || nodes_.find(id) == nodes_.end(); });
  rethrow_locked();
}

void TaskGraph::wait_all() {
  std::unique_lock<std::mutex> lock(mu_);
  done_cv_.wait(lock, [&] { return nodes_.empty(); });
  rethrow_locked();
}

void TaskGraph::rethrow_locked() const {
  if (failure_) std::rethrow_exception(failure_);
}

void TaskGraph::finish_locked(Id id) {
  auto it = nodes_.find(id);
  for (Id d : it->second.dependents) {
    Node& dep = nodes_.at(d);
    if (--dep.waiting == 0) {
      ready_.push(d);
      ready_cv_.notify_one();
    }
  }
  nodes_.erase(it);
  done_cv_.notify_all();
}

void TaskGraph::work(int worker) {
  on_worker_thread() = true;
  std::unique_lock<std::mutex> lock(mu_);
  for (;;) {
    ready_cv_.wait(lock, [&] { return stop_ || !ready_.empty(); });
    if (stop_) return;
    const Id id = ready_.top();
    ready_.pop();
    Task task = std::move(nodes_.at(id).task);
    // After a failure only older tasks still run: none of the later ones can fail first.
    const bool skip = failed_id_ >= 0 && id > failed_id_;
    if (!skip) {
      lock.unlock();
      std::exception_ptr error;
      try {
        task(worker);
      } catch (...) {
        error = std::current_exception();
      }
      task = nullptr;  // its captures are released outside the lock
      lock.lock();
      if (error && (failed_id_ < 0 || id < failed_id_)) {
        failed_id_ = id;
        failure_ = error;
      }
    }
    finish_locked(id);
  }
}

}  // namespace xbarsim
