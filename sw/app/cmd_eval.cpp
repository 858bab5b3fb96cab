// xbarsim eval: accuracy of a whole network on crossbars, with per-layer error propagation.
#include <chrono>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <mutex>

#include "sw/app/app_common.h"
#include "sw/app/model_source.h"
#include "sw/inference/crossbar_backend.h"

namespace xbarsim {

namespace {

struct LayerTally {
  double sum = 0, worst = 0;
  long long count = 0;
};

/// Relative errors of one image's layer output (crossbar vs software), each normalised by
/// the output channel's calibration range.
LayerTally layer_error(const LayerStatistics& st, const Eigen::MatrixXf& s, const Eigen::MatrixXf& c) {
  LayerTally ty;
  for (Eigen::Index col = 0; col < s.cols(); ++col) {
    const double range = std::max(st.out_hi(col) - st.out_lo(col), 1e-30);
    for (Eigen::Index r = 0; r < s.rows(); ++r) {
      const double e = std::abs(static_cast<double>(c(r, col)) - s(r, col)) / range;
      ty.sum += e;
      ty.worst = std::max(ty.worst, e);
    }
  }
  ty.count = s.size();
  return ty;
}

struct EvalResult {
  nlohmann::json json;
  std::vector<std::string> csv_rows;
};

EvalResult evaluate(const Model& model, const ConfigTree& cfg, const Dataset& test, const Dataset& calib,
                    const std::string& label) {
  const AnalogConfig ac = parse_analog_config(cfg);
  const auto t0 = std::chrono::steady_clock::now();
  CrossbarBackend xb(model, ac);
  {
    ProgressBar bar(static_cast<int>(model.linear.size()), "programming " + label);
    const int samples = cfg.get_int32("eval.calibration_samples");
    if (samples < ac.calibration_samples)
      throw InputError("configuration key 'eval.calibration_samples' must be >= calibration.samples");
    xb.program(calib, samples, [&](int d, int) { bar.update(d); });
  }
  const auto t1 = std::chrono::steady_clock::now();
  int images = test.count();
  std::string note;
  if (!ac.xbar.is_linear()) {
    const int nl = cfg.get_int32("eval.nonlinear_images");
    if (nl < images) {
      images = nl;
      note = "nonlinear devices: every crossbar input vector is a Newton circuit solve; evaluated on the first " +
             std::to_string(images) + " images only (eval.nonlinear_images)";
      std::cerr << "xbarsim eval: " << note << "\n";
    }
  }
  const int L = static_cast<int>(model.linear.size());
  const int threads = std::max(1, std::min(resolve_threads(ac.solver.threads), images));
  // Per image and layer: sum and worst of the relative errors; reduced in image order after
  // the parallel loop, so the figures do not depend on the number of threads.
  std::vector<LayerTally> tallies(static_cast<size_t>(images) * L);
  std::vector<char> sw_correct(images, 0), xb_correct(images, 0);
  std::mutex progress_mu;
  int done = 0;
  ProgressBar bar(images, "evaluating  " + label);
  // Images are evaluated in parallel; inside an image, linear layers run serially (the
  // solver's own threads are used for the programming step only).
  parallel_for(threads, threads, [&](int t) {
    SoftwareBackend sw(model);
    LayerTrace sw_trace, xb_trace;
    sw_trace.record_inputs = xb_trace.record_inputs = false;
    std::vector<float> x(model.input.size());
    for (int k = t; k < images; k += threads) {
      test.preprocess(k, model.pre, x.data());
      Eigen::Index a, b;
      run_image(model, x.data(), sw, &sw_trace).maxCoeff(&a);
      run_image(model, x.data(), xb, &xb_trace).maxCoeff(&b);
      sw_correct[k] = a == test.labels[k];
      xb_correct[k] = b == test.labels[k];
      for (int l = 0; l < L; ++l)
        tallies[static_cast<size_t>(k) * L + l] = layer_error(xb.statistics(l), sw_trace.outputs[l], xb_trace.outputs[l]);
      std::lock_guard<std::mutex> lock(progress_mu);
      bar.update(++done);
    }
  });
  bar.finish();
  const auto t2 = std::chrono::steady_clock::now();
  EvalResult r;
  nlohmann::json& j = r.json;
  int swc = 0, xbc = 0;
  for (int k = 0; k < images; ++k) {
    swc += sw_correct[k];
    xbc += xb_correct[k];
  }
  j["model"] = model.path;
  j["dataset"] = test.name;
  j["images"] = images;
  j["software_accuracy"] = static_cast<double>(swc) / images;
  j["crossbar_accuracy"] = static_cast<double>(xbc) / images;
  j["method"] = ac.method;
  j["dac_bits"] = ac.dac_bits ? nlohmann::json(ac.dac_bits) : nlohmann::json("none");
  j["adc_bits"] = ac.adc_bits ? nlohmann::json(ac.adc_bits) : nlohmann::json("none");
  j["sigma_us"] = ac.sigma_s * 1e6;
  j["memristor_model"] = to_string(ac.xbar.memristor.model);
  j["transistor_model"] = to_string(ac.xbar.transistor.model);
  j["max_rows"] = ac.max_rows ? nlohmann::json(ac.max_rows) : nlohmann::json("unbounded");
  j["max_cols"] = ac.max_cols ? nlohmann::json(ac.max_cols) : nlohmann::json("unbounded");
  if (!note.empty()) j["note"] = note;
  j["program_time_s"] = std::chrono::duration<double>(t1 - t0).count();
  j["evaluate_time_s"] = std::chrono::duration<double>(t2 - t1).count();
  j["images_per_s"] = images / std::max(1e-9, std::chrono::duration<double>(t2 - t1).count());
  j["layers"] = nlohmann::json::array();
  int crossbars = 0, adcs = 0, oor = 0;
  for (int l = 0; l < L; ++l) {
    LayerTally sum;
    for (int k = 0; k < images; ++k) {
      const LayerTally& ty = tallies[static_cast<size_t>(k) * L + l];
      sum.sum += ty.sum;
      sum.count += ty.count;
      sum.worst = std::max(sum.worst, ty.worst);
    }
    const AnalogLayer& al = xb.layer(l);
    int l_oor = 0, l_adcs = 0;
    double min_gain = 1;
    for (const auto& rep : al.reports()) {
      l_oor += rep.out_of_range_cells;
      l_adcs += (rep.physical_cols + 127) / 128;
      min_gain = std::min(min_gain, rep.min_column_gain);
    }
    crossbars += al.crossbars();
    adcs += l_adcs;
    oor += l_oor;
    const LinearLayer& lin = model.linear[l];
    const double mean = sum.count ? sum.sum / sum.count : 0.0;
    j["layers"].push_back({{"name", lin.name},
                           {"kernel", {lin.k_h, lin.k_w, lin.c_in, lin.c_out}},
                           {"rows", lin.rows()},
                           {"cols", lin.c_out},
                           {"crossbars", al.crossbars()},
                           {"adcs", l_adcs},
                           {"iterations", lin.iterations()},
                           {"input_full_scale", xb.statistics(l).x_max},
                           {"signed_inputs", xb.statistics(l).signed_inputs},
                           {"out_of_range_cells", l_oor},
                           {"min_column_gain", min_gain},
                           {"mean_relative_error", mean},
                           {"worst_relative_error", sum.worst}});
    char line[512];
    std::snprintf(line, sizeof line, "%d,%s,%d,%d,%d,%.6g,%.6g", l, lin.name.c_str(), lin.rows(), lin.c_out,
                  al.crossbars(), mean, sum.worst);
    r.csv_rows.push_back(line);
  }
  j["crossbars"] = crossbars;
  j["adcs"] = adcs;
  j["out_of_range_cells"] = oor;
  return r;
}

int cmd_eval(int argc, char** argv) {
  const CliArgs args(argc, argv, 0, {"--model", "--dataset", "--images", "--offset"});
  check_outputs(args, {"--json", "--csv"});
  std::vector<std::string> sets = args.sets();
  if (args.has("--images")) sets.push_back("eval.images=" + args.get("--images"));
  if (args.has("--offset")) sets.push_back("eval.offset=" + args.get("--offset"));
  const ConfigTree base = ConfigTree::load(args.get("--config"), sets);
  // The command's own keys first, so a bad value is reported before any file is read.
  const std::string n_str = base.get_string("eval.images");
  const int offset = base.get_int32("eval.offset");
  int count = n_str == "all" ? -1 : base.get_int32("eval.images");
  const int ncal = base.get_int32("eval.calibration_images");
  const auto combos = sweep_combinations(base);
  for_each_sweep_point(base, combos, [](const ConfigTree& cfg) { parse_analog_config(cfg); });
  Model model = load_onnx_model(find_model_file(args.require("--model"), base));
  apply_preprocessing_overrides(base, model.pre, model.input.c);
  const std::string dataset = args.has("--dataset") ? args.get("--dataset") : model.dataset;
  if (dataset.empty()) throw InputError("the model names no dataset in its metadata: give --dataset");
  const std::string dir = resolve_data_dir(base);
  if (dataset == "mnist") {
    // MNIST has no calibration split here: test images 9000.. calibrate and are never evaluated.
    const int limit = kMnistCalibrationStart - offset;
    if (limit <= 0) throw InputError("MNIST test images from 9000 on are the calibration set (see README)");
    if (count < 0 || count > limit) {
      count = limit;
      std::cerr << "xbarsim eval: MNIST images 9000-9999 are used for calibration; evaluating images " << offset
                << ".." << offset + count - 1 << "\n";
    }
  }
  const Dataset test = load_dataset(dataset, dir, "test", offset, count);
  const Dataset calib = load_dataset(dataset, dir, "calib", 0, ncal);
  if (!(test.shape == model.input))
    throw InputError("dataset images are " + std::to_string(test.shape.c) + "x" + std::to_string(test.shape.h) + "x" +
                     std::to_string(test.shape.w) + " but the model expects " + std::to_string(model.input.c) + "x" +
                     std::to_string(model.input.h) + "x" + std::to_string(model.input.w));

  SweepCsv csv(args.get("--csv"), combos.front(), "layer,name,rows,cols,crossbars,mean_relative_error,worst_relative_error");
  nlohmann::json all = nlohmann::json::array();
  std::printf("%-44s %7s %9s %9s %8s %7s %9s\n", "run", "images", "software", "crossbar", "xbars", "oor", "img/s");
  int run = 0;
  for (const auto& combo : combos) {
    const std::string label = sweep_label(combo);
    EvalResult r = evaluate(model, sweep_point(base, combo), test, calib, label);
    for (const auto& kv : combo) r.json["sweep"][kv.first] = kv.second;
    std::printf("%-44s %7d %8.2f%% %8.2f%% %8d %7d %9.1f\n", label.c_str(), r.json["images"].get<int>(),
                100 * r.json["software_accuracy"].get<double>(), 100 * r.json["crossbar_accuracy"].get<double>(),
                r.json["crossbars"].get<int>(), r.json["out_of_range_cells"].get<int>(),
                r.json["images_per_s"].get<double>());
    std::fflush(stdout);
    if (combos.size() == 1) {
      std::printf("\n%-34s %6s %5s %6s %12s %12s\n", "layer", "rows", "cols", "xbars", "mean_RE_%", "worst_RE_%");
      for (const auto& l : r.json["layers"])
        std::printf("%-34s %6d %5d %6d %12.4f %12.4f\n", l["name"].get<std::string>().c_str(), l["rows"].get<int>(),
                    l["cols"].get<int>(), l["crossbars"].get<int>(), 100 * l["mean_relative_error"].get<double>(),
                    100 * l["worst_relative_error"].get<double>());
    }
    if (csv.enabled())
      for (const auto& row : r.csv_rows) csv.row(run, combo) << "," << row << "\n";
    all.push_back(r.json);
    ++run;
  }
  csv.commit();
  if (args.has("--json")) write_json(args.get("--json"), combos.size() == 1 ? all[0] : all);
  return 0;
}

}  // namespace

namespace {
const CommandRegistrar kRegister{
    "eval", cmd_eval,
    "eval --model M.onnx [--dataset cifar10|mnist] [--images N] [--offset K] [--config F] [--set k=v]...\n"
    "      accuracy on crossbars vs software, per-layer error propagation; list values sweep"};
}  // namespace

}  // namespace xbarsim
