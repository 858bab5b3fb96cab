// TaskGraph: dependencies respected, oldest ready task first, failures reported as the
// lowest-numbered failed task whatever the workers, waits that end.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <stdexcept>
#include <thread>
#include <vector>

#include "sw/common/task_graph.h"

namespace xbarsim {
namespace {

TEST(TaskGraph, ChainsRunInDependencyOrderOnAnyNumberOfWorkers) {
  for (int workers : {1, 2, 4}) {
    TaskGraph g(workers);
    // Four independent chains of 50 steps: x_k = 3 x_{k-1} + k (mod 2^31), each step a task
    // after the previous one; the result must equal the serial recurrence.
    constexpr int kChains = 4, kSteps = 50;
    std::vector<long long> x(kChains, 1);
    std::vector<TaskGraph::Id> last(kChains, -1);
    for (int k = 1; k <= kSteps; ++k)
      for (int c = 0; c < kChains; ++c)
        last[c] = g.submit([&x, c, k](int) { x[c] = (3 * x[c] + k + c) % 2147483648LL; }, {last[c]});
    g.wait_all();
    for (int c = 0; c < kChains; ++c) {
      long long ref = 1;
      for (int k = 1; k <= kSteps; ++k) ref = (3 * ref + k + c) % 2147483648LL;
      EXPECT_EQ(x[c], ref) << workers << " workers, chain " << c;
    }
  }
}

TEST(TaskGraph, AJoinWaitsForBothBranches) {
  TaskGraph g(2);
  std::atomic<int> a{0}, b{0};
  int seen = -1;
  const auto ta = g.submit([&](int) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    a = 1;
  });
  const auto tb = g.submit([&](int) { b = 2; });
  const auto join = g.submit([&](int) { seen = a + b; }, {ta, tb});
  g.wait(join);
  EXPECT_EQ(seen, 3);
  EXPECT_TRUE(g.finished(ta));
  EXPECT_TRUE(g.finished(tb));
}

TEST(TaskGraph, TheLowestFailedTaskIsReportedAndLaterTasksAreSkipped) {
  for (int workers : {1, 2}) {
    TaskGraph g(workers);
    std::atomic<int> ran_after{0};
    // Task 0 blocks until task 2 has failed, so that a worker sees the later failure first.
    std::atomic<bool> later_failed{false};
    const auto t0 = g.submit([&](int) {
      for (int k = 0; k < 200 && workers > 1 && !later_failed; ++k)
        std::this_thread::sleep_for(std::chrono::milliseconds(1));
      throw std::runtime_error("first");
    });
    g.submit([](int) {});
    g.submit([&](int) {
      later_failed = true;
      throw std::runtime_error("second");
    });
    const auto dependent = g.submit([&](int) { ++ran_after; }, {t0});
    try {
      g.wait_all();
      FAIL() << "no failure reported";
    } catch (const std::runtime_error& e) {
      EXPECT_STREQ(e.what(), "first") << workers << " workers";
    }
    EXPECT_TRUE(g.finished(dependent));
    EXPECT_EQ(ran_after, 0);
  }
}

TEST(TaskGraph, WorkersRunNestedLoopsInline) {
  TaskGraph g(2);
  bool on_worker = false;
  g.wait(g.submit([&](int) { on_worker = on_worker_thread(); }));
  EXPECT_TRUE(on_worker);
  EXPECT_FALSE(on_worker_thread());
}

TEST(TaskGraph, DestroyingWithPendingTasksEnds) {
  std::atomic<int> ran{0};
  {
    TaskGraph g(1);
    TaskGraph::Id prev = -1;
    for (int k = 0; k < 1000; ++k)
      prev = g.submit(
          [&](int) {
            ++ran;
            std::this_thread::sleep_for(std::chrono::microseconds(100));
          },
          {prev});
  }
  EXPECT_LT(ran.load(), 1000);
}

}  // namespace
}  // namespace xbarsim
