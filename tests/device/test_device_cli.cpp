// Bad device input through the executable (issue 40, "Done when": bad input): every case exits 2
// with one message naming the key (or the model file's key), never a crash or a silent default.
#include <gtest/gtest.h>

#include <unistd.h>

#include <cstdio>
#include <fstream>
#include <functional>
#include <nlohmann/json.hpp>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include "tests/app/cli_test_util.h"

namespace {

using xbarsim_test::Result;

const std::string kStudy = "xbar-study --set study.rows=8 --set study.cols=4 --set study.vectors=20 ";

int count(const std::string& s, const std::string& part) {
  int n = 0;
  for (size_t p = s.find(part); p != std::string::npos; p = s.find(part, p + 1)) ++n;
  return n;
}

/// Exit 2, one error message, naming `key`.
void expect_input_error(const std::string& args, const std::string& key) {
  const Result r = xbarsim_test::run_xbarsim(kStudy + args);
  EXPECT_EQ(r.code, 2) << args << "\n" << r.out;
  EXPECT_EQ(count(r.out, ": error:"), 1) << args << "\n" << r.out;
  EXPECT_NE(r.out.find(key), std::string::npos) << args << ": message does not name " << key << "\n" << r.out;
  EXPECT_EQ(r.out.find("internal error"), std::string::npos) << args << "\n" << r.out;
}

std::string slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

std::string write(const std::string& name, const std::string& text) {
  const std::string path = "/tmp/xbarsim_devtest_" + std::to_string(getpid()) + "_" + name + ".yaml";
  std::ofstream(path, std::ios::binary) << text;
  return path;
}

/// The preset's text without the line of `key` (a dotted path: the line "  leaf:" under the
/// line "section:", or a top-level "key:").
std::string without(const std::string& text, const std::string& key) {
  const size_t dot = key.find('.');
  const std::string section = dot == std::string::npos ? "" : key.substr(0, dot);
  const std::string leaf = dot == std::string::npos ? key : key.substr(dot + 1);
  std::istringstream in(text);
  std::string line, out, current;
  bool removed = false, skipping = false;
  while (std::getline(in, line)) {
    const bool top = !line.empty() && line[0] != ' ' && line[0] != '#';
    if (top) current = line.substr(0, line.find(':'));
    if (skipping && !top && !line.empty() && line.compare(0, 4, "    ") == 0) continue;  // the entries of a removed list
    skipping = false;
    const std::string indent = section.empty() ? "" : "  ";
    if (!removed && current == (section.empty() ? leaf : section) && line.compare(0, indent.size() + leaf.size() + 1,
                                                                             indent + leaf + ":") == 0) {
      removed = true;
      skipping = true;
      continue;
    }
    out += line + "\n";
  }
  EXPECT_TRUE(removed) << key;
  return out;
}

}  // namespace

TEST(DeviceCli, BadSigmasRatesTimesAndModelsExit2NamingTheKey) {
  // Negative sigma (the constant model's).
  expect_input_error("--set device.model=constant --set device.program_sigma_us=-1", "device.program_sigma_us");
  expect_input_error("--set device.model=constant --set device.read_sigma_us=-0.5", "device.read_sigma_us");
  // A constant model's sigma under a published model (which states its own).
  expect_input_error("--set device.model=rram-cmo --set device.program_sigma_us=0.5", "device.program_sigma_us");
  // Rates above 1, below 0, or summing above 1.
  expect_input_error("--set device.stuck_at_gmin=1.5", "device.stuck_at_gmin");
  expect_input_error("--set device.stuck_at_gmax=-0.1", "device.stuck_at_gmax");
  expect_input_error("--set device.stuck_at_gmin=0.6 --set device.stuck_at_gmax=0.6", "device.stuck_at_gmax");
  // Negative, NaN or infinite time (also inside a sweep).
  for (const char* t : {"-1", "-1e-9", "nan", "NaN", "inf", "[1,nan]", "[60,-1]"})
    expect_input_error(std::string("--set device.model=pcm-joshi2020 --set device.time_s=") + t, "device.time_s");
  // An unknown model, a missing model file; an unknown compensation.
  expect_input_error("--set device.model=pcm-joshi2021", "device.model");
  expect_input_error("--set device.model=/nonexistent/pcm.yaml", "device.model");
  expect_input_error("--set device.compensation=drift", "device.compensation");
  // The removed key: one message naming it and the key that replaces it (--set and a config file).
  expect_input_error("--set noise.sigma_us=0.5", "noise.sigma_us");
  expect_input_error("--set noise.sigma_us=0.5", "device.program_sigma_us");
  const std::string old = write("old", "noise:\n  sigma_us: 0.5\n");
  expect_input_error("--config " + old, "device.program_sigma_us");
  std::remove(old.c_str());
}

TEST(DeviceCli, AModelFileMissingAnyKeyOrWithANegativeSpreadExits2NamingIt) {
  struct Preset {
    const char* name;
    std::vector<std::string> keys;
  };
  const std::vector<std::string> common = {"name",          "source",       "range.g_min_us",      "range.g_max_us",
                                           "programming.sigma_us", "read.relative", "read.sqrt_relative",
                                           "read.sigma_us", "clip_to_range"};
  const std::vector<Preset> presets = {
      {"pcm-joshi2020",
       {"drift.t0_s", "drift.nu_mean", "drift.nu_std", "noise_1f.t_read_s", "noise_1f.t_offset_s", "noise_1f.amplitude",
        "noise_1f.coeff", "noise_1f.exponent", "noise_1f.max"}},
      {"rram-wan2022", {"relaxation.times_s", "relaxation.sigma_us", "relaxation.shift_us"}},
      {"rram-cmo", {"relaxation.times_s", "relaxation.sigma_us", "relaxation.shift_us", "noise_1f.coeff"}},
  };
  for (const Preset& p : presets) {
    const std::string text = slurp(std::string(XBARSIM_SOURCE_DIR) + "/configs/devices/" + p.name + ".yaml");
    ASSERT_FALSE(text.empty()) << p.name;
    // The copy as it is runs (the test's edits, not the copy, make the errors).
    const std::string same = write("same", text);
    const Result ok = xbarsim_test::run_xbarsim(kStudy + "--set device.model=" + same);
    EXPECT_EQ(ok.code, 0) << p.name << "\n" << ok.out;
    std::vector<std::string> keys = common;
    keys.insert(keys.end(), p.keys.begin(), p.keys.end());
    for (const std::string& key : keys) {
      const std::string path = write("missing", without(text, key));
      expect_input_error("--set device.model=" + path, "'" + key + "'");
    }
    std::remove(same.c_str());
  }
  const std::string pcm = slurp(std::string(XBARSIM_SOURCE_DIR) + "/configs/devices/pcm-joshi2020.yaml");
  const std::string cmo = slurp(std::string(XBARSIM_SOURCE_DIR) + "/configs/devices/rram-cmo.yaml");
  auto edited = [](std::string text, const std::string& from, const std::string& to) {
    const size_t p = text.find(from);
    EXPECT_NE(p, std::string::npos) << from;
    if (p != std::string::npos) text.replace(p, from.size(), to);
    return write("edited", text);
  };
  // Negative spreads: one read's sigma, a programming sigma polynomial negative on the range,
  // a relaxation spread negative, the drift exponent's spread clipped below 0.
  expect_input_error("--set device.model=" + edited(pcm, "sigma_us: 0.0", "sigma_us: -0.1"), "read.sigma_us");
  expect_input_error("--set device.model=" + edited(pcm, "relative: 0.0\n", "relative: -0.01\n"), "read.relative");
  expect_input_error(
      "--set device.model=" + edited(pcm, "[0.26348, 1.9650, -1.1731]", "[-0.26348, -1.9650, 1.1731]"),
      "programming.sigma_us");
  expect_input_error("--set device.model=" + edited(cmo, "- [0.41183342]", "- [-0.41183342]"), "relaxation.sigma_us");
  expect_input_error("--set device.model=" + edited(pcm, "-0.0059, 0.008, 0.045", "-0.0059, -0.008, 0.045"),
                     "drift.nu_std");
  expect_input_error("--set device.model=" + edited(pcm, "0.0244, 0.049, 0.1]", "0.0244, 0.1, 0.049]"),
                     "drift.nu_mean");
  // A flag that is not true or false is an error, not false.
  expect_input_error("--set device.model=" + edited(cmo, "incremental: true", "incremental: yes"),
                     "relaxation.incremental");
  expect_input_error("--set device.model=" + edited(pcm, "clip_to_range: false", "clip_to_range: no"), "clip_to_range");
  // NaN or negative times in the file.
  expect_input_error("--set device.model=" + edited(pcm, "t0_s: 20.0", "t0_s: nan"), "drift.t0_s");
  expect_input_error("--set device.model=" + edited(cmo, "times_s: [1.0, 1.0e10]", "times_s: [1.0, -1.0e10]"),
                     "relaxation.times_s");
  std::remove(write("edited", "").c_str());
  std::remove(write("missing", "").c_str());
}

TEST(DeviceCli, DeviceDrawsDoNotDependOnTheThreadCount) {
  // Programming error, faults, relaxation and read noise on every read, 1 thread against 2: the
  // same numbers (everything but the wall-clock times).
  auto run = [](int threads) {
    const std::string json = "/tmp/xbarsim_devtest_" + std::to_string(getpid()) + "_threads.json";
    const Result r = xbarsim_test::run_xbarsim(
        "xbar-study --set study.rows=64 --set study.cols=16 --set study.vectors=300 --set device.model=rram-wan2022 "
        "--set device.time_s=86400 --set device.stuck_at_gmin=0.01 --set converters.readout_noise_na=5 "
        "--set solver.threads=" + std::to_string(threads) + " --json " + json);
    EXPECT_EQ(r.code, 0) << r.out;
    nlohmann::json j = nlohmann::json::parse(slurp(json), nullptr, false);
    std::remove(json.c_str());
    // Drop the wall-clock times (keys ending in _time_s, at any depth).
    std::function<void(nlohmann::json&)> strip = [&](nlohmann::json& n) {
      if (n.is_object()) {
        for (auto it = n.begin(); it != n.end();) {
          const std::string k = it.key();
          if (k.size() > 7 && k.compare(k.size() - 7, 7, "_time_s") == 0) {
            it = n.erase(it);
          } else {
            strip(*it);
            ++it;
          }
        }
      } else if (n.is_array()) {
        for (auto& e : n) strip(e);
      }
    };
    strip(j);
    return j;
  };
  const nlohmann::json one = run(1), two = run(2);
  EXPECT_FALSE(one.is_discarded());
  EXPECT_EQ(one, two);
}
