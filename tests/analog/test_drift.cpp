// Time after programming (issue 40, item 4): the crossbars drift, and compensation restores what
// it can; a layer moved in time by set_readout equals one programmed for that time.
#include <gtest/gtest.h>

#include <cmath>

#include "sw/analog/analog_layer.h"
#include "sw/analog/synthetic.h"

using namespace xbarsim;

namespace {

constexpr double kYear = 365.25 * 86400;

/// A drift-only statistical device: no programming error, no read or 1/f noise; every cell
/// drifts as G (t + t0) / t0)^-nu with nu ~ |N(0.06, 0.01)| (a PCM-like exponent).
DeviceSpec drift_only() {
  DeviceSpec d;
  d.kind = DeviceKind::Statistical;
  d.model = "drift-only";
  StatisticalModel& m = d.stat;
  m.g_min_s = 1e-6;
  m.g_max_s = 25e-6;
  m.program_sigma_us = {0.0};
  m.drifts = true;
  m.drift_t0_s = 20;
  m.nu_mean = {0.0, 0.06, 0.0, 1.0};
  m.nu_std = {0.0, 0.01, 0.0, 1.0};
  return d;
}

/// Differential pairs (the output scales with the drift), ideal wires, no converters.
AnalogConfig config(double t, Compensation comp) {
  AnalogConfig c;
  c.set_method("none", "test");
  c.mapping.negative = NegativeWeights::Differential;
  c.mapping.max_rows = 64;
  c.xbar.r_wire_ohm = c.xbar.r_in_ohm = c.xbar.r_out_ohm = 1e-6;
  c.device = drift_only();
  c.device.time_s = t;
  c.device.compensation = comp;
  return c;
}

/// The least-squares scale of y against the ideal output.
double scale(const Eigen::MatrixXd& y, const Eigen::MatrixXd& ideal) {
  return (y.array() * ideal.array()).sum() / ideal.array().square().sum();
}

}  // namespace

TEST(Drift, GlobalCompensationRestoresTheOutputScaleWithinTheSpreadOfNu) {
  const Eigen::MatrixXd w = synthetic_kernel("gaussian", 64, 16, 3);
  const Eigen::MatrixXd x = synthetic_inputs(200, 64, 0.5, 1.0, 4);
  const Eigen::MatrixXd ideal = x * w;
  auto run = [&](double t, Compensation comp) {
    AnalogLayer layer(config(t, comp), w, 1.0, false);
    layer.program(Eigen::MatrixXd());
    return scale(layer.forward(x), ideal);
  };
  // After a year every cell holds ((t + t0) / t0)^-nu of its conductance: 0.425 at the mean nu.
  const double ratio = std::log((kYear + 20) / 20);
  const double expected = std::exp(-0.06 * ratio);
  EXPECT_NEAR(run(0, Compensation::None), 1.0, 1e-7);  // at programming: exact but for 1e-6 ohm wires
  const double none = run(kYear, Compensation::None);
  // The spread of nu (0.01) moves one cell's factor by about 0.01 ln ratio = 14 %; the scale of
  // a sum of many cells far less, but it is the spread's scale that bounds what one gain can do.
  const double spread = 0.01 * ratio * expected;
  EXPECT_NEAR(none, expected, spread);
  const double global = run(kYear, Compensation::Global);
  EXPECT_NEAR(global, 1.0, spread);
  EXPECT_LT(std::abs(global - 1), std::abs(none - 1) / 10);
  const double column = run(kYear, Compensation::Column);
  EXPECT_NEAR(column, 1.0, spread);
}

TEST(Drift, MovingInTimeEqualsProgrammingForThatTime) {
  const Eigen::MatrixXd w = synthetic_kernel("gaussian", 40, 12, 5);
  const Eigen::MatrixXd x = synthetic_inputs(30, 40, 0.5, 1.0, 6);
  for (Compensation comp : {Compensation::None, Compensation::Global, Compensation::Column, Compensation::Recalibrate}) {
    AnalogConfig a = config(0, Compensation::None);
    a.set_method("conversion+calibration", "test");
    a.converters.adc_bits = 8;
    a.device.read_sigma_s = 0;
    AnalogConfig b = a;
    b.device.time_s = 86400;
    b.device.compensation = comp;
    AnalogLayer moved(a, w, 1.0, false);
    moved.program(Eigen::MatrixXd());
    moved.set_readout(b, Eigen::MatrixXd());
    AnalogLayer direct(b, w, 1.0, false);
    direct.program(Eigen::MatrixXd());
    EXPECT_EQ(moved.forward(x), direct.forward(x)) << to_string(comp);
    // And back to the time of programming.
    moved.set_readout(a, Eigen::MatrixXd());
    AnalogLayer at0(a, w, 1.0, false);
    at0.program(Eigen::MatrixXd());
    EXPECT_EQ(moved.forward(x), at0.forward(x)) << to_string(comp);
  }
}
