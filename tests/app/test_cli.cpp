// The xbarsim executable: exit codes and messages for good and bad input.
#include <gtest/gtest.h>

#include "tests/app/cli_test_util.h"

#include <array>
#include <cstdio>
#include <fstream>
#include <sys/wait.h>

namespace {

using xbarsim_test::Result;
Result run(const std::string& args, const std::string& prefix = "") { return xbarsim_test::run_xbarsim(args, prefix); }

std::string file(const std::string& name, const std::string& text) {
  const std::string path = "/tmp/xbarsim_cli_" + name;
  std::ofstream(path) << text;
  return path;
}

}  // namespace

TEST(Cli, SolveSingleCellMatchesOhmsLaw) {
  const auto g = file("g1.csv", "5e-5\n");
  const auto v = file("v1.csv", "0.2\n0.4\n");
  const auto r = run("solve --conductances " + g + " --inputs " + v + " --set crossbar.r_wire=0.5");
  ASSERT_EQ(r.code, 0) << r.out;
  const double i1 = 0.2 / (1 + 0.5 + 2e4 + 0.5 + 1), i2 = 0.4 / (1 + 0.5 + 2e4 + 0.5 + 1);
  double a = 0, b = 0;
  ASSERT_EQ(std::sscanf(r.out.c_str(), "%lf\n%lf", &a, &b), 2) << r.out;
  EXPECT_NEAR(a, i1, 1e-12 * i1);
  EXPECT_NEAR(b, i2, 1e-12 * i2);
}

TEST(Cli, SolveWithVoltageSensingPrintsTheOpenColumnsVoltages) {
  // Two cells on one column, nearly ideal wires: V = (G1 V1 + G2 V2) / (G1 + G2).
  const auto g = file("gv.csv", "5e-5\n2e-5\n");
  const auto v = file("vv.csv", "0.1,0.4\n");
  const auto r = run("solve --conductances " + g + " --inputs " + v +
                     " --set crossbar.sensing=voltage --set crossbar.r_wire=1e-9 --set crossbar.r_in=1e-9");
  ASSERT_EQ(r.code, 0) << r.out;
  const double expect = (5e-5 * 0.1 + 2e-5 * 0.4) / 7e-5;
  double a = 0;
  ASSERT_EQ(std::sscanf(r.out.c_str(), "%lf", &a), 1) << r.out;
  EXPECT_NEAR(a, expect, 1e-12 * expect);
  // The analog layers read currents: an input error naming the key, not a run on zero currents.
  const auto e = run("eval --model lenet_mnist --images 1 --set crossbar.sensing=voltage");
  EXPECT_EQ(e.code, 2) << e.out;
  EXPECT_NE(e.out.find("crossbar.sensing"), std::string::npos) << e.out;
}

TEST(Cli, BadInputGivesOneClearMessageAndNonZeroExit) {
  const auto g = file("g.csv", "5e-5,6e-5\n4e-5,3e-5\n");
  const auto v3 = file("v3.csv", "0.1,0.2,0.3\n");
  const auto v2 = file("v2.csv", "0.1,0.2\n");
  const auto gneg = file("gneg.csv", "5e-5,-6e-5\n4e-5,3e-5\n");
  const auto gtxt = file("gtxt.csv", "5e-5,abc\n4e-5,3e-5\n");
  struct Bad {
    std::string args, expect;
  } cases[] = {
      {"solve --conductances " + g + " --inputs " + v3, "3 voltages"},
      {"solve --conductances " + gneg + " --inputs " + v2, "conductances must lie in"},
      {"solve --conductances " + gtxt + " --inputs " + v2, "'abc' is not a finite number"},
      {"solve --conductances /nonexistent.csv --inputs " + v2, "cannot open '/nonexistent.csv'"},
      {"solve --conductances " + g + " --inputs " + v2 + " --set crossbar.r_wier=1", "crossbar.r_wier"},
      {"solve --conductances " + g + " --inputs " + v2 + " --set crossbar.r_wire=-1", "crossbar.r_wire"},
      {"solve --conductances " + g + " --inputs " + v2 + " --set crossbar.sensing=charge", "crossbar.sensing"},
      {"solve --conductances " + g + " --inputs " + v2 + " --config /nonexistent.yaml", "nonexistent.yaml"},
      {"solve --inputs " + v2, "--conductances"},
      {"solve --conductances " + g + " --inputs " + v2 + " --bogus 1", "unknown option"},
      {"frobnicate", "unknown command"},
      {"eval --model lenet_mnist --set data.dir=[a,b]", "'data.dir' holds a list"},  // was: model not found
  };
  for (const auto& c : cases) {
    const auto r = run(c.args);
    EXPECT_NE(r.code, 0) << c.args;
    EXPECT_NE(r.out.find(c.expect), std::string::npos) << c.args << "\n" << r.out;
    EXPECT_EQ(r.out.find("internal error"), std::string::npos) << r.out;
  }
}

TEST(Cli, HelpForOneCommand) {
  // xbarsim CMD --help (or -h, anywhere among its options) and xbarsim help CMD: that command's
  // synopsis, exit 0, nothing run.
  for (const char* args : {"eval --help", "eval --model lenet_mnist -h", "help eval"}) {
    const auto r = run(args);
    EXPECT_EQ(r.code, 0) << args << "\n" << r.out;
    EXPECT_NE(r.out.find("usage: xbarsim eval"), std::string::npos) << args << "\n" << r.out;
    EXPECT_NE(r.out.find("--journal"), std::string::npos) << args << "\n" << r.out;
    EXPECT_EQ(r.out.find("solve --conductances"), std::string::npos) << args << ": only eval's\n" << r.out;
  }
  // The value of an option is not a request for help, and help for no such command is an error.
  const auto value = run("solve --conductances /nonexistent.csv --inputs -h");
  EXPECT_NE(value.code, 0) << value.out;
  EXPECT_EQ(value.out.find("usage:"), std::string::npos) << value.out;
  EXPECT_EQ(run("help frobnicate").code, 2);
  const auto all = run("help");
  EXPECT_EQ(all.code, 0);
  EXPECT_NE(all.out.find("solve --conductances"), std::string::npos) << all.out;
  EXPECT_NE(all.out.find("eval --model"), std::string::npos) << all.out;
}

TEST(Cli, NetlistWritesSpice) {
  const auto g = file("gn.csv", "5e-5,6e-5\n4e-5,3e-5\n");
  const auto v = file("vn.csv", "0.1,0.2\n");
  const auto r = run("netlist --conductances " + g + " --inputs " + v);
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("vsense_1"), std::string::npos);
  EXPECT_NE(r.out.find(".end"), std::string::npos);
}
