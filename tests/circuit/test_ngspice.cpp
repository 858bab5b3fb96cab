// xbarsim against ngspice (Debian package) on the same netlists: the independent reference.
#include <gtest/gtest.h>

#include <array>
#include <cstdio>
#include <fstream>
#include <random>
#include <sstream>

#include "sw/circuit/crossbar_solver.h"
#include "sw/circuit/spice_netlist.h"
#include "tests/circuit/ngspice_reference.h"

using namespace xbarsim;

using namespace xbarsim::testing_ngspice;

namespace {

struct Case {
  int m, n, vectors;
  bool nonlinear;
};

}  // namespace

class Ngspice : public ::testing::TestWithParam<Case> {};

TEST_P(Ngspice, ColumnCurrentsAgree) {
  ASSERT_TRUE(have_ngspice()) << "ngspice is required as the circuit reference: run scripts/setup.sh "
                                 "(apt-get install ngspice)";
  const Case c = GetParam();
  CrossbarParams p;
  if (c.nonlinear) {
    p.memristor.model = MemristorModel::Sinh;
    p.transistor.model = TransistorModel::Level1;
  }
  std::mt19937_64 rng(1000 + c.m * 7 + c.n);
  std::uniform_real_distribution<double> ug(p.g_min_s, p.g_max_s), uv(-0.4, 0.4);
  Eigen::MatrixXd g(c.m, c.n), v(c.vectors, c.m);
  for (int i = 0; i < c.m; ++i)
    for (int j = 0; j < c.n; ++j) g(i, j) = ug(rng);
  std::bernoulli_distribution zero(0.5);
  for (int k = 0; k < c.vectors; ++k)  // unipolar and bipolar; from the third vector on, half the inputs 0 V
    for (int i = 0; i < c.m; ++i) v(k, i) = k >= 2 && zero(rng) ? 0.0 : k == 0 ? std::abs(uv(rng)) : uv(rng);
  const Eigen::MatrixXd ref = ngspice_currents(p, g, v);
  auto solver = make_crossbar_solver(p, SolverOptions{});  // nonlinear: the batched Newton
  solver->program(g);
  const Eigen::MatrixXd got = solver->column_currents(v);
  const double tol = 1e-6;
  double worst = 0;
  for (int k = 0; k < c.vectors; ++k)
    for (int j = 0; j < c.n; ++j) {
      const double rel = std::abs(got(k, j) - ref(k, j)) / std::abs(ref(k, j));
      worst = std::max(worst, rel);
      EXPECT_LT(rel, tol) << "vector " << k << " column " << j << ": xbarsim " << got(k, j) << " ngspice " << ref(k, j);
    }
  RecordProperty("worst_relative_difference", std::to_string(worst));
  std::cout << "[ ngspice ] " << c.m << "x" << c.n << (c.nonlinear ? " sinh+level1" : " linear")
            << ": worst relative difference " << worst << "\n";
}

INSTANTIATE_TEST_SUITE_P(Sizes, Ngspice,
                         ::testing::Values(Case{8, 4, 3, false}, Case{8, 4, 3, true}, Case{32, 32, 2, false},
                                           Case{64, 32, 8, true}, Case{128, 64, 1, false}, Case{128, 64, 8, true}),
                         [](const auto& info) {
                           return std::to_string(info.param.m) + "x" + std::to_string(info.param.n) +
                                  (info.param.nonlinear ? "_nonlinear" : "_linear");
                         });

// Voltage sensing (crossbar.sensing = voltage): the columns end open and settle to a voltage.
// Both solvers, and for linear devices the effective matrix (V_col = V A), against ngspice on
// the same netlist with the column ends left open.
namespace {
struct VoltageCase {
  int m, n, vectors;
  bool nonlinear;
};
}  // namespace

class NgspiceVoltage : public ::testing::TestWithParam<VoltageCase> {};

TEST_P(NgspiceVoltage, ColumnVoltagesAgree) {
  ASSERT_TRUE(have_ngspice()) << "ngspice is required as the circuit reference: run scripts/setup.sh "
                                 "(apt-get install ngspice)";
  const VoltageCase c = GetParam();
  CrossbarParams p;
  p.sensing = Sensing::Voltage;
  p.transistor.model = TransistorModel::Linear;  // wires, input resistance and access transistors
  if (c.nonlinear) {
    p.memristor.model = MemristorModel::Sinh;
    p.transistor.model = TransistorModel::Level1;
  }
  std::mt19937_64 rng(2000 + c.m * 7 + c.n);
  std::uniform_real_distribution<double> ug(p.g_min_s, p.g_max_s), uv(-0.4, 0.4);
  Eigen::MatrixXd g(c.m, c.n), v(c.vectors, c.m);
  for (int i = 0; i < c.m; ++i)
    for (int j = 0; j < c.n; ++j) g(i, j) = ug(rng);
  // Unipolar, then bipolar. (Half the bipolar inputs at 0 V, as for the currents above, took
  // ngspice's operating point 600 iterations from the unipolar one: 15 s at 256x16.)
  for (int k = 0; k < c.vectors; ++k)
    for (int i = 0; i < c.m; ++i) v(k, i) = k == 0 ? std::abs(uv(rng)) : uv(rng);
  const Eigen::MatrixXd ref = ngspice_outputs(p, g, v);
  // Relative to the column voltage; a bipolar column within 1 % of the largest input of 0 V,
  // relative to that 1 %.
  auto worst_of = [&](const Eigen::MatrixXd& got, const char* what) {
    const double tol = c.nonlinear ? 1e-6 : 1e-9;
    double worst = 0;
    for (int k = 0; k < c.vectors; ++k) {
      const double floor = 0.01 * v.row(k).cwiseAbs().maxCoeff();
      for (int j = 0; j < c.n; ++j) {
        const double rel = std::abs(got(k, j) - ref(k, j)) / std::max(std::abs(ref(k, j)), floor);
        worst = std::max(worst, rel);
        EXPECT_LT(rel, tol) << what << ": vector " << k << " column " << j << ": xbarsim " << got(k, j) << " ngspice "
                            << ref(k, j);
      }
    }
    std::cout << "[ ngspice ] voltage sensing " << c.m << "x" << c.n << (c.nonlinear ? " sinh+level1 " : " linear ")
              << what << ": worst relative difference " << worst << "\n";
  };
  for (const SolverMethod method : {SolverMethod::Line, SolverMethod::Direct}) {
    SolverOptions o;
    o.method = method;
    auto solver = make_crossbar_solver(p, o);  // line, nonlinear: the batched Newton
    solver->program(g);
    worst_of(solver->column_voltages(v), to_string(method));
    if (c.nonlinear && method == SolverMethod::Line) {
      o.batched_nonlinear = false;  // the per-vector Newton
      auto newton = make_crossbar_solver(p, o);
      newton->program(g);
      worst_of(newton->column_voltages(v), "line (per-vector Newton)");
    }
    if (!c.nonlinear) worst_of(v * solver->effective_matrix(), (std::string(to_string(method)) + " (V A)").c_str());
  }
}

// 256x64 takes ngspice ~40 s (linear) and ~80 s (nonlinear) of matrix ordering: CI only
// (scripts/test.sh, XBARSIM_CI_ONLY); 256x16 keeps tall open columns in the suite.
INSTANTIATE_TEST_SUITE_P(Sizes, NgspiceVoltage,
                         ::testing::Values(VoltageCase{64, 32, 2, false}, VoltageCase{64, 32, 2, true},
                                           VoltageCase{256, 16, 2, false}, VoltageCase{256, 16, 2, true},
                                           VoltageCase{256, 64, 1, false}, VoltageCase{256, 64, 1, true}),
                         [](const auto& info) {
                           return std::to_string(info.param.m) + "x" + std::to_string(info.param.n) + "_voltage_" +
                                  (info.param.nonlinear ? "nonlinear" : "linear");
                         });
