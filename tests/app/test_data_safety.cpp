// Inputs are sacred, and bad input never crashes (issue 23): every command against files the
// tests write themselves (a tiny CIFAR-shaped network and data set, tests/app/tiny_network.h),
// so nothing here needs the shared data. Each numbered test is one item of the issue and
// failed before its fix (data lost with exit 0, a signal, an internal error or a silently
// wrong number).
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "tests/app/cli_test_util.h"
#include "tests/app/tiny_network.h"
#include "tests/npz_writer.h"

namespace {

using xbarsim_test::Result;

std::string slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

/// The lines of a journal, parsed.
std::vector<nlohmann::json> json_lines(const std::string& path) {
  std::vector<nlohmann::json> lines;
  std::ifstream in(path);
  for (std::string l; std::getline(in, l);) lines.push_back(nlohmann::json::parse(l));
  return lines;
}

void spit(const std::string& path, const std::string& text) { std::ofstream(path, std::ios::binary) << text; }

/// A folder of its own per test with the tiny network (models/tiny.onnx), its data
/// (data/cifar10, 16 images), a configuration naming both and a copy of the component library.
class Safety : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = ::testing::TempDir() + "xbarsim_safety_" + ::testing::UnitTest::GetInstance()->current_test_info()->name();
    std::system(("rm -rf '" + dir_ + "' && mkdir -p '" + dir_ + "/models'").c_str());
    xbarsim_test::write_tiny_cifar(dir_ + "/data", 16);
    xbarsim_test::write_tiny_model(model());
    spit(library(), slurp(std::string(XBARSIM_SOURCE_DIR) + "/configs/components/isaac_paper.yaml"));
    spit(config(), "data:\n  dir: " + dir_ + "/data\n  models_dir: " + dir_ + "/models\ncomponents:\n  library: " +
                       library() + "\neval:\n  calibration_images: 4\n  calibration_samples: 64\ncalibration:\n  samples: 10\n");
  }
  void TearDown() override {
    if (!HasFailure()) std::system(("rm -rf '" + dir_ + "'").c_str());
  }
  std::string path(const std::string& name) const { return dir_ + "/" + name; }
  std::string model() const { return path("models/tiny.onnx"); }
  std::string test_batch() const { return path("data/cifar10/test_batch.bin"); }
  std::string calib_batch() const { return path("data/cifar10/calib_batch.bin"); }
  std::string library() const { return path("lib.yaml"); }
  std::string config() const { return path("cfg.yaml"); }
  /// xbarsim ARGS with the configuration (stderr merged).
  Result run(const std::string& args, const std::string& prefix = "") const {
    const auto space = args.find(' ');
    return xbarsim_test::run_xbarsim(args.substr(0, space) + " --config " + config() + " " + args.substr(space + 1),
                                     prefix);
  }
  std::string dir_;
};

void expect_input_error(const Result& r, const std::string& part, const std::string& what) {
  EXPECT_EQ(r.code, 2) << what << "\n" << r.out;
  EXPECT_NE(r.out.find(part), std::string::npos) << what << ": no '" << part << "' in\n" << r.out;
  EXPECT_EQ(r.out.find("internal error"), std::string::npos) << what << "\n" << r.out;
}

const char kEval[] = "eval --model tiny --images 2";
const char kExplore[] = "explore --model tiny --images 2 --set converters.adc_bits=[6,8]";

}  // namespace

// "No command of xbarsim can truncate, overwrite or append to a file it reads in the same run":
// every output flag of every command, onto every file the command reads (typed on the command
// line or found through the configuration), is refused before any work, and the file is left
// byte for byte as it was.
TEST_F(Safety, NoOutputFlagCanWriteAFileTheRunReads) {
  // Journals of the other kind (what eval --journal and explore --out wrote), to be given to the
  // other command.
  ASSERT_EQ(run(std::string(kEval) + " --journal " + path("eval.jsonl")).code, 0);
  ASSERT_EQ(run(std::string(kExplore) + " --out " + path("explore.jsonl")).code, 0);
  spit(path("g.csv"), "5e-5,6e-5\n4e-5,3e-5\n");
  spit(path("v.csv"), "0.1,0.2\n");
  struct Command {
    std::string args;
    std::vector<std::string> outputs, inputs;
  };
  const std::string by_path = "--model " + model(), by_name = "--model tiny";
  const std::vector<std::string> network_inputs = {config(), model(), test_batch(), calib_batch(), library()};
  const std::vector<Command> commands = {
      {"eval " + by_path + " --images 2", {"--json", "--csv", "--report", "--journal"}, network_inputs},
      {"eval " + by_name + " --images 2", {"--json", "--journal"}, {model()}},
      {"eval " + by_path + " --images 2 --journal", {""}, {path("explore.jsonl")}},
      {"explore " + by_path + " --images 2", {"--out"}, network_inputs},
      {"explore " + by_path + " --images 2 --out " + path("new.jsonl"),
       {"--json", "--csv", "--report"},
       network_inputs},
      {"explore " + by_name + " --images 2", {"--out"}, {model()}},
      {"explore " + by_name + " --images 2 --out " + path("new.jsonl"), {"--json"}, {model()}},
      {"explore " + by_path + " --images 2 --out", {""}, {path("eval.jsonl")}},
      {"simulate " + by_path + " --dataset cifar10 --images 2",
       {"--json", "--csv", "--report", "--vcd"},
       network_inputs},
      {"simulate " + by_name + " --dataset cifar10", {"--json", "--vcd"}, {model()}},
      {"overhead " + by_path, {"--json", "--csv"}, {config(), model(), library()}},
      {"overhead " + by_name, {"--json"}, {model()}},
      {"xbar-study --set study.vectors=5", {"--json", "--csv", "--report"}, {config(), library()}},
      {"solve --conductances " + path("g.csv") + " --inputs " + path("v.csv"),
       {"--out", "--json", "--csv"},
       {config(), path("g.csv"), path("v.csv")}},
      {"netlist --conductances " + path("g.csv") + " --inputs " + path("v.csv"),
       {"--out"},
       {config(), path("g.csv"), path("v.csv")}},
  };
  int cases = 0;
  for (const Command& c : commands)
    for (const std::string& flag : c.outputs)
      for (const std::string& input : c.inputs) {
        const std::string before = slurp(input);
        ASSERT_FALSE(before.empty()) << input;
        const std::string what = c.args + " " + flag + " " + input;
        const Result r = run(c.args + " " + flag + (flag.empty() ? "" : " ") + input);
        EXPECT_EQ(r.code, 2) << what << "\n" << r.out;
        EXPECT_NE(r.out.find("refusing to"), std::string::npos) << what << "\n" << r.out;
        EXPECT_EQ(slurp(input), before) << what << ": the input changed";
        ++cases;
      }
  EXPECT_EQ(cases, 93);
}

TEST_F(Safety, Item1_ExploreOutOntoTheModelLeavesItIntact) {
  const std::string before = slurp(model());
  expect_input_error(run(std::string(kExplore) + " --out " + model()), "is the model this run reads", "item 1");
  EXPECT_EQ(slurp(model()), before);
}

TEST_F(Safety, Item2_AJournalThatIsNotOneIsLeftAsItIs) {
  for (const std::string& text : {std::string("a\nb"), std::string("a,b\n1,2\n"), std::string("{\"x\":1}\n")}) {
    spit(path("n.txt"), text);
    expect_input_error(run(std::string(kEval) + " --journal " + path("n.txt")), "is not an eval journal", text);
    EXPECT_EQ(slurp(path("n.txt")), text);
    expect_input_error(run(std::string(kExplore) + " --out " + path("n.txt")), "is not an explore results file", text);
    EXPECT_EQ(slurp(path("n.txt")), text);
  }
}

TEST_F(Safety, Item3_OutputsOntoFilesFoundThroughTheConfiguration) {
  // The model found by name through data.models_dir, the dataset through data.dir.
  for (const std::string& input : {model(), test_batch(), calib_batch()}) {
    const std::string before = slurp(input);
    expect_input_error(run(std::string(kEval) + " --json " + input), "refusing to overwrite", input);
    expect_input_error(run(std::string(kEval) + " --csv " + input), "refusing to overwrite", input);
    EXPECT_EQ(slurp(input), before);
  }
}

TEST_F(Safety, Item4_AVcdFileThatCannotBeCreatedIsAnInputErrorNotASignal) {
  expect_input_error(run("simulate --preset lenet --vcd /proc/xbarsim_x.vcd"), "cannot create it", "/proc");
  expect_input_error(run("simulate --preset lenet --vcd " + path(std::string(252, 'a') + ".vcd")), "File name too long",
                     "256 characters");
}

TEST_F(Safety, Item5And12_SimulateNeverRunsPastTheImagesItHas) {
  // 16 test images: 40 asked for, 4 calibration images (reading past the end crashed).
  const Result r = run("simulate --model tiny --dataset cifar10 --images 40 --timing ideal --json " + path("s.json"));
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("using images 0..15 (16 of the 40 images asked for)"), std::string::npos) << r.out;
  EXPECT_EQ(nlohmann::json::parse(slurp(path("s.json")))["images"], 16);
}

TEST_F(Safety, Item12_MnistSimulatesTheImagesItEvaluatesNotACalibrationImage) {
  if (!xbarsim_test::have_data()) GTEST_SKIP() << "shared data not found; test skipped";
  // Images 9000-9999 calibrate: 9001 asked for are the 9000 before them.
  const Result r = xbarsim_test::run_xbarsim(
      "simulate --model lenet_mnist --dataset mnist --images 9001 --timing ideal "
      "--set eval.calibration_images=4 --json " +
      path("m.json"));
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("using images 0..8999 (9000 of the 9001 images asked for)"), std::string::npos) << r.out;
  EXPECT_EQ(nlohmann::json::parse(slurp(path("m.json")))["images"], 9000);
}

TEST_F(Safety, Item6_AJournalLineWithMissingOrMistypedFieldsRunsThePointAgain) {
  ASSERT_EQ(run(std::string(kExplore) + " --out " + path("j.jsonl")).code, 0);
  const std::vector<nlohmann::json> lines = json_lines(path("j.jsonl"));
  ASSERT_EQ(lines.size(), 2u);
  nlohmann::json a = lines[0], b = lines[1];
  a.erase("label");
  b["status"] = "failed";  // without a reason
  spit(path("j.jsonl"), a.dump() + "\n" + b.dump() + "\n");
  const Result r = run(std::string(kExplore) + " --out " + path("j.jsonl") + " --json " + path("e.json"));
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("line 1: 'label' is not a text; the point runs again"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("line 2: a failed point's 'reason' is not a text"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("2 points, 0 already in"), std::string::npos) << r.out;
  for (const auto& p : nlohmann::json::parse(slurp(path("e.json")))["points"]) EXPECT_EQ(p["status"], "ok");
}

TEST_F(Safety, Item7_EndlessInputsAreRefusedWithTheirBound) {
  spit(path("g.csv"), "1e-4\n");
  expect_input_error(run("solve --conductances " + path("g.csv") + " --inputs /dev/zero"), "a line longer than 16 MiB",
                     "--inputs /dev/zero");
  expect_input_error(xbarsim_test::run_xbarsim("xbar-study --config /dev/zero"), "holds more than 16 MiB",
                     "--config /dev/zero");
}

TEST_F(Safety, Item8_WholeNumbersWrittenAsDecimalsAreTheIntegerEverywhere) {
  // 8.0 for an integer key is 8: a valid point, the same one as 8.
  const Result r = run("explore --model tiny --images 2 --set 'converters.adc_bits=[6,8.0]' --out " + path("j.jsonl") +
                       " --json " + path("e.json"));
  ASSERT_EQ(r.code, 0) << r.out;
  for (const auto& p : nlohmann::json::parse(slurp(path("e.json")))["points"]) EXPECT_EQ(p["status"], "ok") << p;
  const Result again =
      run("explore --model tiny --images 2 --set 'converters.adc_bits=[6e0,8]' --out " + path("j.jsonl"));
  ASSERT_EQ(again.code, 0) << again.out;
  EXPECT_NE(again.out.find("2 points, 2 already in"), std::string::npos) << again.out;
  ASSERT_EQ(run(std::string(kEval) + " --set converters.adc_bits=8e0").code, 0);
  expect_input_error(
      run("explore --model tiny --images 2 --set 'converters.adc_bits=[8,8.0]' --out " + path("k.jsonl")),
      "are one design", "8 and 8.0 in one space");
}

TEST_F(Safety, Item9_AListOverAKeyThatChangesNoResultIsRefused) {
  expect_input_error(run("explore --model tiny --images 2 --set 'solver.threads=[1,2]' --out " + path("j.jsonl")),
                     "'solver.threads' cannot be a list in an exploration", "threads");
}

TEST_F(Safety, Item10_ExploreKnowsTheModelByItsContent) {
  ASSERT_EQ(run(std::string(kExplore) + " --out " + path("j.jsonl")).code, 0);
  // The same file again: reused. Other weights at the same path: run again.
  Result r = run(std::string(kExplore) + " --out " + path("j.jsonl"));
  EXPECT_NE(r.out.find("2 points, 2 already in"), std::string::npos) << r.out;
  xbarsim_test::write_tiny_model(model(), 1);
  r = run(std::string(kExplore) + " --out " + path("j.jsonl"));
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("2 points, 0 already in"), std::string::npos) << r.out;
}

TEST_F(Safety, Item11_ATimeSystemCCannotHoldIsRefused) {
  expect_input_error(run("simulate --preset lenet --set platform.clock_mhz=1e-11"), "2^64 ps", "1e-11 MHz");
  // A slow clock that fits still runs: 642 cycles of 1 s each and more.
  const Result slow =
      run("simulate --preset lenet --set platform.clock_mhz=1e-6 --timing ideal --json " + path("s.json"));
  ASSERT_EQ(slow.code, 0) << slow.out;
  EXPECT_GE(nlohmann::json::parse(slurp(path("s.json")))["latency_us"].get<double>(), 642 * 1e6);
}

TEST_F(Safety, Item13_AConfigurationThatIsADirectoryIsAnError) {
  expect_input_error(xbarsim_test::run_xbarsim("xbar-study --config " + dir_), "is a directory", "--config dir");
}

TEST_F(Safety, Item14_ASimulateSweepTracesEachPointIntoItsOwnFile) {
  const Result r = run("simulate --preset lenet --set 'platform.clock_mhz=[100,50]' --vcd " + path("t.vcd"));
  ASSERT_EQ(r.code, 0) << r.out;
  const std::string a = slurp(path("t-0.vcd")), b = slurp(path("t-1.vcd"));
  EXPECT_NE(a.find("$enddefinitions"), std::string::npos);
  EXPECT_NE(b.find("$enddefinitions"), std::string::npos);
  EXPECT_NE(a, b);  // half the clock: other times
  EXPECT_NE(r.out.find("clock_mhz=50 traced into " + path("t-1.vcd")), std::string::npos) << r.out;
}

TEST_F(Safety, Item15_HandEditedJournalsWithImpossibleValuesAreRefused) {
  ASSERT_EQ(run(std::string(kEval) + " --journal " + path("j.jsonl")).code, 0);
  const std::string good = slurp(path("j.jsonl"));
  const std::vector<nlohmann::json> lines = json_lines(path("j.jsonl"));
  ASSERT_EQ(lines.size(), 2u);
  const auto with = [&](const std::function<void(nlohmann::json&)>& edit, bool duplicate = false) {
    nlohmann::json a = lines[0];
    edit(a);
    spit(path("j.jsonl"), (duplicate ? lines[0].dump() + "\n" : "") + a.dump() + "\n" + lines[1].dump() + "\n");
    return run(std::string(kEval) + " --journal " + path("j.jsonl"));
  };
  expect_input_error(with([](nlohmann::json& a) { a["layers"][0][2] = 0; }), "line 1", "a count of 0");
  expect_input_error(with([](nlohmann::json& a) { a["layers"][0][1] = 1e308; }), "has errors no run can give",
                     "an error of 1e308");
  expect_input_error(with([](nlohmann::json& a) { a["layers"][1][0] = -1; }), "has errors no run can give",
                     "a negative error");
  expect_input_error(with([](nlohmann::json& a) { a["xb"] = 1 - a["xb"].get<int>(); }, true),
                     "line 2: a line of this run", "conflicting duplicates");
  const Result same = with([](nlohmann::json&) {}, true);  // the same line twice: one image
  EXPECT_EQ(same.code, 0) << same.out;
  EXPECT_NE(same.out.find("2 of 2 images from"), std::string::npos) << same.out;
  spit(path("j.jsonl"), good);

  // Explore rows: an accuracy that is not a number, a negative energy: not results.
  ASSERT_EQ(run(std::string(kExplore) + " --out " + path("x.jsonl")).code, 0);
  std::vector<nlohmann::json> rows = json_lines(path("x.jsonl"));
  ASSERT_EQ(rows.size(), 2u);
  rows[0]["accuracy"] = "high";
  rows[1]["energy_uj_per_image"] = -1;
  spit(path("x.jsonl"), rows[0].dump() + "\n" + rows[1].dump() + "\n");
  Result r = run(std::string(kExplore) + " --out " + path("x.jsonl"));
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("'accuracy' is not an accuracy in [0, 1]"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("'energy_uj_per_image' is not a finite number >= 0"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("2 points, 0 already in"), std::string::npos) << r.out;
  // Two different results for one point: refused, naming both lines.
  nlohmann::json other = json_lines(path("x.jsonl")).back();
  other["accuracy"] = 0.125;
  spit(path("x.jsonl"), slurp(path("x.jsonl")) + other.dump() + "\n");
  expect_input_error(run(std::string(kExplore) + " --out " + path("x.jsonl")), "give different results for point",
                     "conflicting explore rows");
}

TEST_F(Safety, Item16_FewerImagesThanAskedForAndABudgetTooSmallAreSaid) {
  const Result r = run("eval --model tiny --offset 15 --images 5 --json " + path("e.json"));
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("using images 15..15 (1 of the 5 images asked for)"), std::string::npos) << r.out;
  EXPECT_EQ(nlohmann::json::parse(slurp(path("e.json")))["images"], 1);
  expect_input_error(run("simulate --preset lenet --set platform.crossbar_budget=2"),
                     "platform.crossbar_budget = 2 is below the", "budget");
  expect_input_error(run("simulate --preset lenet --set platform.replication=auto --set platform.crossbar_budget=2"),
                     "without replication", "auto budget");
}

TEST_F(Safety, MessagesNameTheKeyAndComeBeforeTheWork) {
  // An output name too long for the file system: before the study, not after it.
  const Result longname = run("xbar-study --json " + path(std::string(300, 'n') + ".json"));
  expect_input_error(longname, "File name too long", "long --json");
  EXPECT_EQ(longname.out.find("mean_rel_error"), std::string::npos) << longname.out;
  // A value out of range in an exploration's list: refused as eval refuses it, not a failed row.
  expect_input_error(run("explore --model tiny --images 2 --set 'converters.adc_bits=[6,99]' --out " + path("j.jsonl")),
                     "converters.adc_bits", "adc_bits 99");
  // A quote inside a list value of a file is that file's value, not a --set.
  spit(path("q.yaml"), "converters:\n  adc_bits: [6, '\"a']\n");
  const Result quote = xbarsim_test::run_xbarsim("xbar-study --set study.vectors=5 --config " + path("q.yaml"));
  expect_input_error(quote, "configuration key 'converters.adc_bits'", "quote");
  EXPECT_EQ(quote.out.find("--set"), std::string::npos) << quote.out;
  expect_input_error(run(std::string(kEval) + " --set preprocessing.scale=1e300"), "'preprocessing.scale'", "scale");
  expect_input_error(run("xbar-study --set crossbar.memristor.model=sinh --set crossbar.memristor.k=5e-324"),
                     "crossbar.memristor.k", "k = 5e-324");
  // A solver that does not converge names the layer and the crossbar.
  const Result solver = run(std::string(kEval) +
                            " --set crossbar.memristor.model=sinh --set solver.nonlinear=newton "
                            "--set solver.newton_max_iterations=1");
  EXPECT_EQ(solver.code, 3) << solver.out;
  EXPECT_NE(solver.out.find("layer Conv_c1: reading out its crossbar of rows 0..26"), std::string::npos) << solver.out;
  // A huge CSV value is quoted in part.
  spit(path("g.csv"), std::string(1 << 20, 'x') + "\n");
  spit(path("v.csv"), "0.1\n");
  const Result csv = run("solve --conductances " + path("g.csv") + " --inputs " + path("v.csv"));
  expect_input_error(csv, "(1048576 characters)", "1 MB cell");
  EXPECT_LT(csv.out.size(), 1000u);
}

TEST_F(Safety, AnOptionGivenTwiceIsRefusedNotTheLastOneTaken) {
  // Before, `--out a --out b` wrote b and left a unmentioned.
  expect_input_error(xbarsim_test::run_xbarsim("xbar-study --json a.json --json b.json"),
                     "option --json is given twice", "twice");
}

TEST_F(Safety, UnderMpiAnErrorEveryRankHasIsPrintedOnce) {
  if (std::system("command -v mpirun >/dev/null 2>&1") != 0) GTEST_SKIP() << "mpirun not found; test skipped";
  const Result one =
      xbarsim_test::run_xbarsim("eval --model nosuch", "mpirun --allow-run-as-root --oversubscribe -n 2 ");
  if (one.out.find("does not share") != std::string::npos || one.out.find("without MPI") != std::string::npos)
    GTEST_SKIP() << "a build without MPI; test skipped";
  EXPECT_NE(one.code, 0) << one.out;
  size_t n = 0;
  for (size_t at = one.out.find("model 'nosuch' not found"); at != std::string::npos;
       at = one.out.find("model 'nosuch' not found", at + 1))
    ++n;
  EXPECT_EQ(n, 1u) << one.out;
}

// Issue 38, items 1 and 6: every array of a .npz dataset is checked against the model before any
// work. Calibration images of another shape overflowed the heap (malloc(): corrupted top size,
// exit 134) or, smaller or of one channel, calibrated on wrong rows with exit 0; a label
// outside the model's classes gave accuracy 0 with exit 0.
TEST_F(Safety, NpzArraysMustFitTheModel) {
  using namespace npz_writer;
  const int n = 4;
  auto images = [](int count, const std::string& shape, size_t per) {
    std::vector<uint8_t> px(static_cast<size_t>(count) * per);
    for (size_t k = 0; k < px.size(); ++k) px[k] = static_cast<uint8_t>((k * 37) % 256);
    return npy("|u1", shape, bytes_of(px.data(), px.size()));
  };
  std::vector<int64_t> labels = {3, 1, 4, 1};
  const std::string test = images(n, "(4, 3, 32, 32)", 3 * 32 * 32);
  auto lab = [&] { return npy("<i8", "(4,)", bytes_of(labels.data(), labels.size() * 8)); };
  const std::string npz = path("mine.npz");
  struct Case {
    std::string calib, shape;
  };
  for (const Case& c : {Case{images(n, "(4, 3, 64, 64)", 3 * 64 * 64), "3x64x64"},
                        Case{images(n, "(4, 3, 16, 16)", 3 * 16 * 16), "3x16x16"},
                        Case{images(n, "(4, 32, 32)", 32 * 32), "1x32x32"}}) {
    SCOPED_TRACE(c.shape);
    write_zip(npz, {{"images.npy", test}, {"labels.npy", lab()}, {"calib_images.npy", c.calib}}, false);
    for (const char* cmd : {"eval", "simulate"}) {
      const Result r = run(std::string(cmd) + " --model " + model() + " --dataset " + npz + " --images 2");
      EXPECT_EQ(r.code, 2) << cmd << ": " << r.out;
      EXPECT_NE(r.out.find("mine.npz', array 'calib_images': the images are " + c.shape +
                           " but the model expects 3x32x32"),
                std::string::npos)
          << cmd << ": " << r.out;
    }
  }
  labels[2] = 99;
  write_zip(npz, {{"images.npy", test}, {"labels.npy", lab()}}, false);
  const Result r = run("eval --model " + model() + " --dataset " + npz);
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("mine.npz', array 'labels': label 99 of image 2 is outside the model's 10 classes"),
            std::string::npos)
      << r.out;
}

// Issue 38, item 8: SystemC wrote the VCD trace in place, so a run killed three seconds in (or
// one that failed) replaced an existing trace with a truncated one. Now the trace is staged
// beside the target: complete, or the old file untouched and no temporary file left.
TEST_F(Safety, VcdIsCompleteOrUntouched) {
  const std::string vcd = path("run.vcd");
  auto leftovers = [&] {
    const Result ls = xbarsim_test::run_xbarsim("", "ls -A '" + dir_ + "' | grep -c xbarsim- ; true #");
    return ls.out;
  };
  for (const char* sig : {"TERM", "INT"}) {
    SCOPED_TRACE(sig);
    spit(vcd, "an earlier trace\n");
    const Result r = xbarsim_test::run_xbarsim(
        "simulate --preset resnet20 --timing-only --images 5000 --vcd " + vcd + " --vcd-images 5000",
        std::string("timeout -s ") + sig + " 3 ");
    EXPECT_NE(r.code, 0) << r.out;
    EXPECT_TRUE(slurp(vcd) == "an earlier trace\n") << "the earlier trace was replaced";
    EXPECT_EQ(leftovers(), "0\n");
  }
  const Result ok = xbarsim_test::run_xbarsim("simulate --preset resnet20 --timing-only --images 2 --vcd " + vcd);
  ASSERT_EQ(ok.code, 0) << ok.out;
  const std::string trace = slurp(vcd);
  EXPECT_EQ(trace.rfind("$date", 0), 0u);
  EXPECT_NE(trace.find("$enddefinitions"), std::string::npos);
  EXPECT_EQ(leftovers(), "0\n");
}

// Issue 38, item 11: values a float cannot hold were reported as "analog layer: input full scale
// must be > 0", naming neither the node nor the cause. Now pixels of 1e300 name the file and
// array, and an activation that overflows (LeakyRelu with alpha 3e38) names the layer it feeds.
TEST_F(Safety, NonFiniteValuesAreNamed) {
  using namespace npz_writer;
  const std::vector<double> huge(2 * 3 * 32 * 32, 1e300);
  const std::vector<int64_t> labels = {0, 1};
  write_zip(path("huge.npz"),
            {{"images.npy", npy("<f8", "(2, 3, 32, 32)", bytes_of(huge.data(), huge.size() * 8))},
             {"labels.npy", npy("<i8", "(2,)", bytes_of(labels.data(), 16))}},
            false);
  Result r = run("eval --model " + model() + " --dataset " + path("huge.npz"));
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("huge.npz', array 'images' holds a value a float cannot hold (1e+300) at element 0"),
            std::string::npos)
      << r.out;

  using namespace onnx_builder;
  // LeakyRelu(alpha) -> Conv (weights 0.3) -> Flatten -> Gemm, on pixels preprocessed to
  // [-0.5, 0.5]: `first` puts the LeakyRelu after the Conv instead (its output then feeds the
  // Gemm inf), else the Conv's input is finite (1.5e38) and its sums overflow.
  for (bool first : {false, true}) {
    SCOPED_TRACE(first ? "LeakyRelu before the Conv" : "LeakyRelu after the Conv");
    onnx::ModelProto m = onnx_builder::model("leaky", "xbarsim tests");
    auto* g = m.mutable_graph();
    io(g->add_input(), "x", {1, 3, 32, 32});
    float_init(g, "w1", {4, 3, 3, 3}, [&](size_t k) { return first ? 0.3f : (k % 2 ? 0.3f : -0.3f); });
    float_init(g, "w2", {10, 900}, [](size_t k) { return k % 3 ? 0.01f : -0.01f; });
    auto leaky = [&](const char* in, const char* out) {
      auto* a = node(g, "LeakyRelu", {in}, out)->add_attribute();
      a->set_name("alpha");
      a->set_type(onnx::AttributeProto::FLOAT);
      a->set_f(3e38f);
    };
    if (first) leaky("x", "l0");
    auto* c = node(g, "Conv", {first ? "l0" : "x", "w1"}, "c1");
    ints_attr(c, "kernel_shape", {3, 3});
    ints_attr(c, "strides", {2, 2});
    if (!first) leaky("c1", "r1");
    node(g, "Flatten", {first ? "c1" : "r1"}, "f1");
    int_attr(node(g, "Gemm", {"f1", "w2"}, "y"), "transB", 1);
    io(g->add_output(), "y", {1, 10});
    meta(m, "dataset", "cifar10");
    {
      std::ofstream f(path("leaky.onnx"), std::ios::binary);
      m.SerializeToOstream(&f);
    }
    r = run("eval --model " + path("leaky.onnx") +
            " --images 2 --set preprocessing.scale=0.00392156862745098 --set preprocessing.mean=0.5 "
            "--set preprocessing.std=1");
    EXPECT_EQ(r.code, 2) << r.out;
    const std::string want = first ? "layer Conv_c1: its output on calibration image 0 is not a finite float"
                                   : "layer Gemm_y: its input on calibration image 0 holds a value that is not a "
                                     "finite float";
    EXPECT_NE(r.out.find(want), std::string::npos) << r.out;
  }
}

// Issue 38, item 11: a component's unit area of 1e308 mm^2 printed inf and wrote JSON null;
// every quantity of a hardware file is at most 1e12 (in its unit), named when it is not.
TEST_F(Safety, HardwareQuantitiesAreBounded) {
  std::string lib = slurp(library());
  const size_t at = lib.find("area_mm2: {value: 0.0012,");  // the ADC's
  ASSERT_NE(at, std::string::npos);
  lib.replace(at, std::string("area_mm2: {value: 0.0012,").size(), "area_mm2: {value: 1e308,");
  spit(library(), lib);
  const Result r = run("overhead --model " + model() + " --json " + path("o.json"));
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("'components.adc.area_mm2.value' must be a non-negative number at most 1e12, got '1e308'"),
            std::string::npos)
      << r.out;
  EXPECT_EQ(r.out.find("inf"), std::string::npos) << r.out;
}

namespace {

nlohmann::json read_json_file(const std::string& p) {
  std::ifstream in(p);
  return nlohmann::json::parse(in);
}

}  // namespace

// Issue 39, item 3: a layer whose outputs are far from software's was reported (a mean error of
// 5.96e9 in one of GoogLeNet's) beside "drop 0.0000" with no warning. Now a layer whose mean
// error passes 10 % of its output range is named, in the JSON's warnings and after the table;
// the tiny network on the default design stays far below.
TEST_F(Safety, LargeLayerErrorsAreWarnedAbout) {
  Result r = run("eval --model tiny --images 2 --json " + path("ok.json"));
  ASSERT_EQ(r.code, 0) << r.out;
  nlohmann::json j = read_json_file(path("ok.json"));
  for (const auto& l : j["layers"]) EXPECT_LT(l["mean_relative_error"].get<double>(), 0.1) << l["name"];
  for (const auto& w : j["warnings"]) EXPECT_EQ(w.get<std::string>().find("mean error"), std::string::npos) << w;
  // Programming errors of 50 uS (sigma) on every cell: the first layer's mean error is 0.125,
  // the second's 0.097 (named and not).
  r = run("eval --model tiny --images 2 --set device.model=constant --set device.program_sigma_us=50 --json " + path("bad.json"));
  ASSERT_EQ(r.code, 0) << r.out;
  j = read_json_file(path("bad.json"));
  int warned = 0;
  for (const auto& l : j["layers"]) {
    const double mean = l["mean_relative_error"].get<double>();
    const std::string name = l["name"].get<std::string>();
    bool named = false;
    for (const auto& w : j["warnings"])
      named = named || w.get<std::string>().find("layer " + name + ": mean error") != std::string::npos;
    EXPECT_EQ(named, mean > 0.1) << name << " " << mean;
    warned += named;
  }
  EXPECT_GT(warned, 0) << j["warnings"];
  EXPECT_NE(r.out.find("of its output range (over 0.1)"), std::string::npos) << r.out;
}

// Issue 39, item 4: float32 images in [0, 1] with the default scale 1/255 reached the network
// 255 times too small, silently (10 % software accuracy). Now eval and simulate warn; pixels
// of 0..255 as floats, or the scale set to 1, do not.
TEST_F(Safety, FloatImagesThatContradictTheScaleAreWarnedAbout) {
  using namespace npz_writer;
  const int n = 2, per = 3 * 32 * 32;
  const std::vector<int64_t> labels = {0, 1};
  auto write = [&](double top) {
    std::vector<float> v(static_cast<size_t>(n) * per);
    for (size_t k = 0; k < v.size(); ++k) v[k] = static_cast<float>(top * ((k * 37) % 256) / 255.0);
    write_zip(path("f.npz"),
              {{"images.npy", npy("<f4", "(2, 3, 32, 32)", bytes_of(v.data(), v.size() * 4))},
               {"labels.npy", npy("<i8", "(2,)", bytes_of(labels.data(), 16))}},
              false);
  };
  const std::string warning = "are float values within [0, 1] but preprocessing.scale is 0.00392157";
  write(1.0);
  for (const char* cmd : {"eval", "simulate"}) {
    const Result r = run(std::string(cmd) + " --model tiny --images 2 --dataset " + path("f.npz"));
    ASSERT_EQ(r.code, 0) << r.out;
    EXPECT_NE(r.out.find(warning), std::string::npos) << cmd << ": " << r.out;
  }
  Result r = run("eval --model tiny --images 2 --set preprocessing.scale=1 --dataset " + path("f.npz"));
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_EQ(r.out.find("preprocessing.scale is"), std::string::npos) << r.out;
  write(255.0);
  r = run("eval --model tiny --images 2 --dataset " + path("f.npz"));
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_EQ(r.out.find("preprocessing.scale"), std::string::npos) << r.out;
}

// Issue 39, item 4: simulate --timing-only of a pipelined machine defaulted to one image and
// reported 1 / latency (ResNet-20 on ISAAC-CE: 13 570 images/s) where the steady state is
// 37 879. One image now reports the bottleneck stage's rate, which the spacing of simulated
// outputs confirms with more images, and says so.
TEST_F(Safety, OneImageReportsTheSteadyStateThroughput) {
  const std::string isaac = std::string(XBARSIM_SOURCE_DIR) + "/configs/isaac.yaml";
  const std::string base = "simulate --preset resnet20 --timing-only --config " + isaac + " --json ";
  Result r = xbarsim_test::run_xbarsim(base + path("one.json"));
  ASSERT_EQ(r.code, 0) << r.out;
  Result many = xbarsim_test::run_xbarsim(base + path("many.json") + " --images 16");
  ASSERT_EQ(many.code, 0) << many.out;
  const nlohmann::json one = read_json_file(path("one.json")), sixteen = read_json_file(path("many.json"));
  const double measured = sixteen["throughput_images_per_s"].get<double>();
  const double busy_us = one["bottleneck"]["busy_us_per_image"].get<double>();
  EXPECT_NEAR(one["throughput_images_per_s"].get<double>(), measured, 1e-3 * measured);
  EXPECT_NEAR(one["throughput_images_per_s"].get<double>(), 1e6 / busy_us, 1e-9 * measured);
  EXPECT_GT(measured, 1.5e6 / one["latency_us"].get<double>());  // far from 1 / latency
  EXPECT_EQ(one["throughput_from"], "bottleneck stage (one image)");
  EXPECT_EQ(sixteen["throughput_from"], "simulated outputs");
  ASSERT_EQ(one["warnings"].size(), 1u);
  EXPECT_NE(r.out.find("warning: one image never fills a pipelined schedule"), std::string::npos) << r.out;
  EXPECT_TRUE(sixteen["warnings"].empty());
}
