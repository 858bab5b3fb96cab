#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "sw/circuit/crossbar_params.h"
#include "sw/circuit/device_models.h"
#include "sw/common/config.h"
#include "sw/common/errors.h"

using namespace xbarsim;

TEST(Devices, SinhMemristorHasNominalConductanceAtReadVoltage) {
  MemristorParams p;
  p.model = MemristorModel::Sinh;
  p.k_per_v = 4.0;
  p.v_read_v = 0.2;
  MemristorDevice d(p);
  double i, di;
  d.eval(1e-5, 0.2, i, di);
  EXPECT_NEAR(i, 1e-5 * 0.2, 1e-20);
  d.eval(1e-5, -0.1, i, di);
  EXPECT_NEAR(i, 1e-5 * 0.2 * std::sinh(-0.4) / std::sinh(0.8), 1e-20);
  EXPECT_NEAR(di, 1e-5 * 0.2 * 4 * std::cosh(-0.4) / std::sinh(0.8), 1e-18);
}

TEST(Devices, Level1RegionsMatchHandFormulas) {
  TransistorParams p;
  p.model = TransistorModel::Level1;
  p.vg_v = 3.0;
  p.vth_v = 0.5;
  p.kp_a_per_v2 = 2e-3;
  TransistorDevice t(p);
  double i, da, db;
  // Triode, a is drain: Vgs = 3 - 0.1, Vds = 0.3.
  t.eval(0.4, 0.1, i, da, db);
  EXPECT_NEAR(i, 2e-3 * ((2.9 - 0.5) * 0.3 - 0.045), 1e-15);
  // Reversed: b is drain, current flows b -> a (negative a -> b).
  t.eval(0.1, 0.4, i, da, db);
  EXPECT_NEAR(i, -2e-3 * ((2.9 - 0.5) * 0.3 - 0.045), 1e-15);
  // Saturation: Vgs - Vth = 3 - 0 - 0.5 = 2.5 < Vds = 2.7.
  t.eval(2.7, 0.0, i, da, db);
  EXPECT_NEAR(i, 0.5 * 2e-3 * 2.5 * 2.5, 1e-15);
  EXPECT_EQ(da, 0.0);
  // Cutoff: source above vg - vth.
  t.eval(2.9, 2.8, i, da, db);
  EXPECT_EQ(i, 0.0);
}

TEST(Devices, Level1DerivativesMatchFiniteDifferences) {
  TransistorParams p;
  p.model = TransistorModel::Level1;
  TransistorDevice t(p);
  const double h = 1e-7;
  for (double va : {-0.3, 0.0, 0.05, 0.2, 0.4})
    for (double vb : {-0.2, 0.0, 0.01, 0.3}) {
      double i, da, db, ip, im, d1, d2;
      t.eval(va, vb, i, da, db);
      t.eval(va + h, vb, ip, d1, d2);
      t.eval(va - h, vb, im, d1, d2);
      EXPECT_NEAR(da, (ip - im) / (2 * h), 1e-8) << va << " " << vb;
      t.eval(va, vb + h, ip, d1, d2);
      t.eval(va, vb - h, im, d1, d2);
      EXPECT_NEAR(db, (ip - im) / (2 * h), 1e-8) << va << " " << vb;
    }
}

namespace {
/// The InputError message of parsing the crossbar keys with `sets`, or "" when it is accepted.
std::string crossbar_error(std::vector<std::string> sets) {
  try {
    parse_crossbar_params(ConfigTree::load("", sets));
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}
}  // namespace

TEST(CrossbarConfig, SettingsTheDeviceModelsCannotEvaluateAreErrorsNamingTheKeys) {
  const std::string sinh = "crossbar.memristor.model=sinh";
  // k v_read past sinh's range made the model's scale 0: every current 0 A, without a word.
  std::string msg = crossbar_error({sinh, "crossbar.memristor.k=100", "crossbar.memristor.v_read=7.2"});
  EXPECT_NE(msg.find("crossbar.memristor.k (100"), std::string::npos) << msg;
  EXPECT_NE(msg.find("crossbar.memristor.v_read (7.2"), std::string::npos) << msg;
  msg = crossbar_error({sinh, "crossbar.memristor.k=100", "crossbar.v_in_max=7"});
  EXPECT_NE(msg.find("crossbar.v_in_max (7"), std::string::npos) << msg;
  EXPECT_EQ(crossbar_error({sinh, "crossbar.memristor.k=100", "crossbar.v_in_max=6"}), "");
  EXPECT_EQ(crossbar_error({"crossbar.memristor.k=100", "crossbar.memristor.v_read=7.2"}), "") << "linear: k unused";
  // Wires 1e8x stiffer than the cells: the Newton reference stalled at the rounding level.
  msg = crossbar_error({sinh, "crossbar.r_wire=1e-8"});
  EXPECT_NE(msg.find("crossbar.r_wire (1e-08"), std::string::npos) << msg;
  EXPECT_NE(crossbar_error({"crossbar.transistor.model=level1", "crossbar.r_wire=1e-7"}), "");
  EXPECT_EQ(crossbar_error({sinh, "crossbar.r_wire=1e-6"}), "");
  EXPECT_EQ(crossbar_error({"crossbar.r_wire=1e-9"}), "") << "linear devices: ideal wires are fine";
  msg = crossbar_error({"crossbar.transistor.model=level1", "crossbar.v_in_max=3"});
  EXPECT_NE(msg.find("crossbar.v_in_max (3"), std::string::npos) << msg;
}
