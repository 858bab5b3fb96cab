// End-to-end runs of eval and simulate through the executable.
#include <gtest/gtest.h>

#include "tests/app/cli_test_util.h"

#include <array>
#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sys/stat.h>
#include <sys/wait.h>

namespace {

int run(const std::string& args, std::string* out = nullptr) {
  const std::string cmd = std::string(XBARSIM_BINARY) + " " + args + " 2>&1";
  FILE* p = popen(cmd.c_str(), "r");
  std::array<char, 4096> buf;
  std::string text;
  while (fgets(buf.data(), buf.size(), p)) text += buf.data();
  const int st = pclose(p);
  if (out) *out = text;
  return WIFEXITED(st) ? WEXITSTATUS(st) : -1;
}

nlohmann::json read_json(const std::string& path) {
  std::ifstream in(path);
  return nlohmann::json::parse(in);
}

}  // namespace

TEST(EvalCommand, IdealCrossbarReproducesSoftware) {
  if (!xbarsim_test::have_data()) GTEST_SKIP() << "shared data directory not found; test skipped";
  // Negligible parasitics, no converters, no mitigation: the analog path must reproduce
  // the software network (an independent check of mapping and recovery on real layers).
  const std::string json = "/tmp/xbarsim_eval_ideal.json";
  std::string out;
  ASSERT_EQ(run("eval --model lenet_mnist --images 300 --set crossbar.r_wire=1e-9 --set crossbar.r_in=1e-9 "
                "--set crossbar.r_out=1e-9 --set converters.dac_bits=none --set converters.adc_bits=none "
                "--set mitigation.method=none --set mapping.max_rows=unbounded --set mapping.max_cols=unbounded "
                "--json " +
                    json,
                &out),
            0)
      << out;
  const auto j = read_json(json);
  EXPECT_EQ(j["images"], 300);
  EXPECT_EQ(j["crossbar_accuracy"], j["software_accuracy"]);
  ASSERT_EQ(j["layers"].size(), 4u);
  for (const auto& l : j["layers"]) {
    EXPECT_LT(l["mean_relative_error"].get<double>(), 1e-5) << l["name"];
    EXPECT_LT(l["worst_relative_error"].get<double>(), 1e-3) << l["name"];
  }
}

TEST(EvalCommand, ReportsErrorsPerLayerAndNamesMissingModels) {
  std::string out;
  EXPECT_NE(run("eval --model no_such_model", &out), 0);
  EXPECT_NE(out.find("no_such_model"), std::string::npos) << out;
  if (!xbarsim_test::have_data()) GTEST_SKIP() << "shared data directory not found; rest skipped";
  const std::string json = "/tmp/xbarsim_eval_default.json";
  ASSERT_EQ(run("eval --model resnet20_cifar10 --images 50 --json " + json, &out), 0) << out;
  const auto j = read_json(json);
  for (const char* k : {"software_accuracy", "crossbar_accuracy", "images", "layers"}) EXPECT_TRUE(j.contains(k)) << k;
  // The paired counts explain the accuracy difference exactly, and the interval holds the drop.
  const int only_sw = j["images_only_software_correct"], only_xb = j["images_only_crossbar_correct"];
  EXPECT_NEAR(50 * (j["software_accuracy"].get<double>() - j["crossbar_accuracy"].get<double>()), only_sw - only_xb,
              1e-9);
  EXPECT_DOUBLE_EQ(j["accuracy_drop"].get<double>(), (only_sw - only_xb) / 50.0);
  EXPECT_LE(j["accuracy_drop_ci95"][0].get<double>(), j["accuracy_drop"].get<double>() + 1e-12);
  EXPECT_GE(j["accuracy_drop_ci95"][1].get<double>(), j["accuracy_drop"].get<double>() - 1e-12);
  ASSERT_EQ(j["layers"].size(), 20u);
  for (const auto& l : j["layers"])
    for (const char* k : {"name", "rows", "cols", "mean_relative_error", "worst_relative_error"})
      EXPECT_TRUE(l.contains(k)) << k;
}

TEST(EvalCommand, WarnsWhenTheConversionClipsALayer) {
  // LeNet with unbounded rows and no headroom: the IR drops of its 500- and 800-row
  // arrays need conductances beyond g_max for most cells (the paper's observation); each
  // such layer is named with its count, and the default design (144-row crossbars, 20 %
  // headroom) draws no warning. (Shift mapping, digital sum(X): physical cells = rows x cols.)
  // The layers whose mean error then passes 10 % of their range are named after them (issue 39).
  if (!xbarsim_test::have_data()) GTEST_SKIP() << "shared data directory not found; test skipped";
  const std::string json = "/tmp/xbarsim_eval_clipped.json";
  std::string out;
  ASSERT_EQ(run("eval --model lenet_mnist --images 10 --set mapping.max_rows=unbounded --set mapping.g_headroom=0 "
                "--json " +
                    json,
                &out),
            0)
      << out;
  auto j = read_json(json);
  ASSERT_GE(j["warnings"].size(), 2u) << out;
  int named = 0, large = 0;
  std::string first;
  for (const auto& l : j["layers"]) {
    const double clipped = l["out_of_range_cells"].get<double>() / (l["rows"].get<double>() * l["cols"].get<double>());
    const std::string layer = "layer " + l["name"].get<std::string>() + ": ";
    bool warned = false, error_warned = false;
    for (const auto& w : j["warnings"]) {
      warned = warned || w.get<std::string>().rfind(layer + "the conversion wanted", 0) == 0;
      error_warned = error_warned || w.get<std::string>().rfind(layer + "mean error", 0) == 0;
    }
    EXPECT_EQ(warned, clipped > 0.10) << l["name"] << " clipped fraction " << clipped << "\n" << out;
    EXPECT_EQ(error_warned, l["mean_relative_error"].get<double>() > 0.10) << l["name"] << "\n" << out;
    if (warned && first.empty()) first = "first: layer " + l["name"].get<std::string>() + ":";
    named += warned;
    large += error_warned;
  }
  EXPECT_EQ(named + large, static_cast<int>(j["warnings"].size()));
  // Stdout counts them after the table by kind, the clipped cells first, with its first example.
  EXPECT_NE(out.find("warnings: " + std::to_string(named + large) + " in all, of " + (large ? "2 kinds" : "1 kind") +
                     "\n  " + std::to_string(named) + " x the conversion wanted"),
            std::string::npos)
      << out;
  EXPECT_NE(out.find(first), std::string::npos) << out;
  EXPECT_NE(out.find("mapping.negative: differential"), std::string::npos) << out;
  ASSERT_EQ(run("eval --model lenet_mnist --images 10 --json " + json, &out), 0) << out;
  j = read_json(json);
  EXPECT_TRUE(j["warnings"].empty()) << out;
  EXPECT_EQ(out.find("warning"), std::string::npos) << out;
}

TEST(EvalCommand, SameResultOnOneTwoAndThreeThreads) {
  // Every random stream (calibration picks, programming noise) is seeded by the item's
  // index, never by a thread: the JSON is identical apart from its timing fields.
  if (!xbarsim_test::have_data()) GTEST_SKIP() << "shared data directory not found; test skipped";
  std::string first, out;
  for (int t = 1; t <= 3; ++t) {
    const std::string json = "/tmp/xbarsim_eval_threads" + std::to_string(t) + ".json";
    ASSERT_EQ(run("eval --model resnet20_cifar10 --images 24 --set device.model=rram-wan2022 --set device.time_s=86400 "
                  "--set converters.readout_noise_na=5 --set solver.threads=" +
                      std::to_string(t) + " --json " + json,
                  &out),
              0)
        << out;
    auto j = read_json(json);
    for (const char* k : {"program_time_s", "evaluate_time_s", "images_per_s"}) j.erase(k);
    if (t == 1)
      first = j.dump();
    else
      EXPECT_EQ(j.dump(), first) << "solver.threads=" << t;
  }
}

TEST(EvalCommand, JournalResumesWithTheSameResultAsOneRun) {
  // eval --journal: a run over more images evaluates only those not in the journal, a last
  // line cut short by a kill is dropped, another configuration does not reuse the lines, and
  // the result equals one uninterrupted run's, bit for bit.
  if (!xbarsim_test::have_data()) GTEST_SKIP() << "shared data directory not found; test skipped";
  const std::string journal = "/tmp/xbarsim_eval_journal.jsonl",
                    base = "eval --model lenet_mnist --set solver.threads=2 ";
  std::remove(journal.c_str());
  auto lines = [&] {
    std::ifstream in(journal);
    int n = 0;
    for (std::string l; std::getline(in, l);) n += !l.empty();
    return n;
  };
  auto result = [](const std::string& path) {
    auto j = read_json(path);
    for (const char* k : {"program_time_s", "evaluate_time_s", "images_per_s", "images_from_journal"}) j.erase(k);
    return j.dump();
  };
  std::string out;
  ASSERT_EQ(run(base + "--images 40 --journal " + journal + " --json /tmp/xbarsim_journal_a.json", &out), 0) << out;
  EXPECT_EQ(lines(), 40);
  std::ofstream(journal, std::ios::app) << "{\"key\": \"cut short";  // a kill during a write
  ASSERT_EQ(run(base + "--images 100 --journal " + journal + " --json /tmp/xbarsim_journal_b.json", &out), 0) << out;
  EXPECT_NE(out.find("dropped an incomplete last line"), std::string::npos) << out;
  EXPECT_NE(out.find("40 of 100 images from"), std::string::npos) << out;
  EXPECT_EQ(read_json("/tmp/xbarsim_journal_b.json")["images_from_journal"], 40);
  EXPECT_EQ(lines(), 100);
  ASSERT_EQ(run(base + "--images 100 --json /tmp/xbarsim_journal_c.json", &out), 0) << out;
  EXPECT_EQ(result("/tmp/xbarsim_journal_b.json"), result("/tmp/xbarsim_journal_c.json"));
  // Images 60..99 from the journal (its image index is the dataset's), 100..119 evaluated.
  ASSERT_EQ(run(base + "--offset 60 --images 60 --journal " + journal + " --json /tmp/xbarsim_journal_d.json", &out), 0)
      << out;
  EXPECT_EQ(read_json("/tmp/xbarsim_journal_d.json")["images_from_journal"], 40);
  ASSERT_EQ(run(base + "--offset 60 --images 60 --json /tmp/xbarsim_journal_e.json", &out), 0) << out;
  EXPECT_EQ(result("/tmp/xbarsim_journal_d.json"), result("/tmp/xbarsim_journal_e.json"));
  // Another design: nothing reused.
  ASSERT_EQ(
      run(base + "--images 20 --set converters.adc_bits=6 --journal " + journal + " --json /tmp/xbarsim_journal_f.json",
          &out),
      0)
      << out;
  EXPECT_EQ(read_json("/tmp/xbarsim_journal_f.json")["images_from_journal"], 0);
  EXPECT_NE(out.find("120 lines of " + journal + " are of another model, dataset or configuration"), std::string::npos)
      << out;
  // The same design written differently reuses everything (and evaluates nothing).
  ASSERT_EQ(run(base +
                    "--images 20 --set converters.adc_bits=6 --set converters.adc_margin=0.050 --set "
                    "crossbar.r_wire=1e0 --journal " +
                    journal,
                &out),
            0)
      << out;
  EXPECT_NE(out.find("20 of 20 images from"), std::string::npos) << out;
  // A line of this run that is not an image record is an error naming the journal.
  std::string key;
  {
    std::ifstream in(journal);
    std::string l;
    std::getline(in, l);
    key = nlohmann::json::parse(l)["key"];
  }
  std::ofstream(journal, std::ios::app) << nlohmann::json{{"key", key}, {"image", 3}, {"layers", 5}}.dump() << "\n";
  EXPECT_EQ(run(base + "--images 10 --journal " + journal, &out), 2) << out;
  EXPECT_NE(out.find("eval journal '" + journal + "'"), std::string::npos) << out;
  EXPECT_NE(out.find("malformed"), std::string::npos) << out;
}

TEST(EvalCommand, JournalSweepPointsThatShareAKeyEvaluateOnce) {
  // The clock changes a point's cost, not an image's outcome: the second point reuses the
  // first one's lines instead of evaluating (and journaling) every image again.
  if (!xbarsim_test::have_data()) GTEST_SKIP() << "shared data directory not found; test skipped";
  const std::string journal = "/tmp/xbarsim_eval_journal_shared.jsonl";
  std::remove(journal.c_str());
  std::string out;
  ASSERT_EQ(run("eval --model lenet_mnist --images 20 --set solver.threads=2 --set platform.clock_mhz=[100,200] "
                "--journal " +
                    journal,
                &out),
            0)
      << out;
  EXPECT_NE(out.find("clock_mhz=200: 20 of 20 images from"), std::string::npos) << out;
  std::ifstream in(journal);
  int lines = 0;
  for (std::string l; std::getline(in, l);) lines += !l.empty();
  EXPECT_EQ(lines, 20);
  std::remove(journal.c_str());
}

TEST(EvalCommand, NonlinearDevicesRunEveryImageTheSameOnAnyThreadCount) {
  // sinh (k = 3) + level-1 devices with pre-distortion: every requested image is evaluated
  // (the batched Newton), the settings are reported, and 1 and 2 threads agree exactly.
  if (!xbarsim_test::have_data()) GTEST_SKIP() << "shared data directory not found; test skipped";
  std::string first, out;
  for (int t = 1; t <= 2; ++t) {
    const std::string json = "/tmp/xbarsim_eval_nonlinear" + std::to_string(t) + ".json";
    ASSERT_EQ(run("eval --model lenet_mnist --images 16 --set crossbar.memristor.model=sinh --set "
                  "crossbar.memristor.k=3 --set crossbar.transistor.model=level1 --set "
                  "converters.dac_predistortion=true --set solver.threads=" +
                      std::to_string(t) + " --json " + json,
                  &out),
              0)
        << out;
    auto j = read_json(json);
    EXPECT_EQ(j["images"], 16);
    EXPECT_EQ(j["memristor_k_per_v"], 3.0);
    EXPECT_EQ(j["dac_predistortion"], true);
    EXPECT_FALSE(j.contains("note")) << j["note"];
    EXPECT_GE(j["crossbar_accuracy"].get<double>(), j["software_accuracy"].get<double>() - 0.13);
    for (const char* k : {"program_time_s", "evaluate_time_s", "images_per_s"}) j.erase(k);
    if (t == 1)
      first = j.dump();
    else
      EXPECT_EQ(j.dump(), first);
  }
}

TEST(SimulateCommand, PresetRunsWithoutDataAndReportsTheClosedForms) {
  const std::string json = "/tmp/xbarsim_simulate.json";
  std::string out;
  ASSERT_EQ(run("simulate --preset resnet20 --timing ideal --json " + json, &out), 0) << out;
  const auto j = read_json(json);
  for (const char* k :
       {"clock_mhz", "iterations_total", "cycles_total", "latency_us", "throughput_images_per_s", "energy_uj_per_image",
        "energy_breakdown_uj", "avg_power_mw", "peak_power_mw", "area_mm2", "area_breakdown_mm2", "layers"})
    EXPECT_TRUE(j.contains(k)) << k;
  for (const auto& l : j["layers"])
    for (const char* k : {"adcs", "dacs", "crossbars", "energy_uj"}) EXPECT_TRUE(l.contains(k)) << k;
  EXPECT_EQ(j["iterations_total"], 9089);
  long long cycles = 0;
  for (const auto& l : j["layers"]) {
    EXPECT_EQ(l["cycles"], l["iterations"]) << l["name"];  // ideal: one clock cycle per iteration
    cycles += l["cycles"].get<long long>();
  }
  EXPECT_EQ(cycles, 9089);
  EXPECT_GE(j["cycles_total"].get<long long>(), 9089);  // plus input/output transfers
  // Sweeps: one point per process, one JSON object per point with its sweep values.
  ASSERT_EQ(
      run("simulate --preset lenet --images 2 --set 'platform.schedule=[sequential,pipelined]' --json " + json, &out),
      0)
      << out;
  const auto sweep = read_json(json);
  ASSERT_EQ(sweep.size(), 2u);
  EXPECT_EQ(sweep[1]["sweep"]["platform.schedule"], "pipelined");
  EXPECT_EQ(sweep[1]["schedule"], "pipelined");
  EXPECT_EQ(sweep[0]["iterations_total"], sweep[1]["iterations_total"]);
  // Buffers too small for one row, or for a window (the run would deadlock): errors, not hangs.
  EXPECT_EQ(run("simulate --preset lenet --set platform.schedule=pipelined --set platform.buffer_bytes=100", &out), 2);
  EXPECT_NE(out.find("cannot hold one transaction"), std::string::npos) << out;
  EXPECT_EQ(run("simulate --preset resnet20 --set platform.schedule=pipelined --set platform.buffer_bytes=1100", &out),
            2);
  EXPECT_NE(out.find("deadlock"), std::string::npos) << out;
  EXPECT_NE(out.find("Blocked: conv1 (image 0): "), std::string::npos) << out;  // what each stage waited for
  EXPECT_NE(run("simulate --preset resnet99", &out), 0);
  EXPECT_NE(out.find("resnet99"), std::string::npos);
}

// Simulate's accuracy line says on how many images and what software scores on them (the same
// as eval's on the same images); both JSONs name the model by its normalised path; each
// average power is named for the time it divides by (issue 39, items 5 and 7).
TEST(SimulateCommand, AccuracyWithImagesAndSoftwareAndEachPowerNamedForItsTime) {
  std::string out;
  ASSERT_EQ(run("simulate --preset lenet --timing-only --images 1", &out), 0) << out;
  EXPECT_NE(out.find("sequential schedule, 1 image: "), std::string::npos) << out;
  if (!xbarsim_test::have_data()) GTEST_SKIP() << "shared data directory not found; rest skipped";
  const std::string sj = ::testing::TempDir() + "xbarsim_simulate_accuracy.json",
                    ej = ::testing::TempDir() + "xbarsim_eval_accuracy.json";
  ASSERT_EQ(run("simulate --model lenet_mnist --dataset mnist --images 8 --json " + sj, &out), 0) << out;
  const auto s = read_json(sj);
  const std::string summary = out;
  ASSERT_EQ(run("eval --model lenet_mnist --dataset mnist --images 8 --json " + ej, &out), 0) << out;
  const auto e = read_json(ej);
  char line[128];
  std::snprintf(line, sizeof line, "accuracy on 8 images: crossbars %.4f, software %.4f (fractions",
                s["accuracy"].get<double>(), e["software_accuracy"].get<double>());
  EXPECT_NE(summary.find(line), std::string::npos) << summary;
  EXPECT_EQ(s["software_accuracy"], e["software_accuracy"]);
  // data.dir/../models/lenet_mnist.onnx, without the detour.
  for (const auto* j : {&s, &e}) {
    const std::string model = (*j)["model"];
    EXPECT_EQ(model.find("/../"), std::string::npos) << model;
    EXPECT_EQ(model.find("/./"), std::string::npos) << model;
    EXPECT_NE(model.find("models/lenet_mnist.onnx"), std::string::npos) << model;
  }
  // simulate: energy over the simulated time per image; eval: over the ideal time, the
  // crossbars' reads back to back (a clock each), named apart.
  EXPECT_NEAR(s["avg_power_mw"].get<double>(),
              s["energy_uj_per_image"].get<double>() / (s["makespan_us"].get<double>() / 8) * 1e3, 1e-9);
  EXPECT_FALSE(e.contains("avg_power_mw"));
  EXPECT_FALSE(e.contains("time_ns_per_image"));
  EXPECT_NEAR(e["ideal_avg_power_mw"].get<double>(),
              e["energy_uj_per_image"].get<double>() / e["ideal_time_ns_per_image"].get<double>() * 1e6, 1e-9);
  long long reads = 0;
  for (const auto& l : s["layers"]) reads += l["iterations"].get<long long>();
  EXPECT_DOUBLE_EQ(e["ideal_time_ns_per_image"].get<double>(), reads * 1e3 / s["clock_mhz"].get<double>());
  EXPECT_GT(e["ideal_avg_power_mw"].get<double>(), s["avg_power_mw"].get<double>());
  EXPECT_NE(summary.find("(energy / simulated time per image)"), std::string::npos) << summary;
}

// Simulate's report plots every stage of the run, the digital ones and the bottleneck among them.
TEST(SimulateCommand, TheReportPlotsEveryStageAndTheBottleneck) {
  const std::string html = ::testing::TempDir() + "xbarsim_simulate_stages.html",
                    json = ::testing::TempDir() + "xbarsim_simulate_stages.json";
  std::string out;
  ASSERT_EQ(run("simulate --preset resnet20 --timing-only --images 2 --config " + std::string(XBARSIM_SOURCE_DIR) +
                    "/configs/isaac.yaml --set platform.grain_rows=2 --json " + json + " --report " + html,
                &out),
            0)
      << out;
  std::ifstream in(html);
  const std::string h((std::istreambuf_iterator<char>(in)), {});
  const size_t a = h.find("id=\"plot-timing\"");
  ASSERT_NE(a, std::string::npos);
  const std::string svg = h.substr(a, h.find("</svg>", a) - a);
  const auto j = read_json(json);
  for (const char* list : {"layers", "digital_stages"})
    for (const auto& st : j[list])
      EXPECT_NE(svg.find("<title>" + st["name"].get<std::string>()), std::string::npos) << st["name"];
  EXPECT_NE(svg.find("<title>layer1.0/add (the bottleneck)"), std::string::npos);
  // The tiles' units: every iteration reads the crossbars 8 times for 100 ns, whichever copy
  // does it, so a layer's crossbar utilization is its images' iterations x 800 ns over its
  // copies' time.
  ASSERT_NE(h.find("id=\"plot-units\""), std::string::npos);
  EXPECT_EQ(j["bottleneck"]["unit"], "add");
  // The period: the two images' outputs leave the add's 13.65 us apart, within 1 % (the
  // estimate: the add's operations at its rate).
  EXPECT_NEAR(j["estimated_period_us"].get<double>(), 16 * 32 * 32 / 1.2e3, 1e-6);
  EXPECT_NEAR(j["period_over_estimate"].get<double>(), 1.0, 0.01);
  for (const auto& l : j["layers"]) {
    const double lanes_ns = l["replication"].get<double>() * j["makespan_us"].get<double>() * 1e3;
    EXPECT_NEAR(l["unit_utilization"]["crossbar"].get<double>(), 2 * l["iterations"].get<double>() * 800 / lanes_ns, 1e-9)
        << l["name"];
    EXPECT_NEAR(l["busy_over_estimate"].get<double>(), 1.0, 1e-6) << l["name"];  // no contention inside a tile
  }
  // The layer-sized platform: its interconnect is a stage too.
  ASSERT_EQ(run("simulate --preset lenet --timing-only --images 2 --json " + json + " --report " + html, &out), 0)
      << out;
  std::ifstream in2(html);
  const std::string h2((std::istreambuf_iterator<char>(in2)), {});
  EXPECT_NE(h2.find("<title>interconnect (platform.bus_lanes)"), std::string::npos);
  EXPECT_GT(read_json(json)["interconnect_busy_us_per_image"].get<double>(), 0);
}

// NeuRRAM's cores (configs/neurram.yaml) read once per neuron readout: 3-bit activations take
// 3 integration steps of 270 ns, 5 ADC steps of 300 ns and a 300-ns phase, 2610 ns, the cores'
// cycle; the 4-bit image 7 x 270 + 5 x 300 + 300 = 3690 ns, two cycles. By hand: conv1 (32 x 32
// outputs on 4 copies) reads 1024 / 4 iterations of two cycles per image at its crossbars;
// layer1.0/conv1 (3 copies, a row's 32 iterations in shares of 10, 11 and 11) is bound by its
// input register, which takes 3 cycles to load a row's first window (144 entries, 64 a cycle)
// and one for each of the 9 others of the first copy's share: 32 rows x 12 cycles.
TEST(SimulateCommand, NeuronCoresAreTimedByTheirReadoutSteps) {
  const std::string json = ::testing::TempDir() + "xbarsim_simulate_neurram.json";
  std::string out;
  ASSERT_EQ(run("simulate --preset resnet20 --timing-only --images 1 --config " + std::string(XBARSIM_SOURCE_DIR) +
                    "/configs/neurram.yaml --json " + json,
                &out),
            0)
      << out;
  const auto j = read_json(json);
  const double cycle_us = (3 * 270 + 5 * 300 + 300) * 1e-3;
  ASSERT_NEAR(1.0 / j["clock_mhz"].get<double>(), cycle_us, 1e-9);
  double layers_uj = 0;
  for (const auto& l : j["layers"]) {
    if (l["name"] == "conv1") {
      EXPECT_EQ(l["replication"], 4);
      EXPECT_NEAR(l["busy_us"].get<double>(), 1024 / 4 * 2 * cycle_us, 1e-6);
      EXPECT_EQ(l["bound_by"], "crossbar");
    }
    if (l["name"] == "layer1.0/conv1") {
      EXPECT_EQ(l["replication"], 3);
      EXPECT_NEAR(l["busy_us"].get<double>(), 32 * (3 + 9) * cycle_us, 1e-6);
      EXPECT_EQ(l["bound_by"], "shift_register");
    }
    EXPECT_NEAR(l["busy_over_estimate"].get<double>(), 1.0, 1e-6) << l["name"];
    EXPECT_GT(l["energy_uj"].get<double>(), 0) << l["name"];  // (it read 0: the cores' energy was only a total)
    layers_uj += l["energy_uj"].get<double>();
  }
  // Neuron cores move no bytes over a bus or mesh of their own: the layers' reads are every
  // joule of the chip's dynamic energy.
  EXPECT_NEAR(layers_uj, j["dynamic_energy_uj_per_image"].get<double>(),
              1e-9 * j["dynamic_energy_uj_per_image"].get<double>());
}

// A sweep of the cells on a machine is refused before anything runs, and the message says how to
// sweep them: on the layer-sized platform (issue 39, item 7).
TEST(SimulateCommand, ASweepOfTheCellsOnAMachineSaysHowToVaryThem) {
  std::string out;
  EXPECT_EQ(run("simulate --preset resnet20 --timing-only --images 1 --config " + std::string(XBARSIM_SOURCE_DIR) +
                    "/configs/isaac.yaml --set 'crossbar.cell_bits=[1,2]'",
                &out),
            2);
  EXPECT_NE(out.find("crossbar.cell_bits 1"), std::string::npos) << out;
  EXPECT_NE(out.find("--set architecture.machine=layer-sized"), std::string::npos) << out;
}

// The bottleneck simulate names is the stage the simulation measured busiest per image, a
// digital one included, and the mapper (simulate's placement, overhead) predicts the same.
// ResNet-20 on ISAAC-CE with two output rows per transaction: every convolution's rows are
// halved (at most 16 x 0.8 us), while layer1.0/add performs 16 x 32 x 32 additions
// on the tile's one shift-and-add unit at 1.2 per ns: 13.65 us, the bottleneck.
TEST(SimulateCommand, NamesTheMeasuredBottleneckAndTheMapperPredictsIt) {
  const std::string json = ::testing::TempDir() + "xbarsim_simulate_bottleneck.json";
  const std::string args = "--preset resnet20 --config " + std::string(XBARSIM_SOURCE_DIR) +
                           "/configs/isaac.yaml --set platform.grain_rows=2 ";
  std::string out;
  ASSERT_EQ(run("simulate " + args + "--timing-only --images 2 --json " + json, &out), 0) << out;
  const auto j = read_json(json);
  std::string busiest;
  double most = -1;
  for (const char* list : {"layers", "digital_stages"})
    for (const auto& s : j[list])
      if (s["busy_us"].get<double>() > most) {
        most = s["busy_us"].get<double>();
        busiest = s["name"].get<std::string>();
      }
  EXPECT_EQ(busiest, "layer1.0/add");
  EXPECT_NEAR(most, 16 * 32 * 32 / 1.2e3, 1e-6);
  EXPECT_EQ(j["bottleneck"]["stage"], busiest);
  EXPECT_NE(out.find("bottleneck: layer1.0/add, busy 13.653 us per image, bound by its add"), std::string::npos) << out;
  EXPECT_EQ(j["placement"]["predicted_bottleneck"], busiest);
  EXPECT_NEAR(j["placement"]["predicted_bottleneck_us"].get<double>(), most, 1e-6);
  ASSERT_EQ(run("overhead " + args, &out), 0) << out;
  EXPECT_NE(out.find("predicted bottleneck layer1.0/add (13.653 us per image)"), std::string::npos) << out;
}
