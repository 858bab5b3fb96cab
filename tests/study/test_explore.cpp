// Design-space exploration pieces against hand-made cases: the Pareto front, the points of a
// space, a point's identity, the resumable journal and the explore.* checks.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>

#include "sw/common/errors.h"
#include "sw/common/input_file.h"
#include "sw/study/eval_study.h"
#include "sw/study/explore.h"

using namespace xbarsim;

namespace {
const double NaN = std::nan("");
ConfigTree cfg_with(const std::vector<std::string>& sets) { return ConfigTree::load("", sets); }
}  // namespace

TEST(Pareto, HandMadeTable) {
  // (energy, area) to minimise. Row 1 dominates rows 0 and 3 (better in both), row 2 and row 4
  // trade off against it, row 5 equals row 2 (both stay), row 6 failed (NaN) and would
  // otherwise dominate everything.
  const std::vector<std::vector<double>> costs{{5, 5}, {2, 3}, {1, 6}, {2, 4}, {4, 1}, {1, 6}, {NaN, 0}};
  const std::vector<bool> f = pareto_front(costs);
  const std::vector<bool> expected{false, true, true, false, true, true, false};
  EXPECT_EQ(f, expected);
}

TEST(Pareto, AccuracyIsMaximised) {
  const nlohmann::json a = {{"accuracy", 0.9}, {"energy_uj_per_image", 2.0}};
  const nlohmann::json b = {{"accuracy", 0.8}, {"energy_uj_per_image", 2.0}};
  const nlohmann::json failed = {{"status", "failed"}};
  const std::vector<Objective> obj{Objective::Accuracy, Objective::Energy};
  std::vector<std::vector<double>> costs;
  for (const auto* r : {&a, &b, &failed}) costs.push_back({objective_cost(*r, obj[0]), objective_cost(*r, obj[1])});
  EXPECT_EQ(costs[0][0], -0.9);
  EXPECT_TRUE(std::isnan(costs[2][1]));
  EXPECT_EQ(pareto_front(costs), (std::vector<bool>{true, false, false}));
}

TEST(ExplorePoints, ProductAndZip) {
  const ConfigTree c = cfg_with({"converters.adc_bits=[4,6,8]", "mapping.max_rows=[64,128,256]"});
  EXPECT_EQ(explore_points(c, ExploreSpec::Combine::Product).size(), 9u);
  const auto zip = explore_points(c, ExploreSpec::Combine::Zip);
  ASSERT_EQ(zip.size(), 3u);
  for (size_t k = 0; k < 3; ++k) {
    ASSERT_EQ(zip[k].size(), 2u);
    std::map<std::string, std::string> v(zip[k].begin(), zip[k].end());
    EXPECT_EQ(v["converters.adc_bits"], std::vector<std::string>({"4", "6", "8"})[k]);
    EXPECT_EQ(v["mapping.max_rows"], std::vector<std::string>({"64", "128", "256"})[k]);
  }
  const ConfigTree bad = cfg_with({"converters.adc_bits=[4,6]", "mapping.max_rows=[64,128,256]"});
  try {
    explore_points(bad, ExploreSpec::Combine::Zip);
    FAIL() << "unequal lists accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("'converters.adc_bits' has 2"), std::string::npos) << e.what();
  }
}

TEST(ExplorePoints, KeyIgnoresThreadsButNotDesign) {
  const std::string a = point_key(cfg_with({"converters.adc_bits=6"}));
  EXPECT_EQ(a, point_key(cfg_with({"converters.adc_bits=6", "solver.threads=3"})));
  EXPECT_EQ(a, point_key(cfg_with({"converters.adc_bits=6", "explore.objectives=accuracy,area"})));
  EXPECT_NE(a, point_key(cfg_with({"converters.adc_bits=7"})));
  EXPECT_NE(a, point_key(cfg_with({"converters.adc_bits=6", "eval.images=10"})));
}

TEST(EvalJournal, RunKeyIgnoresTheImageRangeAndKnowsTheModelByItsContent) {
  const std::string a = ::testing::TempDir() + "xbarsim_key_a.onnx", b = ::testing::TempDir() + "xbarsim_key_b.onnx",
                    c = ::testing::TempDir() + "xbarsim_key_c.onnx";
  std::ofstream(a) << "model bytes";
  std::ofstream(b) << "model bytes";  // a copy elsewhere
  std::ofstream(c) << "model bytez";  // re-exported
  const ConfigTree cfg = cfg_with({"converters.adc_bits=6"});
  const std::string k = eval_run_key(cfg, file_id(a), "cifar10");
  EXPECT_EQ(
      k, eval_run_key(cfg_with({"converters.adc_bits=6", "eval.images=10", "eval.offset=5"}), file_id(a), "cifar10"));
  EXPECT_EQ(k, eval_run_key(cfg_with({"converters.adc_bits=6", "solver.threads=2"}), file_id(a), "cifar10"));
  EXPECT_EQ(k, eval_run_key(cfg, file_id(b), "cifar10"));
  EXPECT_NE(k, eval_run_key(cfg, file_id(c), "cifar10"));
  EXPECT_NE(k, eval_run_key(cfg, file_id(a), "mnist"));
  EXPECT_NE(k, eval_run_key(cfg_with({"converters.adc_bits=7"}), file_id(a), "cifar10"));
  EXPECT_NE(k, eval_run_key(cfg_with({"converters.adc_bits=6", "eval.calibration_images=100"}), file_id(a), "cifar10"));
  // A number is its value however it is written (a rerun with k=3.0 must not start over)...
  EXPECT_EQ(k, eval_run_key(cfg_with({"converters.adc_bits=6.0"}), file_id(a), "cifar10"));
  EXPECT_EQ(k, eval_run_key(cfg_with({"converters.adc_bits=6", "crossbar.r_wire=1e0", "crossbar.v_in_max=0.40"}),
                            file_id(a), "cifar10"));
  EXPECT_NE(k, eval_run_key(cfg_with({"converters.adc_bits=6", "crossbar.v_in_max=0.4000001"}), file_id(a), "cifar10"));
  // ... and sections that cannot change an image's outcome do not count.
  EXPECT_EQ(k, eval_run_key(cfg_with({"converters.adc_bits=6", "platform.clock_mhz=200", "study.rows=16",
                                      "explore.objectives=accuracy,area"}),
                            file_id(a), "cifar10"));
}

TEST(PointKey, NumbersAreCanonicalOtherTextIsKept) {
  for (bool integer : {false, true}) {
    EXPECT_EQ(canonical_value("3.0", integer), "3");
    EXPECT_EQ(canonical_value("3e0", integer), "3");
    EXPECT_EQ(canonical_value("-0", integer), "0");
    EXPECT_EQ(canonical_value("08", integer), "8");
    EXPECT_EQ(canonical_value("+3", integer), "3");
    for (const char* kept : {"", "all", "0x10", "1e400", "nan", "1,2", "3 ", "sinh"})
      EXPECT_EQ(canonical_value(kept, integer), kept);
  }
  EXPECT_EQ(canonical_value("0.40", false), "0.4");
  EXPECT_EQ(canonical_value("1e-300", false), "1e-300");
  EXPECT_EQ(canonical_value("0.1", false), "0.1");
  // A real key: one text however the value is written, the defaults' form (r_on: 1000.0) kept.
  for (const char* r_on : {"1000", "1000.0", "1e3"}) EXPECT_EQ(canonical_value(r_on, false), "1e+03") << r_on;
  // An integer key: whole decimals are the integer get_int reads (item 8 of issue 23).
  EXPECT_EQ(canonical_value("1e6", true), "1000000");
  EXPECT_EQ(canonical_value("1000000", true), "1000000");
  EXPECT_EQ(canonical_value("8.5", true), "8.5");  // not an integer: refused by get_int, kept apart
  // Integers beyond 2^53 stay exact: two seeds must not share a key.
  EXPECT_EQ(canonical_value("1000000000000000001", true), "1000000000000000001");
  EXPECT_NE(point_key(cfg_with({"calibration.seed=1000000000000000000"})),
            point_key(cfg_with({"calibration.seed=1000000000000000001"})));
  EXPECT_EQ(std::stod(canonical_value("3.3333333333333333e-6", false)), 3.3333333333333333e-6);  // round-trips
  EXPECT_TRUE(ConfigTree::is_integer("mapping.max_rows"));
  EXPECT_TRUE(ConfigTree::is_integer("eval.images"));  // "all", or a whole number
  EXPECT_TRUE(ConfigTree::is_integer("calibration.seed"));
  EXPECT_FALSE(ConfigTree::is_integer("crossbar.transistor.r_on"));
  EXPECT_FALSE(ConfigTree::is_integer("crossbar.r_wire"));
  EXPECT_EQ(point_key(cfg_with({"study.vectors=1e6"})), point_key(cfg_with({"study.vectors=1000000"})));
  EXPECT_EQ(point_key(cfg_with({"crossbar.transistor.r_on=1000"})), point_key(cfg_with({})));
  // explore's point key too: a space written 1.0 finds the points it journaled as 1
  EXPECT_EQ(point_key(cfg_with({"crossbar.r_wire=1.0"})), point_key(cfg_with({"crossbar.r_wire=1"})));
  EXPECT_NE(point_key(cfg_with({"crossbar.r_wire=1.0"})), point_key(cfg_with({"crossbar.r_wire=2"})));
  // Only numeric keys: a path that reads as a number is another path.
  EXPECT_NE(point_key(cfg_with({"data.dir=1e3"})), point_key(cfg_with({"data.dir=1000"})));
  EXPECT_TRUE(ConfigTree::is_numeric("crossbar.r_wire"));
  EXPECT_TRUE(ConfigTree::is_numeric("converters.dac_bits"));
  EXPECT_FALSE(ConfigTree::is_numeric("data.dir"));
}

TEST(ExploreSpec, ChecksNameTheKey) {
  auto message = [](const std::vector<std::string>& sets) {
    try {
      parse_explore_spec(cfg_with(sets));
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_NE(message({"explore.objectives=accuracy,speed"}).find("'speed'"), std::string::npos);
  EXPECT_NE(message({"explore.objectives=accuracy"}).find("fewer than two"), std::string::npos);
  EXPECT_NE(message({"explore.color_by=converters.adc_bits"}).find("explore.color_by"), std::string::npos);
  EXPECT_NE(message({"eval.images=[10,20]"}).find("eval.images"), std::string::npos);
  EXPECT_EQ(message({"converters.adc_bits=[4,8]", "explore.color_by=converters.adc_bits"}), "");
  const ExploreSpec s = parse_explore_spec(cfg_with({"explore.objectives= energy , accuracy"}));
  EXPECT_EQ(s.objectives, (std::vector<Objective>{Objective::Energy, Objective::Accuracy}));
}

namespace {
/// A journal kind for these tests: a line is one of its own when it has a text "key".
JournalKind test_kind() {
  return {"example journal", "--example",
          [](const nlohmann::json& r) { return r.contains("key") && r["key"].is_string(); }};
}
}  // namespace

TEST(ResultJournal, AppendsRepairsAndSkipsBadLines) {
  const std::string path = ::testing::TempDir() + "xbarsim_journal_test.jsonl";
  std::remove(path.c_str());
  const ResultJournal j(path, test_kind());
  EXPECT_TRUE(j.read().empty());  // no file yet
  j.append({{"key", "a"}, {"accuracy", 0.5}});
  j.append({{"key", "b"}, {"accuracy", 0.25}});
  {
    std::ofstream(path, std::ios::app) << "not json\n{\"key\": \"c\", \"accur";  // a garbage line, then a cut-off one
  }
  j.repair();
  int skipped = 0;
  const auto rows = j.read(&skipped);
  ASSERT_EQ(rows.size(), 2u);
  EXPECT_EQ(rows[1].row["key"], "b");
  EXPECT_EQ(rows[1].row["accuracy"], 0.25);
  EXPECT_EQ(rows[1].number, 2);
  EXPECT_EQ(skipped, 1);
  j.append({{"key", "c"}});  // lands on its own line after the repair
  EXPECT_EQ(j.read().size(), 3u);
  EXPECT_EQ(j.read()[2].number, 4);  // after the garbage line
  std::remove(path.c_str());
}

TEST(ResultJournal, AFileThatIsNotOneOfItsKindIsLeftAsItIs) {
  // Before: any file given as a journal lost its last line (repair) and got lines appended.
  const std::string path = ::testing::TempDir() + "xbarsim_not_a_journal.txt";
  for (const std::string& text : {std::string("a\nb"), std::string("a,b\n1,2\n"), std::string("{\"x\": 1}\n"),
                                  std::string("\x08\x01\x12\x04onnx"), std::string(2u << 20, '{')}) {
    std::ofstream(path, std::ios::binary) << text;
    try {
      ResultJournal j(path, test_kind());
      FAIL() << "accepted " << text.substr(0, 20);
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("is not an example journal"), std::string::npos) << e.what();
    }
    std::ifstream in(path, std::ios::binary);
    EXPECT_EQ(std::string(std::istreambuf_iterator<char>(in), {}), text);
  }
  // Ours: an empty file, a journal, and a first line a kill cut short.
  for (const std::string& text : {std::string(), std::string("{\"key\":\"a\"}\nrest"), std::string("{\"key\":\"a")}) {
    std::ofstream(path, std::ios::binary) << text;
    EXPECT_NO_THROW(ResultJournal(path, test_kind())) << text;
  }
  // Never a file the run reads in another role (`path` was opened as a journal above, and
  // stays while this runs: the registry knows files by their inode, which a new file could
  // reuse once it is gone).
  const std::string model = ::testing::TempDir() + "xbarsim_registered_input.jsonl";
  std::ofstream(model, std::ios::binary) << "{\"key\":\"a\"}\n";
  register_input(model, "the model");
  try {
    ResultJournal j(model, test_kind());
    FAIL() << "a registered input accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("is the model this run reads"), std::string::npos) << e.what();
  }
  std::remove(model.c_str());
  std::remove(path.c_str());
}

TEST(ResultJournalFile, MustBeARegularFile) {
  // Read back and appended to: /dev/zero never ends (it was reported as out of memory),
  // /dev/null loses every line.
  for (const char* special : {"/dev/null", "/dev/zero"}) {
    try {
      ResultJournal j(special, test_kind());
      FAIL() << special << " accepted";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("not a regular file"), std::string::npos) << e.what();
    }
  }
  // A new journal is created at once: a place that refuses files fails before the work.
  const std::string fresh = ::testing::TempDir() + "xbarsim_fresh_journal.jsonl";
  std::remove(fresh.c_str());
  EXPECT_NO_THROW(ResultJournal(fresh, test_kind()));
  EXPECT_TRUE(std::ifstream(fresh).good());
  std::remove(fresh.c_str());
  try {
    ResultJournal j("/proc/xbarsim_journal.jsonl", test_kind());
    FAIL() << "/proc accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("cannot write the example journal"), std::string::npos) << e.what();
  }
}

// Points that differ only in what is read out after programming (the ADCs, whether the method
// calibrates, the platform) program equal crossbars: one programming key; anything that changes
// the conductances, the conversion or the programming inputs is another.
TEST(ProgrammingKey, ReadoutKeysShareAKeyProgrammingKeysDoNot) {
  const auto key = [](const std::vector<std::string>& sets) { return programming_key(cfg_with(sets), "m", "d"); };
  const std::string a = key({});
  for (const char* same :
       {"converters.adc_bits=4", "converters.adc_bits=none", "converters.adc_margin=0.2",
        "converters.adc_offset_subtraction=false", "converters.adc_columns_per_adc=32", "mitigation.method=conversion",
        "platform.clock_mhz=200", "platform.schedule=pipelined", "architecture.machine=isaac-ce",
        "components.library=isaac", "solver.threads=3", "study.rows=10", "device.time_s=86400",
        "device.compensation=global"})
    EXPECT_EQ(key({same}), a) << same;
  EXPECT_EQ(key({"converters.adc_range=per_read", "converters.input_bits=8", "converters.dac_bits=2"}),
            key({"converters.input_bits=8", "converters.dac_bits=2"}));
  for (const char* other :
       {"mitigation.method=calibration", "mitigation.method=matrix-conversion", "mapping.g_headroom=0.1",
        "mapping.max_rows=64", "mapping.weight_bits=6", "crossbar.cell_bits=3", "crossbar.r_wire=2",
        "converters.dac_bits=6", "converters.input_bits=8", "converters.dac_predistortion=true", "device.model=constant",
        "device.seed=3", "device.stuck_at_gmin=0.01", "converters.readout_noise_na=1", "device.model=rram-cmo", "calibration.samples=20", "calibration.seed=1", "conversion.amplitude=0.2",
        "solver.tolerance=1e-10"})
    EXPECT_NE(key({other}), a) << other;
  EXPECT_EQ(key({"mitigation.method=none"}), key({"mitigation.method=calibration"}));
  EXPECT_EQ(key({"mitigation.method=matrix-conversion"}), key({"mitigation.method=matrix-conversion+calibration"}));
  EXPECT_NE(programming_key(cfg_with({}), "m", "d"), programming_key(cfg_with({}), "other model", "d"));
}

// The shares of the ranks: every pending point once, a group's points together, each group
// reaching as few ranks as contiguous shares allow (programmings <= groups + ranks - 1), share
// sizes within one of each other.
TEST(ExploreShare, GroupByGroupInContiguousShares) {
  // Space of 9 points in 3 groups, interleaved (a x b with the group from b); point 4 is done.
  const std::vector<std::string> group_of = {"A", "B", "C", "A", "B", "C", "A", "B", "C"};
  const std::vector<size_t> pending = {0, 1, 2, 3, 5, 6, 7, 8};
  EXPECT_EQ(explore_share(pending, group_of, 0, 1), (std::vector<size_t>{0, 3, 6, 1, 7, 2, 5, 8}));
  for (int ranks = 1; ranks <= 9; ++ranks) {
    std::vector<size_t> all;
    int programmings = 0;
    for (int r = 0; r < ranks; ++r) {
      const std::vector<size_t> share = explore_share(pending, group_of, r, ranks);
      EXPECT_LE(share.size(), pending.size() / ranks + 1) << ranks;
      EXPECT_GE(share.size(), pending.size() / ranks) << ranks;
      for (size_t i = 0; i < share.size(); ++i) programmings += i == 0 || group_of[share[i]] != group_of[share[i - 1]];
      all.insert(all.end(), share.begin(), share.end());
    }
    EXPECT_EQ(all, explore_share(pending, group_of, 0, 1)) << ranks;  // the shares cut one order
    EXPECT_LE(programmings, 3 + ranks - 1) << ranks;
  }
  EXPECT_EQ(explore_share(pending, group_of, 0, 2), (std::vector<size_t>{0, 3, 6, 1}));
  EXPECT_EQ(explore_share(pending, group_of, 1, 2), (std::vector<size_t>{7, 2, 5, 8}));
}
