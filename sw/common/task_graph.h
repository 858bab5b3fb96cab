#pragma once
/// A pool of worker threads that runs tasks in dependency order: a task runs once every task
/// it was submitted after (its dependencies) has finished; among the ready ones the oldest runs
/// first. Used where one thread decides what is computed and when (a simulation's processes)
/// and the computation itself can proceed on other cores, e.g. the values of the layers of
/// several images in flight. Results do not depend on the workers: a task gets only its
/// inputs and the worker's index (for per-worker scratch), never a shared random stream.
///
/// A task that throws fails the graph: tasks submitted after it are skipped, earlier ones still
/// run, and wait()/wait_all() rethrow the failure of the lowest-numbered failed task (the same
/// failure whatever the number of workers).
#include <condition_variable>
#include <exception>
#include <functional>
#include <mutex>
#include <queue>
#include <thread>
#include <unordered_map>
#include <vector>

namespace xbarsim {

class TaskGraph {
 public:
  using Id = long long;
  using Task = std::function<void(int worker)>;

  /// `workers` threads (at least 1), started now.
  explicit TaskGraph(int workers);
  /// Skips the tasks not yet started and joins the workers.
  ~TaskGraph();
  TaskGraph(const TaskGraph&) = delete;
  TaskGraph& operator=(const TaskGraph&) = delete;

  /// Adds a task that runs after the tasks `after` (ids from earlier submit() calls; negative
  /// ids and finished tasks are ignored). Returns its id (0, 1, 2, ... in submission order).
  Id submit(Task task, const std::vector<Id>& after = {});
  /// Whether task `id` has finished (run, skipped or failed).
  bool finished(Id id) const;
  /// Blocks until task `id` has finished; rethrows the graph's failure, if any.
  void wait(Id id);
  /// Blocks until every submitted task has finished; rethrows the graph's failure, if any.
  void wait_all();
  int workers() const { return static_cast<int>(threads_.size()); }

 private:
  struct Node {
    Task task;
    int waiting = 0;  ///< unfinished dependencies
    std::vector<Id> dependents;
  };
  void work(int worker);
  void finish_locked(Id id);
  void rethrow_locked() const;

  mutable std::mutex mu_;
  std::condition_variable ready_cv_, done_cv_;
  std::unordered_map<Id, Node> nodes_;  ///< submitted, not finished
  std::priority_queue<Id, std::vector<Id>, std::greater<Id>> ready_;
  Id next_ = 0;
  Id failed_id_ = -1;
  std::exception_ptr failure_;
  bool stop_ = false;
  std::vector<std::thread> threads_;
};

/// True on a thread that already shares the cores with others (a parallel_for or TaskGraph
/// worker): nested parallel loops run inline there instead of starting more threads.
bool& on_worker_thread();

}  // namespace xbarsim
