// xbarsim explore end to end on LeNet/MNIST (skipped without the shared data): rows, a
// failing point, the report; a run killed mid-way resumes with only the missing points; and
// mpirun -n 2 gives the same JSON as one rank (skipped without mpirun or an MPI build).
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <set>
#include <thread>
#include <utility>
#include <vector>

#include "tests/app/cli_test_util.h"
#include "tests/app/tiny_network.h"

using xbarsim_test::run_xbarsim;

namespace {

std::string tmp(const std::string& name) { return ::testing::TempDir() + "xbarsim_explore_" + name; }

/// A 6-point LeNet space: 2 max_rows x 3 ADC widths, one of which cannot be scheduled.
std::string write_space(const std::string& name, int images) {
  const std::string path = tmp(name + ".yaml");
  std::ofstream(path) << "explore:\n  model: lenet_mnist\n  color_by: converters.adc_bits\n"
                         "mapping:\n  max_rows: [64, 128]\nconverters:\n  adc_bits: [4, 8, none]\n"
                         "eval:\n  images: "
                      << images
                      << "\n  calibration_images: 20\n  calibration_samples: 256\ncalibration:\n  samples: 64\n"
                      << "solver:\n  threads: 1\n";
  return path;
}

int lines(const std::string& path) {
  std::ifstream in(path);
  int n = 0;
  std::string l;
  while (std::getline(in, l)) n += !l.empty();
  return n;
}

nlohmann::json without_timing(nlohmann::json j) {
  for (auto& r : j["points"])
    for (const char* k : {"program_time_s", "evaluate_time_s", "simulation_wall_time_s", "reused_programming"})
      r.erase(k);
  return j;
}

}  // namespace

TEST(ExploreCommand, RowsFrontFailureAndReport) {
  if (!xbarsim_test::have_data()) GTEST_SKIP() << "shared data directory not found; test skipped";
  const std::string space = write_space("rows", 60), out = tmp("rows.jsonl"), json = tmp("rows.json"),
                    csv = tmp("rows.csv"), html = tmp("rows.html");
  std::remove(out.c_str());
  // One more dimension whose second value cannot be scheduled: those points are rows with a reason.
  const auto r = run_xbarsim("explore --config " + space + " --set \"platform.buffer_bytes=[auto,1]\" --out " + out +
                             " --json " + json + " --csv " + csv + " --report " + html);
  ASSERT_EQ(r.code, 0) << r.out;
  std::ifstream in(json);
  const auto j = nlohmann::json::parse(in);
  ASSERT_EQ(j["points"].size(), 12u);
  int failed = 0, front = 0;
  for (const auto& p : j["points"]) {
    if (p["status"] == "failed") {
      ++failed;
      EXPECT_NE(p["reason"].get<std::string>().find("buffer_bytes"), std::string::npos) << p;
      EXPECT_EQ(p["point"]["platform.buffer_bytes"], "1");
      EXPECT_FALSE(p["front"].get<bool>());
    } else {
      EXPECT_GT(p["accuracy"].get<double>(), 0.9) << p["label"];
      // The paired drop: its counts explain the accuracy difference; its interval holds it.
      const int n = j["images"];
      const double drop = p["accuracy_drop"];
      EXPECT_NEAR(drop, p["software_accuracy"].get<double>() - p["accuracy"].get<double>(), 1e-12);
      EXPECT_EQ(p["images_only_software_correct"].get<int>() - p["images_only_crossbar_correct"].get<int>(),
                static_cast<int>(std::lround(drop * n)));
      EXPECT_LE(p["accuracy_drop_ci95"][0].get<double>(), drop);
      EXPECT_GE(p["accuracy_drop_ci95"][1].get<double>(), drop);
      EXPECT_TRUE(p["warnings"].is_array());
      EXPECT_GT(p["energy_uj_per_image"].get<double>(), 0) << p["label"];
      EXPECT_EQ(p["layers"].size(), 4u);
      front += p["front"].get<bool>();
    }
  }
  EXPECT_EQ(failed, 6);
  EXPECT_GE(front, 1);
  EXPECT_EQ(lines(csv), 13);
  std::ifstream c(csv);
  std::string header;
  std::getline(c, header);
  EXPECT_NE(header.find(",accuracy_drop,accuracy_drop_ci95_low,accuracy_drop_ci95_high,front,reason,warnings"),
            std::string::npos)
      << header;
  std::ifstream h(html);
  const std::string page((std::istreambuf_iterator<char>(h)), {});
  for (const char* id : {"plot-pareto", "plot-bits", "plot-layers", "plot-energy", "plot-area", "plot-timing"})
    EXPECT_NE(page.find(std::string("id=\"") + id + "\""), std::string::npos) << id;
  EXPECT_NEAR(j["min_accuracy"].get<double>(), 0.5 * j["points"][0]["software_accuracy"].get<double>(), 1e-12);  // auto

  // A floor of 100 % (the same journal: nothing is rerun): only a point without a single
  // wrong image may stay on the front.
  const auto floor = run_xbarsim("explore --config " + space + " --set \"platform.buffer_bytes=[auto,1]\" --set " +
                                 "explore.min_accuracy=1 --out " + out + " --json " + json + " --report " + html);
  ASSERT_EQ(floor.code, 0) << floor.out;
  std::ifstream in2(json);
  const auto j2 = nlohmann::json::parse(in2);
  EXPECT_EQ(j2["min_accuracy"].get<double>(), 1.0);
  int below = 0;
  for (const auto& p : j2["points"])
    if (p["status"] == "ok" && p["accuracy"].get<double>() < 1) {
      ++below;
      EXPECT_FALSE(p["front"].get<bool>()) << p["label"];
    }
  EXPECT_GT(below, 0);
  EXPECT_LT(j2["front"].size(), j["front"].size() + below);
  const auto bad = run_xbarsim("explore --config " + space + " --set explore.min_accuracy=1.5 --out " + out);
  EXPECT_EQ(bad.code, 2);
  EXPECT_NE(bad.out.find("explore.min_accuracy"), std::string::npos) << bad.out;
}

TEST(ExploreCommand, KilledRunResumesWithOnlyTheMissingPoints) {
  if (!xbarsim_test::have_data()) GTEST_SKIP() << "shared data directory not found; test skipped";
  const std::string space = write_space("kill", 400), out = tmp("kill.jsonl"), json = tmp("kill.json");
  std::remove(out.c_str());
  const pid_t pid = fork();
  if (pid == 0) {
    freopen("/dev/null", "w", stdout);
    freopen("/dev/null", "w", stderr);
    execl(XBARSIM_BINARY, XBARSIM_BINARY, "explore", "--config", space.c_str(), "--out", out.c_str(), nullptr);
    _exit(127);
  }
  // Kill it (SIGKILL: no cleanup) as soon as the first points are in the journal.
  const auto t0 = std::chrono::steady_clock::now();
  while (lines(out) < 2 && std::chrono::steady_clock::now() - t0 < std::chrono::seconds(120))
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  kill(pid, SIGKILL);
  int st = 0;
  waitpid(pid, &st, 0);
  const int finished = lines(out);
  ASSERT_GE(finished, 2) << "no point finished in 120 s";
  ASSERT_LT(finished, 6) << "the run ended before it could be killed";
  // Simulate a kill in the middle of a write too: a cut-off last line.
  std::ofstream(out, std::ios::app) << "{\"key\":\"00";
  const auto r = run_xbarsim("explore --config " + space + " --out " + out + " --json " + json);
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("6 points, " + std::to_string(finished) + " already in"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find(std::to_string(6 - finished) + " to run"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("dropped an incomplete last line"), std::string::npos) << r.out;
  EXPECT_EQ(lines(out), 6);  // every point once
  // A rerun has nothing left to do and gives the same rows.
  const std::string json2 = tmp("kill2.json");
  const auto again = run_xbarsim("explore --config " + space + " --out " + out + " --json " + json2);
  ASSERT_EQ(again.code, 0) << again.out;
  EXPECT_NE(again.out.find("0 to run"), std::string::npos) << again.out;
  std::ifstream a(json), b(json2);
  EXPECT_EQ(nlohmann::json::parse(a), nlohmann::json::parse(b));
}

TEST(ExploreCommand, TwoMpiRanksEqualOne) {
  if (!xbarsim_test::have_data()) GTEST_SKIP() << "shared data directory not found; test skipped";
  if (std::system("command -v mpirun >/dev/null 2>&1") != 0) GTEST_SKIP() << "mpirun not found; MPI test skipped";
  const std::string space = write_space("mpi", 100);
  const std::string mpirun = "OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 mpirun -n 2 --oversubscribe ";
  for (const char* cmd : {"explore", "eval"}) {
    const std::string one = tmp(std::string(cmd) + "_1.json"), two = tmp(std::string(cmd) + "_2.json");
    const std::string out1 = tmp(std::string(cmd) + "_1.jsonl"), out2 = tmp(std::string(cmd) + "_2.jsonl");
    std::remove(out1.c_str());
    std::remove(out2.c_str());
    const std::string args = std::string(cmd) == "explore"
                                 ? "explore --config " + space + " --set \"converters.adc_bits=[4,8]\" --out "
                                 : "eval --model lenet_mnist --images 100 --set \"converters.adc_bits=[4,8]\" --csv ";
    const auto r1 = run_xbarsim(args + out1 + " --json " + one);
    ASSERT_EQ(r1.code, 0) << r1.out;
    const auto r2 = run_xbarsim(args + out2 + " --json " + two, mpirun);
    if (r2.out.find("built without MPI") != std::string::npos) GTEST_SKIP() << "xbarsim built without MPI";
    ASSERT_EQ(r2.code, 0) << r2.out;
    std::ifstream a(one), b(two);
    nlohmann::json ja = nlohmann::json::parse(a), jb = nlohmann::json::parse(b);
    if (std::string(cmd) == "explore") {
      EXPECT_EQ(without_timing(ja).dump(1), without_timing(jb).dump(1));
    } else {
      for (auto* j : {&ja, &jb})
        for (auto& run : *j)
          for (const char* k : {"program_time_s", "evaluate_time_s", "images_per_s"}) run.erase(k);
      EXPECT_EQ(ja.dump(1), jb.dump(1));
    }
  }
}

// explore.accuracy false: no programming, evaluation or dataset; every point's platform runs
// timing only and reports the cost and timing the full run reports; accuracy leaves the
// objectives (said on stderr); the journal keys differ, so the two kinds of rows never mix.
TEST(ExploreCommand, WithoutAccuracyPointsRunTimingOnlyWithTheFullRunsFigures) {
  if (!xbarsim_test::have_data()) GTEST_SKIP() << "shared data directory not found; test skipped";
  const std::string space = write_space("fast", 20), full_out = tmp("fast_full.jsonl"), fast_out = tmp("fast.jsonl"),
                    full_json = tmp("fast_full.json"), fast_json = tmp("fast.json");
  std::remove(full_out.c_str());
  std::remove(fast_out.c_str());
  const auto full = run_xbarsim("explore --config " + space + " --out " + full_out + " --json " + full_json);
  ASSERT_EQ(full.code, 0) << full.out;
  const auto fast = run_xbarsim("explore --config " + space + " --set explore.accuracy=false --out " + fast_out +
                                " --json " + fast_json);
  ASSERT_EQ(fast.code, 0) << fast.out;
  EXPECT_NE(fast.out.find("accuracy is left out of the objectives"), std::string::npos) << fast.out;
  std::ifstream a(full_json), b(fast_json);
  const auto fj = nlohmann::json::parse(a), tj = nlohmann::json::parse(b);
  EXPECT_EQ(tj["accuracy"], false);
  EXPECT_EQ(tj["objectives"], nlohmann::json({"energy", "area", "latency"}));
  ASSERT_EQ(fj["points"].size(), tj["points"].size());
  for (size_t k = 0; k < fj["points"].size(); ++k) {
    const auto &f = fj["points"][k], t = tj["points"][k];
    SCOPED_TRACE(f["label"].get<std::string>());
    EXPECT_EQ(f["status"], t["status"]);
    EXPECT_NE(f["key"], t["key"]);
    if (t["status"] != "ok") continue;
    EXPECT_EQ(t["mode"], "timing-only");
    EXPECT_FALSE(t.contains("accuracy"));
    for (const char* k : {"energy_uj_per_image", "area_mm2", "latency_us", "throughput_images_per_s", "avg_power_mw"})
      EXPECT_EQ(f[k], t[k]) << k;
  }
  // Accuracy as an objective would leave fewer than two: an input error.
  const auto bad = run_xbarsim("explore --config " + space +
                               " --set explore.accuracy=false --set explore.objectives=accuracy,energy --out " +
                               tmp("bad.jsonl"));
  EXPECT_EQ(bad.code, 2) << bad.out;
}

// Points that differ only in their readout (ADC bits, whether the method calibrates, the
// platform's clock) share one programming: 2 x 2 x 2 x 2 points over two conductance headrooms
// are 2 programmings, and every point's row equals the row of an exploration of that point
// alone (programmed for it), bit for bit. On the tiny network the test writes (no shared data).
TEST(ExploreCommand, PointsDifferingInTheirReadoutShareOneProgramming) {
  const std::string dir = tmp("reuse");
  std::system(("rm -rf '" + dir + "' && mkdir -p '" + dir + "/models'").c_str());
  xbarsim_test::write_tiny_cifar(dir + "/data", 12);
  xbarsim_test::write_tiny_model(dir + "/models/tiny.onnx");
  const std::string cfg = dir + "/space.yaml";
  std::ofstream(cfg) << "data:\n  dir: " << dir << "/data\n  models_dir: " << dir
                     << "/models\nexplore:\n  model: tiny\neval:\n  images: 12\n  calibration_images: 6\n"
                        "  calibration_samples: 64\ncalibration:\n  samples: 10\nmapping:\n  max_rows: 16\n  max_cols: 4\n"
                        "device:\n  model: constant\n  program_sigma_us: 0.5\nsolver:\n  threads: 1\n";
  const std::vector<std::pair<std::string, std::vector<std::string>>> dims = {
      {"mapping.g_headroom", {"0.1", "0.3"}},
      {"converters.adc_bits", {"3", "6"}},
      {"mitigation.method", {"conversion", "conversion+calibration"}},
      {"platform.clock_mhz", {"100", "200"}}};
  std::string lists;
  for (const auto& [key, values] : dims) lists += " --set '" + key + "=[" + values[0] + "," + values[1] + "]'";
  const auto r =
      run_xbarsim("explore --config " + cfg + lists + " --out " + dir + "/all.jsonl --json " + dir + "/all.json");
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("16 to run; 2 crossbar programmings"), std::string::npos) << r.out;
  std::ifstream in(dir + "/all.json");
  const auto all = nlohmann::json::parse(in);
  ASSERT_EQ(all["points"].size(), 16u);
  int programmings = 0;
  std::set<std::string> accuracies_and_errors;  // the readout changes results
  for (const auto& p : all["points"]) {
    ASSERT_EQ(p["status"], "ok") << p;
    programmings += !p["reused_programming"].get<bool>();
    accuracies_and_errors.insert(p["mean_relative_error"].dump() + " " + p["energy_uj_per_image"].dump());
  }
  EXPECT_EQ(programmings, 2);
  EXPECT_GE(accuracies_and_errors.size(), 8u);
  // Each point on its own, programmed for itself.
  for (const auto& p : all["points"]) {
    std::string sets;
    for (const auto& [key, value] : p["point"].items()) sets += " --set '" + key + "=" + value.get<std::string>() + "'";
    const std::string one = dir + "/one_" + std::to_string(p["index"].get<int>());
    const auto r1 = run_xbarsim("explore --config " + cfg + sets + " --out " + one + ".jsonl --json " + one + ".json");
    ASSERT_EQ(r1.code, 0) << r1.out;
    std::ifstream in1(one + ".json");
    auto row = nlohmann::json::parse(in1)["points"][0];
    EXPECT_FALSE(row["reused_programming"].get<bool>());
    auto expected = p;
    for (auto* j : {&row, &expected})
      for (const char* k : {"program_time_s", "evaluate_time_s", "simulation_wall_time_s", "reused_programming",
                            "index", "label", "point", "front"})
        j->erase(k);
    EXPECT_EQ(row.dump(1), expected.dump(1)) << p["label"];
  }
  // Three ranks split the groups (6, 5 and 5 points: the first group reaches two ranks, and so
  // does the second): the same results.
  if (std::system("command -v mpirun >/dev/null 2>&1") == 0) {
    const auto r3 =
        run_xbarsim("explore --config " + cfg + lists + " --out " + dir + "/three.jsonl --json " + dir + "/three.json",
                    "OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 mpirun -n 3 --oversubscribe ");
    if (r3.out.find("built without MPI") == std::string::npos) {
      ASSERT_EQ(r3.code, 0) << r3.out;
      EXPECT_NE(r3.out.find("16 to run on 3 ranks; 4 crossbar programmings"), std::string::npos) << r3.out;
      std::ifstream in3(dir + "/three.json");
      EXPECT_EQ(without_timing(nlohmann::json::parse(in3)).dump(1), without_timing(all).dump(1));
    }
  }
  if (!HasFailure()) std::system(("rm -rf '" + dir + "'").c_str());
}
