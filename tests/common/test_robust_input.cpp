// Issue: bad input never crashes or passes silently (configuration, numbers, output files).
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <climits>
#include <cstdio>
#include <fstream>
#include <sstream>

#include "sw/common/config.h"
#include "sw/common/csv.h"
#include "sw/common/output_file.h"
#include "sw/common/parse.h"

using namespace xbarsim;

namespace {

/// The InputError message of `f`, or a failure when it does not throw one.
template <class F>
std::string input_error(F f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  ADD_FAILURE() << "expected InputError";
  return "";
}

#define EXPECT_CONTAINS(text, part) EXPECT_NE(std::string(text).find(part), std::string::npos) << (text)

std::string tmp_file(const std::string& name, const std::string& text) {
  const std::string path = "/tmp/xbarsim_robust_" + name;
  std::ofstream(path, std::ios::binary) << text;
  return path;
}

}  // namespace

TEST(CheckedNumbers, WholeTextFiniteAndInRange) {
  double d = 0;
  long long i = 0;
  EXPECT_TRUE(parse_finite_double(" 1e-320 ", d));  // subnormal: a real value, not an error
  EXPECT_GT(d, 0);
  EXPECT_FALSE(parse_finite_double("1e400", d));
  EXPECT_FALSE(parse_finite_double("nan", d));
  EXPECT_FALSE(parse_finite_double("inf", d));
  EXPECT_FALSE(parse_finite_double("1.5x", d));
  EXPECT_FALSE(parse_finite_double("", d));
  EXPECT_TRUE(parse_int64("4294967297", i));
  EXPECT_EQ(i, 4294967297LL);
  EXPECT_FALSE(parse_int64("99999999999999999999", i));
  EXPECT_FALSE(parse_int64("12.5", i));
  EXPECT_TRUE(parse_finite_ratio("1/255", d));
  EXPECT_DOUBLE_EQ(d, 1.0 / 255);
  EXPECT_FALSE(parse_finite_ratio("1/0", d));
  EXPECT_FALSE(parse_finite_ratio("abc", d));
}

TEST(ConfigRanges, EveryNumericDefaultHasADocumentedRange) {
  // Every key whose default is a number is read through get_int/get_double, which throw
  // std::logic_error for a key without a range: reading each proves the range exists.
  ConfigTree cfg;
  std::istringstream in(default_config_yaml());
  std::string line;
  std::vector<std::pair<size_t, std::string>> path;
  int numeric = 0;
  while (std::getline(in, line)) {
    const auto indent = line.find_first_not_of(' ');
    if (indent == std::string::npos || line[indent] == '#') continue;
    const auto colon = line.find(':', indent);
    if (colon == std::string::npos) continue;
    while (!path.empty() && path.back().first >= indent) path.pop_back();
    std::string key;
    for (const auto& p : path) key += p.second + ".";
    key += line.substr(indent, colon - indent);
    std::string value = line.substr(colon + 1, line.find('#', colon) - colon - 1);
    value.erase(0, value.find_first_not_of(' '));
    value.erase(value.find_last_not_of(' ') + 1);
    if (value.empty()) {
      path.emplace_back(indent, line.substr(indent, colon - indent));
      continue;
    }
    double d = 0;
    if (!parse_finite_double(value, d)) continue;
    ++numeric;
    EXPECT_NO_THROW(cfg.get_double(key)) << key;
  }
  EXPECT_GT(numeric, 40);
}

TEST(ConfigRanges, OutOfRangeAndHugeIntegersNameKeyRangeAndValue) {
  const std::pair<const char*, const char*> bad[] = {
      {"study.vectors=2147483648", "study.vectors"},
      {"study.vectors=4294967297", "study.vectors"},
      {"solver.max_iterations=4294967297", "solver.max_iterations"},
      {"platform.replication=2147483648", "platform.replication"},
      {"platform.clock_mhz=1e300", "platform.clock_mhz"},
      {"eval.images=4294967298", "eval.images"},
      {"eval.offset=4294967296", "eval.offset"},
      {"study.sparsity=1", "study.sparsity"},
      {"crossbar.r_wire=0", "crossbar.r_wire"},
  };
  for (const auto& b : bad) {
    const ConfigTree cfg = ConfigTree::load("", {b.first});
    const std::string key = b.second;
    const std::string msg = input_error([&] {
      if (key == "platform.clock_mhz" || key == "study.sparsity" || key == "crossbar.r_wire")
        cfg.get_double(key);
      else
        cfg.get_int32(key);
    });
    EXPECT_CONTAINS(msg, key);
    EXPECT_CONTAINS(msg, "must be in");
    EXPECT_CONTAINS(msg, std::string(b.first).substr(key.size() + 1));
  }
  EXPECT_EQ(ConfigTree::load("", {"study.vectors=10000000"}).get_int32("study.vectors"), 10000000);
}

TEST(ConfigYaml, DuplicateKeysSecondDocumentsAndComplexKeysAreRejectedWithTheLine) {
  ConfigTree cfg;
  EXPECT_CONTAINS(input_error([&] { cfg.merge_yaml_text("study:\n  rows: 8\n  rows: 9\n", "f.yaml"); }),
                  "f.yaml:3: duplicate key 'rows'");
  EXPECT_CONTAINS(input_error([&] { cfg.merge_yaml_text("study:\n  rows: 8\n---\nstudy:\n  rows: 9\n", "f.yaml"); }),
                  "f.yaml:3: a second YAML document");
  EXPECT_CONTAINS(input_error([&] { cfg.merge_yaml_text("? [a, b] : 1\n", "f.yaml"); }), "f.yaml:1: a key must be");
  EXPECT_CONTAINS(input_error([&] { cfg.set("study.rows", "{? [a]: 1}"); }), "study.rows");
  // A single document with distinct keys still merges.
  cfg.merge_yaml_text("---\nstudy:\n  rows: 8\n  cols: 9\n", "f.yaml");
  EXPECT_EQ(cfg.get_int("study.cols"), 9);
}

TEST(ConfigYaml, AnchorBombIsCountedNotExpanded) {
  // One anchor of 10 values used by 9 keys: 10^9 sweep points, counted without expanding.
  ConfigTree cfg;
  cfg.merge_yaml_text(
      "study:\n  rows: &v [1,2,3,4,5,6,7,8,9,10]\n  cols: *v\n  vectors: *v\n  seed: *v\n"
      "calibration:\n  samples: *v\n  seed: *v\ndevice:\n  seed: *v\n  time_s: *v\nsolver:\n  threads: *v\n",
      "bomb.yaml");
  EXPECT_EQ(cfg.sweep_points(), 1000000000ULL);
}

TEST(CsvReader, ByteOrderMarkSubnormalsAndOverflow) {
  const Eigen::MatrixXd m = read_csv_matrix(tmp_file("bom.csv",
                                                     "\xEF\xBB\xBF"
                                                     "1,2\n3,1e-320\n"));
  EXPECT_EQ(m(0, 0), 1.0);
  EXPECT_GT(m(1, 1), 0.0);
  EXPECT_CONTAINS(input_error([] { read_csv_matrix(tmp_file("big.csv", "1,1e400\n")); }),
                  "'1e400' is not a finite number");
}

TEST(OutputFiles, CheckedBeforeWorkAndWrittenAtomically) {
  const std::string in = tmp_file("in.csv", "1,2\n");
  EXPECT_CONTAINS(input_error([&] { check_output_path(in, "--json", {in}); }), "refusing to overwrite");
  EXPECT_CONTAINS(input_error([&] { check_output_path("/tmp", "--json", {}); }), "is a directory");
  EXPECT_CONTAINS(input_error([&] { check_output_path("/nonexistent/dir/x.json", "--json", {}); }), "does not exist");
  EXPECT_CONTAINS(input_error([&] { check_output_path("", "--json", {}); }), "needs a file name");
  EXPECT_NO_THROW(check_output_path("/tmp/xbarsim_robust_new.json", "--json", {in}));
  // A full disk is an error, not a silent success.
  EXPECT_CONTAINS(input_error([] { write_text_file("/dev/full", std::string(1 << 16, 'x')); }), "/dev/full");
  // Without commit() the target is untouched; with it, it holds the whole text.
  const std::string out = tmp_file("out.txt", "old");
  {
    OutputFile f(out);
    f.stream() << "new";
  }
  std::ifstream a(out);
  EXPECT_EQ(std::string(std::istreambuf_iterator<char>(a), {}), "old");
  write_text_file(out, "new");
  std::ifstream b(out);
  EXPECT_EQ(std::string(std::istreambuf_iterator<char>(b), {}), "new");
}
