// IR drops under current and voltage sensing (docs/physics.md, "Voltage-mode sensing"): the
// outputs of a 256x256 crossbar with the default wires against the same crossbar with ideal
// wires, for RRAM conductances (configs/devices/rram-wan2022.yaml: 1-40 uS). A printout, not a
// test: build the target bench_ir_drop_sensing and run it (a few seconds).
#include <cstdio>
#include <random>

#include "sw/circuit/crossbar_solver.h"
#include "sw/circuit/device_models.h"

using namespace xbarsim;

namespace {
struct Errors {
  double mean = 0, worst = 0, worst_of_range = 0, fitted_worst = 0;
};

/// |out - ideal| / (largest |ideal|): mean and worst; the worst relative to the ideal outputs'
/// range (max - min, the part that carries information); and the worst after a per-column gain
/// and offset fitted over the vectors (what calibration can remove), relative to the range.
Errors errors(const Eigen::MatrixXd& out, const Eigen::MatrixXd& ideal) {
  Errors e;
  const double scale = ideal.cwiseAbs().maxCoeff(), range = ideal.maxCoeff() - ideal.minCoeff();
  const Eigen::ArrayXXd d = (out - ideal).array().abs() / scale;
  e.mean = d.mean();
  e.worst = d.maxCoeff();
  e.worst_of_range = d.maxCoeff() * scale / range;
  for (Eigen::Index j = 0; j < out.cols(); ++j) {
    Eigen::MatrixXd a(out.rows(), 2);
    a.col(0) = out.col(j);
    a.col(1).setOnes();
    const Eigen::Vector2d c = a.colPivHouseholderQr().solve(ideal.col(j));
    e.fitted_worst = std::max(e.fitted_worst, ((a * c - ideal.col(j)).cwiseAbs().maxCoeff()) / range);
  }
  return e;
}
}  // namespace

int main() {
  const int m = 256, n = 256, vectors = 32;
  std::printf("256x256 crossbar, r_wire = r_in = r_out = 1 ohm, G uniform in [g_min, g_max], %d input vectors\n"
              "uniform in [0, 0.4] V; error = |output - ideal-wire output| / largest ideal output (of range: / (max - min)\n"
              "of the ideal outputs); after fit: per-column gain and offset fitted over the vectors, / range\n\n",
              vectors);
  std::printf("%-12s %-12s %-8s %11s %11s %15s %16s\n", "G range", "devices", "sensing", "mean error", "worst error",
              "worst of range", "after fit, range");
  for (const auto& range : {std::pair<double, double>{1e-6, 40e-6}, std::pair<double, double>{20e-6, 70e-6}})
    for (const bool nonlinear : {false, true}) {
      CrossbarParams p;
      p.g_min_s = range.first;
      p.g_max_s = range.second;
      if (nonlinear) {
        p.memristor.model = MemristorModel::Sinh;
        p.transistor.model = TransistorModel::Level1;
      }
      std::mt19937_64 rng(42);
      std::uniform_real_distribution<double> ug(p.g_min_s, p.g_max_s), uv(0.0, 0.4);
      Eigen::MatrixXd g(m, n), v(vectors, m);
      for (int i = 0; i < g.size(); ++i) g(i) = ug(rng);
      for (int i = 0; i < v.size(); ++i) v(i) = uv(rng);
      for (const Sensing sensing : {Sensing::Current, Sensing::Voltage}) {
        p.sensing = sensing;
        CrossbarParams ideal_p = p;  // the same devices on (nearly) ideal wires
        ideal_p.r_wire_ohm = ideal_p.r_in_ohm = ideal_p.r_out_ohm = 1e-6;
        auto real = make_crossbar_solver(p, SolverOptions{});
        auto ideal = make_crossbar_solver(ideal_p, SolverOptions{});
        real->program(g);
        ideal->program(g);
        const Errors e = errors(real->column_outputs(v), ideal->column_outputs(v));
        char label[32];
        std::snprintf(label, sizeof label, "%.0f-%.0f uS", p.g_min_s * 1e6, p.g_max_s * 1e6);
        std::printf("%-12s %-12s %-8s %10.3f%% %10.3f%% %14.2f%% %15.3f%%\n", label, nonlinear ? "sinh+level1" : "linear",
                    to_string(sensing), 100 * e.mean, 100 * e.worst, 100 * e.worst_of_range, 100 * e.fitted_worst);
      }
    }
  return 0;
}
