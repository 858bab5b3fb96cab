// Solvers against closed-form circuit analysis (independent formulations).
#include <gtest/gtest.h>

#include <random>

#include "sw/circuit/crossbar_solver.h"
#include "sw/circuit/device_models.h"

using namespace xbarsim;

namespace {
CrossbarParams params(double r_wire, double r_in, double r_out, TransistorModel t) {
  CrossbarParams p;
  p.r_wire_ohm = r_wire;
  p.r_in_ohm = r_in;
  p.r_out_ohm = r_out;
  p.transistor.model = t;
  p.transistor.r_on_ohm = 2000;
  return p;
}
}  // namespace

class ClosedForm : public ::testing::TestWithParam<std::tuple<std::string, TransistorModel>> {};

TEST_P(ClosedForm, SingleCellIsASeriesCircuit) {
  const auto p = params(1.5, 2.0, 3.0, std::get<1>(GetParam()));
  SolverOptions o;
  o.method = solver_method_from_name(std::get<0>(GetParam()));
  auto s = make_crossbar_solver(p, o);
  Eigen::MatrixXd g(1, 1);
  g << 1.0 / 20e3;
  s->program(g);
  Eigen::VectorXd v(1);
  v << 0.3;
  const double r_tr = p.transistor.model == TransistorModel::Linear ? 2000 : 0;
  const double expect = 0.3 / (2.0 + 1.5 + 20e3 + r_tr + 1.5 + 3.0);
  EXPECT_NEAR(s->solve(v).column_current(0), expect, 1e-12 * expect);
}

TEST_P(ClosedForm, SingleRowIsALadder) {
  const auto p = params(1.0, 1.0, 1.0, std::get<1>(GetParam()));
  SolverOptions o;
  o.method = solver_method_from_name(std::get<0>(GetParam()));
  const int n = 40;
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(p.g_min_s, p.g_max_s);
  Eigen::MatrixXd g(1, n);
  for (int j = 0; j < n; ++j) g(0, j) = u(rng);
  // Branch j to ground: cell + r_wire + r_out. Ladder impedances from the far end.
  std::vector<double> z(n), zin(n);
  for (int j = 0; j < n; ++j) z[j] = 1.0 / linear_cell_conductance(p, g(0, j)) + p.r_wire_ohm + p.r_out_ohm;
  zin[n - 1] = z[n - 1];
  for (int j = n - 2; j >= 0; --j) {
    const double right = p.r_wire_ohm + zin[j + 1];
    zin[j] = z[j] * right / (z[j] + right);
  }
  const double vin = 0.37;
  double vt = vin * zin[0] / (p.r_in_ohm + p.r_wire_ohm + zin[0]);
  Eigen::VectorXd expect(n);
  for (int j = 0; j < n; ++j) {
    expect(j) = vt / z[j];
    if (j + 1 < n) vt = vt * zin[j + 1] / (p.r_wire_ohm + zin[j + 1]);
  }
  auto s = make_crossbar_solver(p, o);
  s->program(g);
  Eigen::VectorXd v(1);
  v << vin;
  const Eigen::VectorXd got = s->solve(v).column_current;
  for (int j = 0; j < n; ++j) EXPECT_NEAR(got(j), expect(j), 1e-11 * std::abs(expect(j))) << j;
}

TEST_P(ClosedForm, SingleColumnMatchesNortonEquivalents) {
  const auto p = params(2.0, 1.0, 1.0, std::get<1>(GetParam()));
  SolverOptions o;
  o.method = solver_method_from_name(std::get<0>(GetParam()));
  const int m = 50;
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> u(p.g_min_s, p.g_max_s), uv(-0.4, 0.4);
  Eigen::MatrixXd g(m, 1);
  Eigen::VectorXd v(m);
  for (int i = 0; i < m; ++i) {
    g(i, 0) = u(rng);
    v(i) = uv(rng);
  }
  // Each row is a Norton source into B_i: conductance 1/(r_in + r_wire + 1/g_cell).
  // Column: B_i -- r_wire -- B_{i+1}; B_{m-1} -- r_wire + r_out -- ground. Dense solve.
  Eigen::MatrixXd a = Eigen::MatrixXd::Zero(m, m);
  Eigen::VectorXd b(m);
  for (int i = 0; i < m; ++i) {
    const double gn = 1.0 / (p.r_in_ohm + p.r_wire_ohm + 1.0 / linear_cell_conductance(p, g(i, 0)));
    a(i, i) += gn;
    b(i) = gn * v(i);
    if (i + 1 < m) {
      const double gw = 1.0 / p.r_wire_ohm;
      a(i, i) += gw;
      a(i + 1, i + 1) += gw;
      a(i, i + 1) -= gw;
      a(i + 1, i) -= gw;
    }
  }
  a(m - 1, m - 1) += 1.0 / (p.r_wire_ohm + p.r_out_ohm);
  const Eigen::VectorXd vb = a.fullPivLu().solve(b);
  const double expect = vb(m - 1) / (p.r_wire_ohm + p.r_out_ohm);
  auto s = make_crossbar_solver(p, o);
  s->program(g);
  EXPECT_NEAR(s->solve(v).column_current(0), expect, 1e-10 * std::abs(expect));
}

INSTANTIATE_TEST_SUITE_P(Solvers, ClosedForm,
                         ::testing::Combine(::testing::Values("line", "direct"),
                                            ::testing::Values(TransistorModel::None, TransistorModel::Linear)));
