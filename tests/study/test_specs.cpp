// Configuration parsed once into typed specs: every key of configs/default.yaml is read by
// some spec (no dead keys), and every key rejects a bad value with a message naming it.
#include <gtest/gtest.h>

#include "sw/study/run_spec.h"

using namespace xbarsim;

TEST(Specs, EveryDefaultKeyIsRead) {
  const ConfigTree cfg;
  parse_run_spec(cfg);
  const std::set<std::string> read = cfg.read_keys();
  const std::vector<std::string> keys = cfg.leaf_keys();
  EXPECT_GT(keys.size(), 60u);
  for (const auto& k : keys) EXPECT_TRUE(read.count(k)) << "configuration key '" << k << "' is never read";
}

TEST(Specs, EveryKeyRejectsABadValueNamingIt) {
  for (const auto& key : ConfigTree().leaf_keys()) {
    const ConfigTree cfg = ConfigTree::load("", {key + "=bogus_value"});
    try {
      parse_run_spec(cfg);
      ADD_FAILURE() << key << " accepted 'bogus_value'";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(key), std::string::npos) << e.what();
    }
  }
}

TEST(Specs, EnumsNotStrings) {
  const RunSpec r = parse_run_spec(ConfigTree::load(
      "",
      {"mapping.negative=differential", "mapping.sum_x=analog", "mitigation.method=matrix-conversion",
       "conversion.signal=mean_input", "calibration.signal=random", "solver.method=direct", "study.kernel=ternary"}));
  const AnalogConfig& ac = r.design.ac;
  EXPECT_EQ(ac.mapping.negative, NegativeWeights::Differential);
  EXPECT_EQ(ac.mapping.sum_x, SumX::Analog);
  EXPECT_EQ(ac.mitigation.conversion(), ConversionKind::Matrix);
  EXPECT_FALSE(ac.mitigation.calibrate());
  EXPECT_EQ(ac.conversion.signal, ConversionSignal::MeanInput);
  EXPECT_EQ(ac.calibration.signal, CalibrationSignal::Random);
  EXPECT_EQ(ac.solver.method, SolverMethod::Direct);
  EXPECT_EQ(r.study.kernel, KernelKind::Ternary);
  // A differential crossbar of 128 physical columns holds 64 weight columns; with the
  // sum(X) column, 63.
  EXPECT_EQ(ac.mapping.logical_columns_per_crossbar(), 63);
  EXPECT_THROW(parse_run_spec(ConfigTree::load(
                   "", {"mapping.max_cols=2", "mapping.negative=differential", "mapping.sum_x=analog"})),
               InputError);
}
