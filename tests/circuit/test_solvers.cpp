// Line solver vs full-topology nodal solver, effective matrix, error handling.
#include <gtest/gtest.h>

#include <random>

#include "sw/circuit/crossbar_solver.h"
#include "sw/circuit/nodal_solver.h"
#include "sw/common/cancel.h"
#include "tests/circuit/random_crossbar.h"

using namespace xbarsim;
using xbarsim::test::random_g;
using xbarsim::test::random_v;

namespace {
double max_rel(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) {
  return (a - b).cwiseAbs().maxCoeff() / b.cwiseAbs().maxCoeff();
}
}  // namespace

struct DeviceCase {
  MemristorModel mem;
  TransistorModel tr;
  double r_wire;
};

class LineVsDirect : public ::testing::TestWithParam<std::tuple<DeviceCase, std::pair<int, int>>> {};

TEST_P(LineVsDirect, SameOperatingPoint) {
  const auto [dc, size] = GetParam();
  CrossbarParams p;
  p.memristor.model = dc.mem;
  p.transistor.model = dc.tr;
  p.r_wire_ohm = dc.r_wire;
  SolverOptions lo, dop;
  lo.method = SolverMethod::Line;
  dop.method = SolverMethod::Direct;
  const auto g = random_g(size.first, size.second, p, 3 + size.first);
  const auto v = random_v(3, size.first, -0.4, 0.4, 5 + size.second);
  auto line = make_crossbar_solver(p, lo);
  auto direct = make_crossbar_solver(p, dop);
  line->program(g);
  direct->program(g);
  const double tol = p.is_linear() ? 1e-10 : 1e-9;
  for (int k = 0; k < v.rows(); ++k) {
    const auto a = line->solve(v.row(k).transpose());
    const auto b = direct->solve(v.row(k).transpose());
    EXPECT_LT(max_rel(a.column_current, b.column_current), tol);
    EXPECT_LT((a.v_top - b.v_top).cwiseAbs().maxCoeff(), 1e-11);
    EXPECT_LT((a.v_mid - b.v_mid).cwiseAbs().maxCoeff(), 1e-11);
    EXPECT_LT((a.v_bottom - b.v_bottom).cwiseAbs().maxCoeff(), 1e-11);
    EXPECT_LT(max_rel(a.cell_current, b.cell_current), tol);
  }
}

INSTANTIATE_TEST_SUITE_P(
    Devices, LineVsDirect,
    ::testing::Combine(::testing::Values(DeviceCase{MemristorModel::Linear, TransistorModel::None, 1.0},
                                         DeviceCase{MemristorModel::Linear, TransistorModel::Linear, 1.0},
                                         DeviceCase{MemristorModel::Linear, TransistorModel::None, 25.0},
                                         DeviceCase{MemristorModel::Sinh, TransistorModel::None, 1.0},
                                         DeviceCase{MemristorModel::Linear, TransistorModel::Level1, 1.0},
                                         DeviceCase{MemristorModel::Sinh, TransistorModel::Level1, 5.0}),
                       ::testing::Values(std::make_pair(1, 1), std::make_pair(1, 9), std::make_pair(12, 1),
                                         std::make_pair(17, 6), std::make_pair(5, 23), std::make_pair(40, 40))),
    [](const auto& info) {
      const DeviceCase& d = std::get<0>(info.param);
      const auto sz = std::get<1>(info.param);
      std::string name = std::string(to_string(d.mem)) + "_" + to_string(d.tr) + "_rwire" +
                         std::to_string(static_cast<int>(d.r_wire)) + "_" + std::to_string(sz.first) + "x" +
                         std::to_string(sz.second);
      return name;
    });

// The paper's largest crossbar: the fast path must agree with the full-topology direct
// solve to 1e-9 relative (linear and nonlinear), and so must its G_eff.
TEST(LineVsDirect, PaperLargestCrossbar576x64) {
  for (bool nonlinear : {false, true}) {
    CrossbarParams p;
    if (nonlinear) {
      p.memristor.model = MemristorModel::Sinh;
      p.transistor.model = TransistorModel::Level1;
    }
    SolverOptions lo, dop;
    lo.method = SolverMethod::Line;
    dop.method = SolverMethod::Direct;
    const auto g = random_g(576, 64, p, 21);
    const auto v = random_v(1, 576, 0, 0.4, 22);
    auto line = make_crossbar_solver(p, lo);
    auto direct = make_crossbar_solver(p, dop);
    line->program(g);
    direct->program(g);
    const Eigen::VectorXd a = line->solve(v.row(0).transpose()).column_current;
    const Eigen::VectorXd b = direct->solve(v.row(0).transpose()).column_current;
    EXPECT_LT(max_rel(a, b), 1e-9) << (nonlinear ? "nonlinear" : "linear");
    if (!nonlinear) {
      const Eigen::MatrixXd geff = line->effective_matrix();
      EXPECT_LT(max_rel((v * geff).transpose(), b), 1e-9);
    }
  }
}

TEST(NodalSolver, UnknownCountIsTheTopology) {
  CrossbarParams p;
  p.transistor.model = TransistorModel::Linear;
  SolverOptions o;
  NodalSolver s(p, o);
  s.program(random_g(6, 4, p, 1));
  EXPECT_EQ(s.unknowns(), 3 * 6 * 4 + 2 * 6 + 2 * 4);
}

TEST(EffectiveMatrix, ReproducesSolvesBySuperposition) {
  for (auto size : {std::make_pair(30, 8), std::make_pair(8, 30)}) {
    CrossbarParams p;
    p.transistor.model = TransistorModel::Linear;
    SolverOptions o;
    o.method = SolverMethod::Line;
    const auto g = random_g(size.first, size.second, p, 9);
    auto s = make_crossbar_solver(p, o);
    s->program(g);
    const Eigen::MatrixXd geff = s->effective_matrix();
    SolverOptions d;
    d.method = SolverMethod::Direct;
    auto ref = make_crossbar_solver(p, d);
    ref->program(g);
    EXPECT_LT(max_rel(geff, ref->effective_matrix()), 1e-10);
    const auto v = random_v(4, size.first, 0, 0.4, 2);
    for (int k = 0; k < v.rows(); ++k) {
      const Eigen::VectorXd direct = ref->solve(v.row(k).transpose()).column_current;
      const Eigen::VectorXd via_geff = (v.row(k) * geff).transpose();
      EXPECT_LT(max_rel(via_geff, direct), 1e-10);
    }
    // Batched path (uses G_eff for large batches) agrees with per-vector solves.
    const auto vb = random_v(50, size.first, 0, 0.4, 4);
    EXPECT_LT(max_rel(s->column_currents(vb), vb * ref->effective_matrix()), 1e-10);
  }
}

TEST(EffectiveMatrix, RejectedForNonlinearDevices) {
  CrossbarParams p;
  p.memristor.model = MemristorModel::Sinh;
  auto s = make_crossbar_solver(p, SolverOptions{});
  s->program(random_g(3, 3, p, 1));
  EXPECT_THROW(s->effective_matrix(), SolverError);
}

TEST(Solvers, NewtonNonConvergenceIsAnErrorNotAnAnswer) {
  CrossbarParams p;
  p.memristor.model = MemristorModel::Sinh;
  p.transistor.model = TransistorModel::Level1;
  for (const char* method : {"line", "direct"}) {
    SolverOptions o;
    o.method = solver_method_from_name(method);
    o.newton_max_iterations = 1;
    auto s = make_crossbar_solver(p, o);
    s->program(random_g(4, 4, p, 1));
    try {
      s->solve(Eigen::VectorXd::Constant(4, 0.4));
      FAIL() << method;
    } catch (const SolverError& e) {
      EXPECT_NE(std::string(e.what()).find("did not converge"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("residual"), std::string::npos) << e.what();
    }
  }
}

TEST(Solvers, BadInputsAreRejected) {
  CrossbarParams p;
  for (const char* method : {"line", "direct"}) {
    SolverOptions o;
    o.method = solver_method_from_name(method);
    auto s = make_crossbar_solver(p, o);
    Eigen::MatrixXd g = random_g(3, 2, p, 1);
    g(1, 1) = -1e-6;
    EXPECT_THROW(s->program(g), InputError);
    g(1, 1) = 0;
    EXPECT_THROW(s->program(g), InputError);
    g(1, 1) = std::nan("");
    EXPECT_THROW(s->program(g), InputError);
    g(1, 1) = 1e-5;
    s->program(g);
    EXPECT_THROW(s->solve(Eigen::VectorXd::Zero(2)), InputError);
    EXPECT_THROW(s->column_currents(Eigen::MatrixXd::Zero(2, 2)), InputError);
  }
}

// Cancellation (issue 38, Ctrl-C from Python): a scope whose check asks to stop makes a long
// solve throw Cancelled, on one thread and on several (the owner keeps checking while it waits
// for the workers); a scope that never stops changes no result; without a scope nothing checks.
TEST(Cancellation, StopsSolvesOnOneAndSeveralThreads) {
  CrossbarParams p;
  p.memristor.model = MemristorModel::Sinh;
  const auto g = random_g(32, 16, p, 7);
  const auto v = random_v(400, 32, 0.0, 0.3, 8);
  for (const int threads : {1, 2}) {
    SolverOptions o;
    o.threads = threads;
    auto solver = make_crossbar_solver(p, o);
    solver->program(g);
    const Eigen::MatrixXd want = solver->column_currents(v.topRows(4));
    int checks = 0;
    {
      CancelScope never([&] { return ++checks, false; }, std::chrono::milliseconds(0));
      EXPECT_EQ(solver->column_currents(v.topRows(4)), want) << threads;
    }
    EXPECT_GT(checks, 0) << threads;
    checks = 0;
    {
      CancelScope stop([&] { return ++checks >= 1; }, std::chrono::milliseconds(0));
      EXPECT_THROW(solver->column_currents(v), Cancelled) << threads;
      EXPECT_THROW(check_cancel(), Cancelled);  // stopped for good
    }
    EXPECT_EQ(checks, 1) << threads;
    EXPECT_EQ(solver->column_currents(v.topRows(4)), want) << threads;  // no scope: solves as before
    EXPECT_EQ(CancelScope::current(), nullptr);
  }
}
