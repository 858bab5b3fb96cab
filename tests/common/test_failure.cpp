// One rendering of failures (sw/common/failure.h): main's exit code and message, a child
// process's report and explore's failed rows all classify through Failure, so each kind must
// survive the trip through a child's report and keep its exit code and wording.
#include <gtest/gtest.h>

#include <new>
#include <functional>
#include <stdexcept>
#include <vector>

#include "sw/common/failure.h"

using namespace xbarsim;

namespace {
Failure failure_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const std::exception&) {
    return current_failure();
  }
  ADD_FAILURE() << "nothing thrown";
  return {};
}
}  // namespace

TEST(Failure, EveryKindHasItsExitCodeWordingAndSurvivesAChildsReport) {
  struct Case {
    std::function<void()> raise;
    Failure::Kind kind;
    int code;
    const char* text;
  };
  const std::vector<Case> cases = {
      {[] { throw InputError("bad key"); }, Failure::Kind::Input, 2, "error: bad key"},
      {[] { throw SolverError("no convergence"); }, Failure::Kind::Solver, 3, "solver error: no convergence"},
      {[] { throw std::bad_alloc(); }, Failure::Kind::OutOfMemory, 2, "error: out of memory: the problem does not fit"},
      {[] { throw std::logic_error("a bug"); }, Failure::Kind::Internal, 4, "internal error: a bug"},
  };
  for (const Case& c : cases) {
    const Failure f = failure_of(c.raise);
    EXPECT_EQ(f.kind, c.kind);
    EXPECT_EQ(f.exit_code(), c.code);
    EXPECT_EQ(f.text().rfind(c.text, 0), 0u) << f.text();
    // Through a child process's report ({"kind": name, "error": message}) and back.
    const Failure back = Failure::from_kind_name(f.kind_name(), f.message);
    EXPECT_EQ(back.kind, f.kind) << f.kind_name();
    const Failure again = failure_of([&] { back.rethrow(); });
    EXPECT_EQ(again.kind, f.kind);
    EXPECT_EQ(again.message, f.message);
  }
  // An explore row's reason: an input error is its message alone.
  EXPECT_EQ(failure_of(cases[0].raise).reason(), "bad key");
  EXPECT_EQ(failure_of(cases[1].raise).reason(), "solver error: no convergence");
  EXPECT_EQ(Failure::from_kind_name("no such kind", "x").kind, Failure::Kind::Internal);
}
