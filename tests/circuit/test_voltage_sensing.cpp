// Voltage sensing (crossbar.sensing = voltage) against closed forms, and the cells' power.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "sw/circuit/crossbar_solver.h"
#include "sw/circuit/device_models.h"
#include "sw/common/errors.h"
#include "tests/circuit/random_crossbar.h"

using namespace xbarsim;

namespace {
CrossbarParams voltage_params(TransistorModel t) {
  CrossbarParams p;
  p.sensing = Sensing::Voltage;
  p.transistor.model = t;
  p.transistor.r_on_ohm = 2000;
  return p;
}

std::unique_ptr<CrossbarSolver> solver_for(const CrossbarParams& p, const std::string& method, bool batched = true) {
  SolverOptions o;
  o.method = solver_method_from_name(method);
  o.batched_nonlinear = batched;
  return make_crossbar_solver(p, o);
}
}  // namespace

class VoltageSensing : public ::testing::TestWithParam<std::tuple<std::string, TransistorModel>> {};

TEST_P(VoltageSensing, IdealWiresGiveTheConductanceWeightedMean) {
  // r_wire = r_in = 1e-9 ohm: the row drops are ~1e-12 of the inputs (64 cells of <= 67 uS at
  // 0.4 V draw 2 mA). r_out = 100 kOhm carries no current, so it must not matter.
  CrossbarParams p = voltage_params(std::get<1>(GetParam()));
  p.r_wire_ohm = p.r_in_ohm = 1e-9;
  p.r_out_ohm = 1e5;
  const int m = 64, n = 32;
  const Eigen::MatrixXd g = test::random_g(m, n, p, 31);
  const Eigen::MatrixXd v = test::random_v(40, m, -0.4, 0.4, 32);  // 40 > min(m, n): the V A path
  Eigen::MatrixXd gc(m, n);
  for (int i = 0; i < m; ++i)
    for (int j = 0; j < n; ++j) gc(i, j) = linear_cell_conductance(p, g(i, j));
  const Eigen::RowVectorXd sum = gc.colwise().sum();
  const Eigen::MatrixXd a = gc.array().rowwise() / sum.array();  // A_ij = G_ij / sum_k G_kj
  auto s = solver_for(p, std::get<0>(GetParam()));
  s->program(g);
  const Eigen::MatrixXd expect = v * a;
  const double scale = v.cwiseAbs().maxCoeff();
  const Eigen::MatrixXd batch = s->column_voltages(v);
  EXPECT_LT((batch - expect).cwiseAbs().maxCoeff(), 1e-10 * scale);
  EXPECT_LT((s->effective_matrix() - a).cwiseAbs().maxCoeff(), 1e-10 * a.maxCoeff());
  const CircuitSolution one = s->solve(v.row(3).transpose());
  for (int j = 0; j < n; ++j) {
    EXPECT_NEAR(one.column_voltage(j), expect(3, j), 1e-10 * scale) << j;
    EXPECT_EQ(one.column_current(j), 0.0) << "the open column carries no current";
  }
}

TEST_P(VoltageSensing, EqualInputsHoldEveryColumnAtThatVoltageWhateverTheWires) {
  // No current flows anywhere, so every node is at V0: exact, with the default 1-ohm wires
  // and for nonlinear devices too (sinh(0) = 0; a level-1 transistor at V_ds = 0 is off).
  for (const bool nonlinear : {false, true}) {
    CrossbarParams p = voltage_params(std::get<1>(GetParam()));
    p.r_wire_ohm = 2.5;
    p.r_in_ohm = 7;
    if (nonlinear) p.memristor.model = MemristorModel::Sinh;
    const int m = 48, n = 24;
    const Eigen::MatrixXd g = test::random_g(m, n, p, 41);
    const double v0 = 0.3;
    const Eigen::MatrixXd v = Eigen::MatrixXd::Constant(3, m, v0);
    for (const bool batched : {true, false}) {
      auto s = solver_for(p, std::get<0>(GetParam()), batched);
      s->program(g);
      const Eigen::MatrixXd got = s->column_voltages(v);
      EXPECT_LT((got.array() - v0).abs().maxCoeff(), 1e-12 * v0) << "nonlinear " << nonlinear;
    }
  }
}

TEST_P(VoltageSensing, SingleColumnMatchesNortonEquivalents) {
  // n = 1: each row is a Norton source into B_i of conductance 1/(r_in + r_wire + 1/g_cell);
  // the column B_0 .. B_m-1 is a chain of r_wire, open at both ends. Dense solve.
  CrossbarParams p = voltage_params(std::get<1>(GetParam()));
  p.r_wire_ohm = 2.0;
  p.r_in_ohm = 3.0;
  const int m = 50;
  const Eigen::MatrixXd g = test::random_g(m, 1, p, 51);
  const Eigen::VectorXd v = test::random_v(1, m, -0.4, 0.4, 52).row(0).transpose();
  Eigen::MatrixXd k = Eigen::MatrixXd::Zero(m, m);
  Eigen::VectorXd rhs(m);
  const double gw = 1.0 / p.r_wire_ohm;
  for (int i = 0; i < m; ++i) {
    const double gn = 1.0 / (p.r_in_ohm + p.r_wire_ohm + 1.0 / linear_cell_conductance(p, g(i, 0)));
    k(i, i) += gn;
    rhs(i) = gn * v(i);
    if (i + 1 < m) {
      k(i, i) += gw;
      k(i + 1, i + 1) += gw;
      k(i, i + 1) -= gw;
      k(i + 1, i) -= gw;
    }
  }
  const double expect = k.fullPivLu().solve(rhs)(m - 1);  // D is at B_m-1: its r_wire carries nothing
  auto s = solver_for(p, std::get<0>(GetParam()));
  s->program(g);
  EXPECT_NEAR(s->solve(v).column_voltage(0), expect, 1e-12 * v.cwiseAbs().maxCoeff());
}

INSTANTIATE_TEST_SUITE_P(Solvers, VoltageSensing,
                         ::testing::Combine(::testing::Values("line", "direct"),
                                            ::testing::Values(TransistorModel::None, TransistorModel::Linear)));

TEST(VoltageSensing, SinhColumnsWithIdealWiresBalanceTheirCellCurrents) {
  // Nearly ideal wires (the 1 uOhm floor of nonlinear devices): each column at the V where
  // sum_i G_ij sinh(k (V_i - V)) = 0, found by bisection (the sum falls monotonically in V).
  // The wires shift it by at most a row's drop, (r_in + n r_wire) x its largest current.
  CrossbarParams p = voltage_params(TransistorModel::None);
  p.memristor.model = MemristorModel::Sinh;
  p.r_wire_ohm = p.r_in_ohm = 1e-6;
  const int m = 64, n = 4;
  const MemristorDevice dev(p.memristor);
  const double drop = (p.r_in_ohm + n * p.r_wire_ohm) * n * p.g_max_s * dev.current_per_siemens(0.8);
  ASSERT_LT(drop, 1e-8);
  const Eigen::MatrixXd g = test::random_g(m, n, p, 71);
  const Eigen::MatrixXd v = test::random_v(3, m, -0.4, 0.4, 72);
  for (const std::string method : {"line", "direct"})
    for (const bool batched : {true, false}) {
      auto s = solver_for(p, method, batched);
      s->program(g);
      const Eigen::MatrixXd got = s->column_voltages(v);
      for (int k = 0; k < v.rows(); ++k)
        for (int j = 0; j < n; ++j) {
          double lo = -0.4, hi = 0.4;
          for (int it = 0; it < 200; ++it) {
            const double mid = 0.5 * (lo + hi);
            double sum = 0;
            for (int i = 0; i < m; ++i) sum += g(i, j) * std::sinh(p.memristor.k_per_v * (v(k, i) - mid));
            (sum > 0 ? lo : hi) = mid;
          }
          EXPECT_NEAR(got(k, j), 0.5 * (lo + hi), drop) << method << " batched " << batched << " " << k << " " << j;
        }
    }
}

TEST(VoltageSensing, CellPowerWithIdealWires) {
  // Ideal wires: sum G (V_i - V_col)^2 (voltage sensing), sum G V_i^2 (current sensing, the
  // column at the virtual ground), and the sources deliver just that. No transistor: its
  // share is not the memristors'.
  const int m = 40, n = 20;
  CrossbarParams p = voltage_params(TransistorModel::None);
  p.r_wire_ohm = p.r_in_ohm = p.r_out_ohm = 1e-9;
  const Eigen::MatrixXd g = test::random_g(m, n, p, 61);
  const Eigen::VectorXd v = test::random_v(1, m, 0.0, 0.4, 62).row(0).transpose();
  const Eigen::RowVectorXd v_col = (v.transpose() * g).array() / g.colwise().sum().array();
  double p_voltage = 0, p_current = 0;
  for (int i = 0; i < m; ++i)
    for (int j = 0; j < n; ++j) {
      p_voltage += g(i, j) * (v(i) - v_col(j)) * (v(i) - v_col(j));
      p_current += g(i, j) * v(i) * v(i);
    }
  for (const std::string method : {"line", "direct"}) {
    p.sensing = Sensing::Voltage;
    auto s = solver_for(p, method);
    s->program(g);
    EXPECT_NEAR(cell_power_w(s->solve(v)), p_voltage, 1e-10 * p_voltage) << method;
    EXPECT_NEAR(source_power_w(s->solve(v), v), p_voltage, 1e-9 * p_voltage) << method;
    p.sensing = Sensing::Current;
    auto c = solver_for(p, method);
    c->program(g);
    EXPECT_NEAR(cell_power_w(c->solve(v)), p_current, 1e-10 * p_current) << method;
  }
}

TEST(VoltageSensing, SourcePowerIsCellsPlusWires) {
  // With resistive wires and drivers the sources deliver what the cells dissipate plus every
  // wire segment's I^2 R (with ideal wires just the cells': CellPowerWithIdealWires).
  const int m = 40, n = 20;
  const CrossbarParams p = voltage_params(TransistorModel::None);
  const Eigen::MatrixXd g = test::random_g(m, n, p, 63);
  const Eigen::VectorXd v = test::random_v(1, m, 0.0, 0.4, 64).row(0).transpose();
  CrossbarParams w = p;
  w.r_wire_ohm = w.r_in_ohm = 50;
  auto s = solver_for(w, "line");
  s->program(g);
  const CircuitSolution sol = s->solve(v);
  // The wires' dissipation, segment by segment: each row's current through its driver (r_in)
  // and the segment before its first cell, the row wires between cells, and the column wires
  // (the open end carries nothing).
  double wires = 0;
  for (int i = 0; i < m; ++i) {
    const double row = sol.cell_current.row(i).sum();
    wires += row * row * (w.r_in_ohm + w.r_wire_ohm);
    for (int j = 0; j + 1 < n; ++j) {
      const double d = sol.v_top(i, j) - sol.v_top(i, j + 1);
      wires += d * d / w.r_wire_ohm;
    }
  }
  for (int j = 0; j < n; ++j)
    for (int i = 0; i + 1 < m; ++i) {
      const double d = sol.v_bottom(i, j) - sol.v_bottom(i + 1, j);
      wires += d * d / w.r_wire_ohm;
    }
  EXPECT_GT(wires, 0);
  EXPECT_NEAR(source_power_w(sol, v), cell_power_w(sol) + wires, 1e-9 * source_power_w(sol, v));
}

TEST(VoltageSensing, ColumnCurrentsAreAnInputError) {
  auto s = solver_for(voltage_params(TransistorModel::None), "line");
  s->program(Eigen::MatrixXd::Constant(4, 3, 2e-5));
  try {
    s->column_currents(Eigen::MatrixXd::Constant(1, 4, 0.1));
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("crossbar.sensing is voltage"), std::string::npos) << e.what();
  }
  EXPECT_EQ(s->column_outputs(Eigen::MatrixXd::Constant(1, 4, 0.1)).rows(), 1);
}

TEST(VoltageSensing, ConfigurationKey) {
  EXPECT_EQ(parse_crossbar_params(ConfigTree()).sensing, Sensing::Current) << "the default";
  EXPECT_EQ(parse_crossbar_params(ConfigTree::load("", {"crossbar.sensing=voltage"})).sensing, Sensing::Voltage);
  try {
    parse_crossbar_params(ConfigTree::load("", {"crossbar.sensing=charge"}));
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("crossbar.sensing"), std::string::npos) << msg;
    EXPECT_NE(msg.find("current, voltage"), std::string::npos) << msg;
  }
}
