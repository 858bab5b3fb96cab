// Conversion checked by independent circuit solves (full-topology direct solver).
#include <gtest/gtest.h>

#include <random>

#include "sw/mitigation/conversion.h"
#include "tests/circuit/random_crossbar.h"

using namespace xbarsim;
using xbarsim::test::random_g;

namespace {
SolverOptions direct() {
  SolverOptions o;
  o.method = SolverMethod::Direct;
  return o;
}
}  // namespace

class SignalConversion : public ::testing::TestWithParam<std::pair<MemristorModel, TransistorModel>> {};

TEST_P(SignalConversion, EveryCellPassesItsIdealCurrent) {
  CrossbarParams p;
  p.memristor.model = GetParam().first;
  p.transistor.model = GetParam().second;
  p.r_wire_ohm = 2.0;
  const int m = 24, n = 10;
  // Targets in the middle of the range so that G' stays programmable.
  Eigen::MatrixXd g = random_g(m, n, p, 3) * 0.5;
  g = g.cwiseMax(p.g_min_s * 2);
  std::mt19937_64 rng(4);
  std::uniform_real_distribution<double> u(0.05, 0.3);
  Eigen::VectorXd v(m);
  for (int i = 0; i < m; ++i) v(i) = (i % 3 == 0 ? -1 : 1) * u(rng);  // signed signal
  const ConversionResult r = convert_signal(p, g, v);
  ASSERT_EQ(r.out_of_range(), 0);
  auto s = make_crossbar_solver(p, direct());
  s->program(r.g_prime);
  const CircuitSolution sol = s->solve(v);
  for (int i = 0; i < m; ++i)
    for (int j = 0; j < n; ++j) {
      const double ideal = v(i) * g(i, j);
      EXPECT_NEAR(sol.cell_current(i, j), ideal, 1e-9 * std::abs(ideal)) << i << "," << j;
    }
  // The columns then carry exactly the ideal currents V * G.
  const Eigen::VectorXd ideal_cols = (v.transpose() * g).transpose();
  EXPECT_LT((sol.column_current - ideal_cols).cwiseAbs().maxCoeff(), 1e-9 * ideal_cols.cwiseAbs().maxCoeff());
}

INSTANTIATE_TEST_SUITE_P(Devices, SignalConversion,
                         ::testing::Values(std::make_pair(MemristorModel::Linear, TransistorModel::None),
                                           std::make_pair(MemristorModel::Linear, TransistorModel::Linear),
                                           std::make_pair(MemristorModel::Sinh, TransistorModel::None),
                                           std::make_pair(MemristorModel::Sinh, TransistorModel::Level1)));

TEST(SignalConversion, PredistortedSignalMeetsItsLinearTarget) {
  // With a DAC lookup table the applied voltage V = f^-1(x) differs from the linear target
  // alpha x: every cell must pass alpha x G at the applied voltage (sinh + level 1).
  CrossbarParams p;
  p.memristor.model = MemristorModel::Sinh;
  p.transistor.model = TransistorModel::Level1;
  const int m = 20, n = 6;
  Eigen::MatrixXd g = (random_g(m, n, p, 9) * 0.5).cwiseMax(p.g_min_s * 2);
  const Eigen::VectorXd v_applied = Eigen::VectorXd::Constant(m, 0.05);
  const Eigen::VectorXd v_target = Eigen::VectorXd::Constant(m, 0.042);
  const ConversionResult r = convert_signal(p, g, v_applied, v_target);
  ASSERT_EQ(r.out_of_range(), 0);
  auto s = make_crossbar_solver(p, direct());
  s->program(r.g_prime);
  const CircuitSolution sol = s->solve(v_applied);
  for (int i = 0; i < m; ++i)
    for (int j = 0; j < n; ++j)
      EXPECT_NEAR(sol.cell_current(i, j), v_target(i) * g(i, j), 1e-9 * v_target(i) * g(i, j)) << i << "," << j;
}

TEST(SignalConversion, LinearDevicesDoNotDependOnAmplitude) {
  CrossbarParams p;
  const Eigen::MatrixXd g = random_g(30, 8, p, 5);
  const auto a = convert_signal(p, g, Eigen::VectorXd::Constant(30, 0.01));
  const auto b = convert_signal(p, g, Eigen::VectorXd::Constant(30, 0.4));
  EXPECT_LT((a.g_prime - b.g_prime).cwiseAbs().maxCoeff(), 1e-12 * p.g_max_s);
}

TEST(SignalConversion, LargeArraysLeaveTheProgrammableRange) {
  // Column IR drop ~ r_wire * mean(G) * m^2 / 2: at 576 rows most cells would need G' > g_max.
  CrossbarParams p;
  const Eigen::MatrixXd g = random_g(576, 64, p, 6);
  const auto r = convert_signal(p, g, Eigen::VectorXd::Constant(576, 0.04));
  EXPECT_GT(r.above_max, 576 * 64 / 2);
}

TEST(MatrixConversion, EffectiveMatrixMatchesTargetForAllInputs) {
  for (auto tr : {TransistorModel::None, TransistorModel::Linear}) {
    CrossbarParams p;
    p.transistor.model = tr;
    p.transistor.r_on_ohm = 500;
    const int m = 48, n = 16;
    Eigen::MatrixXd g = random_g(m, n, p, 8) * 0.6;
    g = g.cwiseMax(2 * p.g_min_s);
    const auto r = convert_matrix(p, SolverOptions{}, g, Eigen::VectorXd::Constant(m, 0.2));
    EXPECT_EQ(r.out_of_range(), 0);
    auto s = make_crossbar_solver(p, direct());
    s->program(r.g_prime);
    const Eigen::MatrixXd geff = s->effective_matrix();
    EXPECT_EQ(r.column_gain, Eigen::VectorXd::Ones(n));  // feasible: no scaling needed
    EXPECT_LT((geff - g).cwiseAbs().maxCoeff() / g.maxCoeff(), 1e-8);
  }
}

TEST(MatrixConversion, ColumnScalingMakesInfeasibleTargetsExact) {
  // 144 rows at the paper's parameters: some cells would need G' > g_max. With a per-column
  // gain on the weight part, G_eff equals the scaled target exactly.
  CrossbarParams p;
  const int m = 144, n = 16;
  const Eigen::MatrixXd g = random_g(m, n, p, 10);
  MatrixConversionOptions mo;
  mo.column_scaling = false;
  const auto bounded = convert_matrix(p, SolverOptions{}, g, Eigen::VectorXd::Constant(m, 0.2), mo);
  EXPECT_GT(bounded.above_max, 0);
  EXPECT_GT(bounded.residual, 1e-3);
  const auto scaled = convert_matrix(p, SolverOptions{}, g, Eigen::VectorXd::Constant(m, 0.2));
  EXPECT_LT(scaled.column_gain.maxCoeff(), 1.0);
  EXPECT_GT(scaled.column_gain.minCoeff(), 0.5);
  Eigen::MatrixXd target(m, n);
  for (int j = 0; j < n; ++j)
    target.col(j) = (p.g_min_s + scaled.column_gain(j) * (g.col(j).array() - p.g_min_s)).matrix();
  auto s = make_crossbar_solver(p, direct());
  s->program(scaled.g_prime);
  EXPECT_LT((s->effective_matrix() - target).cwiseAbs().maxCoeff() / target.maxCoeff(), 1e-8);
  EXPECT_LE(scaled.g_prime.maxCoeff(), p.g_max_s);
  EXPECT_GE(scaled.g_prime.minCoeff(), p.g_min_s);
}

TEST(MatrixConversion, NonlinearDevicesMatchAtTheOperatingPoint) {
  CrossbarParams p;
  p.memristor.model = MemristorModel::Sinh;
  p.transistor.model = TransistorModel::Level1;
  const int m = 32, n = 8;
  Eigen::MatrixXd g = random_g(m, n, p, 9) * 0.6;
  g = g.cwiseMax(2 * p.g_min_s);
  const Eigen::VectorXd v = Eigen::VectorXd::Constant(m, 0.1);
  const auto r = convert_matrix(p, SolverOptions{}, g, v);
  auto s = make_crossbar_solver(p, direct());
  s->program(r.g_prime);
  const Eigen::VectorXd got = s->solve(v).column_current;
  const Eigen::VectorXd ideal = (v.transpose() * g).transpose();
  EXPECT_LT((got - ideal).cwiseAbs().maxCoeff() / ideal.cwiseAbs().maxCoeff(), 1e-6);
}
