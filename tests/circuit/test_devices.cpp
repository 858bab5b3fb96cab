#include <gtest/gtest.h>

#include <cmath>

#include "sw/circuit/device_models.h"

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
