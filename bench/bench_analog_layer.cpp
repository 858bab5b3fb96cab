// The forward stages of one analog layer on one core: the default design (one 8-bit read per
// vector, analog cells) against the ISAAC-style datapath (configs/isaac.yaml: 8 bit-serial
// reads, 4 cells per weight, an ADC per read), on a ResNet-20 layer's shape (288 x 32, three
// crossbars) and ReLU-like inputs (half of them zero, the rest mostly small). The minimum over
// repetitions is the figure to compare (the machine is shared).
// Run: build/bench/bench_analog_layer --benchmark_repetitions=10 --benchmark_report_aggregates_only=true
// (programming: --benchmark_filter=program --benchmark_repetitions=3)
#include <benchmark/benchmark.h>

#include <random>

#include "sw/analog/analog_layer.h"
#include "sw/analog/synthetic.h"

using namespace xbarsim;

namespace {

constexpr int kRows = 288, kCols = 32, kVectors = 256;

/// configs/default.yaml, or the datapath of configs/isaac.yaml on it.
AnalogConfig design(bool isaac) {
  ConfigTree cfg;
  if (isaac)
    cfg.merge_yaml_text(
        "crossbar: {cell_bits: 2}\n"
        "mapping: {max_rows: 128, max_cols: 128, weight_bits: 8}\n"
        "converters: {input_bits: 8, dac_bits: 1, adc_bits: 8, adc_range: per_read}\n",
        "bench");
  AnalogConfig c = parse_analog_config(cfg);
  c.set_method("calibration", "bench");  // programming in seconds; the forward stages are the same
  return c;
}

/// ReLU outputs: zero half of the time, else exponential with mean x_max / 8 (clipped).
AnalogLayer::RowMat<float> relu_inputs(int n, int k, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::bernoulli_distribution zero(0.5);
  std::exponential_distribution<float> value(8.0f);
  AnalogLayer::RowMat<float> x(n, k);
  for (Eigen::Index i = 0; i < x.size(); ++i) x.data()[i] = zero(rng) ? 0.0f : std::min(1.0f, value(rng));
  return x;
}

void forward(benchmark::State& state, bool isaac) {
  const Eigen::MatrixXd w = synthetic_kernel("gaussian", kRows, kCols, 5);
  AnalogLayer layer(design(isaac), w, 1.0, false, 1);
  layer.program(relu_inputs(512, kRows, 6).cast<double>());
  const AnalogLayer::RowMat<float> x = relu_inputs(kVectors, kRows, 7);
  AnalogLayer::Mat<float> y;
  for (auto _ : state) {
    layer.forward<float>(x, y);
    benchmark::DoNotOptimize(y.data());
  }
  state.counters["vectors/s"] = benchmark::Counter(kVectors, benchmark::Counter::kIsIterationInvariantRate);
}

/// The Python package's Crossbar.matvec case (bench/bench_python.sh): the default design on the
/// paper's largest crossbar (576 x 64), 1024 vectors in double, row-major as NumPy holds them,
/// through the call the binding makes (forward<double>, the output reused). The convenience
/// forward(const MatrixXd&) copies a column-major input to row-major and allocates its result
/// per call, which made this case 2x slower than Python's (its copy 16 %, page faults 20 %).
void matvec_576x64(benchmark::State& state) {
  const Eigen::MatrixXd w = synthetic_kernel("gaussian", 576, 64, 5);
  AnalogLayer layer(design(false), w, 1.0, false, 1);
  layer.program(relu_inputs(512, 576, 6).cast<double>());
  const AnalogLayer::RowMat<double> x = relu_inputs(1024, 576, 7).cast<double>();
  AnalogLayer::Mat<double> y;
  for (auto _ : state) {
    layer.forward<double>(x, y);
    benchmark::DoNotOptimize(y.data());
  }
  state.counters["us/vector"] =
      benchmark::Counter(1024, benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
}

/// Programming at the defaults (conversion + calibration, 144-row crossbars) of an 8192 x 10
/// weight (a large fully connected layer: 57 crossbars) with 256, 512 and 2048 real calibration
/// rows (eval.calibration_samples): the cost must grow no worse than linearly in the rows. Each
/// crossbar once converted the layer's whole range-estimation matrix to take its own columns
/// (0.72 s / 10 s / 41 s: quadratic in the layer's rows, and a cache cliff at 512 rows).
void program_8192x10(benchmark::State& state) {
  const Eigen::MatrixXd w = synthetic_kernel("gaussian", 8192, 10, 5);
  const Eigen::MatrixXd calib = relu_inputs(static_cast<int>(state.range(0)), 8192, 6).cast<double>();
  AnalogConfig c = parse_analog_config(ConfigTree());
  c.solver.threads = 1;
  for (auto _ : state) {
    AnalogLayer layer(c, w, 1.0, false, 1);
    layer.program(calib);
    benchmark::DoNotOptimize(&layer);
  }
  state.counters["us/row"] = benchmark::Counter(static_cast<double>(state.range(0)),
                                                benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
}

double minimum(const std::vector<double>& v) { return *std::min_element(v.begin(), v.end()); }

}  // namespace

BENCHMARK_CAPTURE(forward, default_design, false)->Unit(benchmark::kMicrosecond)->ComputeStatistics("min", minimum);
BENCHMARK_CAPTURE(forward, isaac_style, true)->Unit(benchmark::kMicrosecond)->ComputeStatistics("min", minimum);

BENCHMARK(matvec_576x64)->Unit(benchmark::kMillisecond)->ComputeStatistics("min", minimum);
BENCHMARK(program_8192x10)->Arg(256)->Arg(512)->Arg(2048)->Unit(benchmark::kMillisecond)->ComputeStatistics("min", minimum);

BENCHMARK_MAIN();
