// The batched inexact Newton (LineSolver::column_currents with nonlinear devices) against the
// per-vector Newton, the reference it must reproduce to solver.nonlinear_tolerance (1e-9).
#include <gtest/gtest.h>

#include <random>

#include "sw/circuit/crossbar_solver.h"
#include "tests/circuit/random_crossbar.h"

using namespace xbarsim;
using xbarsim::test::random_g;

namespace {

struct Case {
  MemristorModel mem;
  TransistorModel tr;
  double k;       ///< sinh nonlinearity, 1/V
  double r_wire;  ///< ohm
  int m, n;
  bool bipolar;
};

/// `count` input vectors, half their entries 0 V, the rest uniform in (0, 0.4] V (with a random
/// sign when bipolar); vector 0 is all zeros and vector 1 has every input at full scale.
Eigen::MatrixXd inputs(int count, int m, bool bipolar, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 0.4);
  std::bernoulli_distribution half(0.5);
  Eigen::MatrixXd v(count, m);
  for (int a = 0; a < count; ++a)
    for (int i = 0; i < m; ++i) {
      double x = a == 0 ? 0.0 : a == 1 ? 0.4 : half(rng) ? 0.0 : u(rng);
      if (bipolar && half(rng)) x = -x;
      v(a, i) = x;
    }
  return v;
}

CrossbarParams device(const Case& c) {
  CrossbarParams p;
  p.memristor.model = c.mem;
  p.memristor.k_per_v = c.k;
  p.transistor.model = c.tr;
  p.r_wire_ohm = c.r_wire;
  return p;
}

/// Largest |difference| of each vector's column currents relative to its largest column current.
double worst_relative(const Eigen::MatrixXd& got, const Eigen::MatrixXd& ref) {
  double worst = 0;
  for (Eigen::Index a = 0; a < ref.rows(); ++a) {
    const double scale = ref.row(a).cwiseAbs().maxCoeff();
    const double diff = (got.row(a) - ref.row(a)).cwiseAbs().maxCoeff();
    worst = std::max(worst, scale > 0 ? diff / scale : diff);
  }
  return worst;
}

}  // namespace

class BatchedNewton : public ::testing::TestWithParam<Case> {};

TEST_P(BatchedNewton, MatchesThePerVectorNewton) {
  const Case c = GetParam();
  const CrossbarParams p = device(c);
  const Eigen::MatrixXd g = random_g(c.m, c.n, p, 17 + c.m * 31 + c.n);
  const Eigen::MatrixXd v = inputs(12, c.m, c.bipolar, 3 + c.m + c.n);
  auto solver = make_crossbar_solver(p, SolverOptions{});
  solver->program(g);
  const Eigen::MatrixXd got = solver->column_currents(v);
  Eigen::MatrixXd ref(v.rows(), c.n);
  for (Eigen::Index a = 0; a < v.rows(); ++a)
    ref.row(a) = solver->solve(v.row(a).transpose()).column_current.transpose();
  EXPECT_EQ(got.row(0).cwiseAbs().maxCoeff(), 0.0) << "0 V in, 0 A out";
  EXPECT_LT(worst_relative(got, ref), 1e-9);
}

INSTANTIATE_TEST_SUITE_P(Devices, BatchedNewton,
                         ::testing::Values(Case{MemristorModel::Sinh, TransistorModel::Level1, 5, 1, 144, 64, false},
                                           Case{MemristorModel::Sinh, TransistorModel::Level1, 5, 1, 144, 64, true},
                                           Case{MemristorModel::Sinh, TransistorModel::Level1, 0.5, 1, 40, 17, true},
                                           Case{MemristorModel::Sinh, TransistorModel::Level1, 10, 1, 27, 16, false},
                                           Case{MemristorModel::Sinh, TransistorModel::None, 5, 1, 64, 32, true},
                                           Case{MemristorModel::Sinh, TransistorModel::Linear, 3, 1, 33, 9, true},
                                           Case{MemristorModel::Linear, TransistorModel::Level1, 5, 1, 64, 32, true},
                                           Case{MemristorModel::Sinh, TransistorModel::Level1, 5, 10, 64, 64, true},
                                           Case{MemristorModel::Sinh, TransistorModel::Level1, 5, 1, 1, 1, true},
                                           Case{MemristorModel::Sinh, TransistorModel::Level1, 5, 1, 1, 9, false},
                                           Case{MemristorModel::Sinh, TransistorModel::Level1, 5, 1, 12, 1, true},
                                           // exp(k V) overflows in the batched iteration: the per-vector
                                           // Newton (voltage-limited) must take over, not an error
                                           Case{MemristorModel::Sinh, TransistorModel::Level1, 80, 1, 16, 8, true},
                                           Case{MemristorModel::Sinh, TransistorModel::Level1, 100, 1, 1, 3, false}),
                         [](const auto& info) {
                           const Case& c = info.param;
                           return std::string(to_string(c.mem)) + "_" + to_string(c.tr) + "_k" +
                                  std::to_string(static_cast<int>(c.k * 10)) + "_rwire" +
                                  std::to_string(static_cast<int>(c.r_wire)) + "_" + std::to_string(c.m) + "x" +
                                  std::to_string(c.n) + (c.bipolar ? "_bipolar" : "_unipolar");
                         });

TEST(BatchedNewtonRun, SameBitsOnAnyThreadCount) {
  const Case c{MemristorModel::Sinh, TransistorModel::Level1, 5, 1, 64, 16, true};
  const CrossbarParams p = device(c);
  const Eigen::MatrixXd g = random_g(c.m, c.n, p, 5);
  const Eigen::MatrixXd v = inputs(21, c.m, true, 9);
  Eigen::MatrixXd first;
  for (int threads : {1, 2, 3}) {
    SolverOptions o;
    o.threads = threads;
    auto s = make_crossbar_solver(p, o);
    s->program(g);
    const Eigen::MatrixXd got = s->column_currents(v);
    if (first.size() == 0)
      first = got;
    else
      EXPECT_TRUE(got == first) << threads << " threads";
  }
}

TEST(BatchedNewtonRun, NonConvergenceNamesTheVector) {
  const Case c{MemristorModel::Sinh, TransistorModel::Level1, 5, 1, 8, 4, false};
  const CrossbarParams p = device(c);
  SolverOptions o;
  o.newton_max_iterations = 1;  // neither the batched nor the per-vector Newton can converge
  auto s = make_crossbar_solver(p, o);
  s->program(random_g(c.m, c.n, p, 1));
  Eigen::MatrixXd v = Eigen::MatrixXd::Zero(3, c.m);
  v.row(1).setConstant(0.4);
  try {
    s->column_currents(v);
    FAIL() << "expected a SolverError";
  } catch (const SolverError& e) {
    EXPECT_NE(std::string(e.what()).find("input vector 2"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("did not converge"), std::string::npos) << e.what();
  }
}

TEST(BatchedNewtonRun, LooserToleranceStaysWithinIt) {
  const Case c{MemristorModel::Sinh, TransistorModel::Level1, 5, 1, 144, 32, false};
  const CrossbarParams p = device(c);
  const Eigen::MatrixXd g = random_g(c.m, c.n, p, 8);
  const Eigen::MatrixXd v = inputs(6, c.m, false, 2);
  SolverOptions loose, reference;
  loose.nonlinear_tolerance = 1e-6;
  reference.batched_nonlinear = false;
  auto a = make_crossbar_solver(p, loose);
  auto b = make_crossbar_solver(p, reference);
  a->program(g);
  b->program(g);
  EXPECT_LT(worst_relative(a->column_currents(v), b->column_currents(v)), 1e-6);
}
