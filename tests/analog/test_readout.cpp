// Programmed crossbars read out with another configuration (AnalogLayer::set_readout): only the
// ADCs and calibration change, and the layer equals one programmed from scratch with that
// configuration, bit for bit (the reference: a whole program() of its own).
#include <gtest/gtest.h>

#include <algorithm>
#include <functional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "sw/analog/analog_layer.h"
#include "sw/analog/synthetic.h"

using namespace xbarsim;

namespace {

using Change = std::pair<std::string, std::function<void(AnalogConfig&)>>;

/// Paper parameters (wire resistance), partitioned into 16 x 6 crossbars, 6-bit DAC, 8-bit ADC,
/// programming noise: every programming step does something.
AnalogConfig base_config() {
  AnalogConfig c;
  c.set_method("conversion+calibration", "test");
  c.mapping.max_rows = 16;
  c.mapping.max_cols = 6;
  c.converters.dac_bits = 6;
  c.converters.adc_bits = 8;
  c.device.kind = DeviceKind::Constant;
  c.device.program_sigma_s = 2e-7;
  return c;
}

bool identical(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) {
  return a.rows() == b.rows() && a.cols() == b.cols() && (a.array() == b.array()).all();
}

/// Programs `base`, then reads it out with every change in turn (each from the previous one's
/// readout, as an exploration's group does), and checks each against a layer programmed from
/// scratch with that configuration; each change must change the outputs unless `no_effect`.
void expect_readouts_equal_fresh_programming(const AnalogConfig& base, const std::vector<Change>& changes, int rows,
                                             int cols, bool signed_inputs,
                                             const std::vector<std::string>& no_effect = {}) {
  const Eigen::MatrixXd w = synthetic_kernel("gaussian", rows, cols, 21);
  Eigen::MatrixXd calib = synthetic_inputs(40, rows, 0.4, 1.0, 22);
  Eigen::MatrixXd x = synthetic_inputs(25, rows, 0.4, 1.0, 23);
  if (signed_inputs)
    for (Eigen::Index k = 0; k < x.size(); k += 3) {
      x.data()[k] = -x.data()[k];
      calib.data()[k % calib.size()] = -calib.data()[k % calib.size()];
    }
  AnalogLayer reused(base, w, 1.0, signed_inputs, 5);
  reused.program(calib);
  Eigen::MatrixXd previous = reused.forward(x);
  for (const Change& change : changes) {
    AnalogConfig c = base;
    change.second(c);
    ASSERT_TRUE(programs_alike(base, c)) << change.first;
    reused.set_readout(c, calib);
    AnalogLayer fresh(c, w, 1.0, signed_inputs, 5);
    fresh.program(calib);
    const Eigen::MatrixXd y = reused.forward(x);
    EXPECT_TRUE(identical(y, fresh.forward(x))) << change.first;
    // The float datapath (network inference) too.
    const AnalogLayer::RowMat<float> xf = x.cast<float>();
    AnalogLayer::Mat<float> yr, yf;
    reused.forward<float>(xf, yr);
    fresh.forward<float>(xf, yf);
    EXPECT_TRUE((yr.array() == yf.array()).all()) << change.first;
    if (std::find(no_effect.begin(), no_effect.end(), change.first) == no_effect.end()) {
      EXPECT_FALSE(identical(y, previous)) << change.first << ": the readout changed nothing";
    }
    previous = y;
  }
}

}  // namespace

TEST(Readout, AnotherReadoutEqualsProgrammingFromScratch) {
  const std::vector<Change> changes = {
      {"adc_bits 4", [](AnalogConfig& c) { c.converters.adc_bits = 4; }},
      {"adc_margin 0.3", [](AnalogConfig& c) { c.converters.adc_margin = 0.3; }},
      {"no offset subtraction", [](AnalogConfig& c) { c.converters.adc_offset_subtraction = false; }},
      {"adc_columns_per_adc 2", [](AnalogConfig& c) { c.converters.adc_columns_per_adc = 2; }},
      {"conversion without calibration", [](AnalogConfig& c) { c.set_method("conversion", "test"); }},
      {"no ADC", [](AnalogConfig& c) { c.converters.adc_bits = 0; }},
      {"adc_bits 8 again", [](AnalogConfig& c) { c.converters.adc_bits = 8; }},
  };
  expect_readouts_equal_fresh_programming(base_config(), changes, 40, 13, false, {"adc_columns_per_adc 2"});
  // Signed inputs, differential pairs, matrix conversion.
  AnalogConfig m = base_config();
  m.set_method("matrix-conversion+calibration", "test");
  m.mapping.negative = NegativeWeights::Differential;
  expect_readouts_equal_fresh_programming(
      m,
      {{"adc_bits 5", [](AnalogConfig& c) { c.converters.adc_bits = 5; }},
       {"matrix conversion without calibration", [](AnalogConfig& c) { c.set_method("matrix-conversion", "test"); }}},
      24, 7, true);
}

TEST(Readout, BitSerialReadsAndTheFullRange) {
  // Bit-serial inputs (6 bits in 2-bit slices) on 2-bit cells: per-read and full ADC ranges.
  AnalogConfig c = base_config();
  c.converters.input_bits = 6;
  c.converters.dac_bits = 2;
  c.mapping.cell_bits = 2;
  c.mapping.weight_bits = 4;
  expect_readouts_equal_fresh_programming(
      c,
      {{"per_read", [](AnalogConfig& a) { a.converters.adc_range = AdcRange::PerRead; }},
       {"full", [](AnalogConfig& a) { a.converters.adc_range = AdcRange::Full; }},
       {"full, 5 bits",
        [](AnalogConfig& a) {
          a.converters.adc_range = AdcRange::Full;
          a.converters.adc_bits = 5;
        }}},
      30, 5, false);
}

TEST(Readout, NonlinearCellsReadOutThroughTheirSolver) {
  AnalogConfig c = base_config();
  c.xbar.memristor.model = MemristorModel::Sinh;
  c.mapping.max_rows = 8;
  c.mapping.max_cols = 4;
  expect_readouts_equal_fresh_programming(c,
                                          {{"adc_bits 5", [](AnalogConfig& a) { a.converters.adc_bits = 5; }},
                                           {"adc_margin 0", [](AnalogConfig& a) { a.converters.adc_margin = 0; }}},
                                          12, 5, false);
}

TEST(Readout, WhatProgramsIsNotAReadout) {
  const AnalogConfig a = base_config();
  const std::vector<Change> programs = {
      {"r_wire", [](AnalogConfig& c) { c.xbar.r_wire_ohm = 2; }},
      {"g_max", [](AnalogConfig& c) { c.xbar.g_max_s *= 0.9; }},
      {"v_in_max", [](AnalogConfig& c) { c.xbar.v_in_max_v = 0.3; }},
      {"memristor", [](AnalogConfig& c) { c.xbar.memristor.model = MemristorModel::Sinh; }},
      {"memristor k", [](AnalogConfig& c) { c.xbar.memristor.k_per_v = 4; }},
      {"transistor", [](AnalogConfig& c) { c.xbar.transistor.model = TransistorModel::Linear; }},
      {"solver tolerance", [](AnalogConfig& c) { c.solver.tolerance = 1e-10; }},
      {"solver method", [](AnalogConfig& c) { c.solver.method = SolverMethod::Direct; }},
      {"max_rows", [](AnalogConfig& c) { c.mapping.max_rows = 32; }},
      {"max_cols", [](AnalogConfig& c) { c.mapping.max_cols = 8; }},
      {"g_headroom", [](AnalogConfig& c) { c.mapping.g_headroom = 0.1; }},
      {"negative", [](AnalogConfig& c) { c.mapping.negative = NegativeWeights::Differential; }},
      {"sum_x", [](AnalogConfig& c) { c.mapping.sum_x = SumX::Analog; }},
      {"cell_bits", [](AnalogConfig& c) { c.mapping.cell_bits = 2; }},
      {"weight_bits", [](AnalogConfig& c) { c.mapping.weight_bits = 6; }},
      {"conversion kind", [](AnalogConfig& c) { c.set_method("calibration", "test"); }},
      {"conversion amplitude", [](AnalogConfig& c) { c.conversion.amplitude = 0.2; }},
      {"conversion signal", [](AnalogConfig& c) { c.conversion.signal = ConversionSignal::MeanInput; }},
      {"calibration samples", [](AnalogConfig& c) { c.calibration.samples = 20; }},
      {"calibration signal", [](AnalogConfig& c) { c.calibration.signal = CalibrationSignal::Random; }},
      {"calibration seed", [](AnalogConfig& c) { c.calibration.seed = 8; }},
      {"dac_bits", [](AnalogConfig& c) { c.converters.dac_bits = 7; }},
      {"input_bits", [](AnalogConfig& c) { c.converters.input_bits = 8; }},
      {"dac_predistortion", [](AnalogConfig& c) { c.converters.dac_predistortion = true; }},
      {"device programming sigma", [](AnalogConfig& c) { c.device.program_sigma_s = 1e-7; }},
      {"device read sigma", [](AnalogConfig& c) { c.device.read_sigma_s = 1e-7; }},
      {"device seed", [](AnalogConfig& c) { c.device.seed = 12; }},
      {"device faults", [](AnalogConfig& c) { c.device.stuck_gmin = 0.01; }},
      {"readout noise", [](AnalogConfig& c) { c.converters.readout_noise_a = 1e-9; }},
  };
  const Eigen::MatrixXd w = synthetic_kernel("gaussian", 20, 6, 31);
  AnalogLayer layer(a, w, 1.0, false);
  EXPECT_THROW(layer.set_readout(a, Eigen::MatrixXd()), std::invalid_argument);  // nothing programmed
  layer.program(Eigen::MatrixXd());
  for (const Change& change : programs) {
    AnalogConfig b = a;
    change.second(b);
    EXPECT_FALSE(programs_alike(a, b)) << change.first;
    EXPECT_THROW(layer.set_readout(b, Eigen::MatrixXd()), std::invalid_argument) << change.first;
  }
  AnalogConfig threads = a;
  threads.solver.threads = 3;
  EXPECT_TRUE(programs_alike(a, threads));
}

TEST(Readout, AFailedReadoutKeepsThePreviousOne) {
  const AnalogConfig a = base_config();
  const Eigen::MatrixXd w = synthetic_kernel("gaussian", 20, 6, 41);
  const Eigen::MatrixXd x = synthetic_inputs(10, 20, 0.4, 1.0, 42);
  AnalogLayer layer(a, w, 1.0, false);
  layer.program(Eigen::MatrixXd());
  const Eigen::MatrixXd before = layer.forward(x);
  AnalogConfig b = a;
  b.converters.adc_bits = 3;
  EXPECT_THROW(layer.set_readout(b, Eigen::MatrixXd::Ones(5, 7)), InputError);  // calibration rows of 7 values
  EXPECT_EQ(layer.config().converters.adc_bits, 8);
  EXPECT_TRUE(identical(layer.forward(x), before));
}
