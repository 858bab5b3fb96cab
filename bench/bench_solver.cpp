// Circuit solver benchmarks (Google Benchmark). Run: build/bench/bench_solver
// Sizes are the paper's largest crossbar (576x64) and the ngspice comparison size (128x64).
#include <benchmark/benchmark.h>

#include <random>

#include "sw/circuit/crossbar_solver.h"

using namespace xbarsim;

namespace {

Eigen::MatrixXd random_g(int m, int n, const CrossbarParams& p) {
  std::mt19937_64 rng(42);
  std::uniform_real_distribution<double> u(p.g_min_s, p.g_max_s);
  Eigen::MatrixXd g(m, n);
  for (int i = 0; i < m; ++i)
    for (int j = 0; j < n; ++j) g(i, j) = u(rng);
  return g;
}

Eigen::VectorXd random_v(int m) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(0, 0.4);
  Eigen::VectorXd v(m);
  for (int i = 0; i < m; ++i) v(i) = u(rng);
  return v;
}

CrossbarParams device(bool nonlinear) {
  CrossbarParams p;
  if (nonlinear) {
    p.memristor.model = MemristorModel::Sinh;
    p.transistor.model = TransistorModel::Level1;
  }
  return p;
}

SolverOptions method(const char* name, int threads = 0) {
  SolverOptions o;
  o.method = solver_method_from_name(name);
  o.threads = threads;
  return o;
}

// One vector on a freshly programmed array: nothing reused.
void BM_FromScratch(benchmark::State& st, const char* name, bool nonlinear) {
  const int m = static_cast<int>(st.range(0)), n = static_cast<int>(st.range(1));
  const auto p = device(nonlinear);
  const auto g = random_g(m, n, p);
  const auto v = random_v(m);
  for (auto _ : st) {
    auto s = make_crossbar_solver(p, method(name));
    s->program(g);
    benchmark::DoNotOptimize(s->solve(v).column_current.data());
  }
}

// Programmed once; one more vector solved on it (factorization / precomputation reused).
void BM_Reused(benchmark::State& st, const char* name) {
  const int m = static_cast<int>(st.range(0)), n = static_cast<int>(st.range(1));
  const auto p = device(false);
  auto s = make_crossbar_solver(p, method(name));
  s->program(random_g(m, n, p));
  const auto v = random_v(m);
  for (auto _ : st) benchmark::DoNotOptimize(s->solve(v).column_current.data());
}

// Exact I = V * G_eff once G_eff is known (one GEMV per vector).
void BM_GeffReused(benchmark::State& st) {
  const int m = static_cast<int>(st.range(0)), n = static_cast<int>(st.range(1));
  const auto p = device(false);
  auto s = make_crossbar_solver(p, method("line"));
  s->program(random_g(m, n, p));
  const Eigen::MatrixXd geff = s->effective_matrix();
  const Eigen::RowVectorXd v = random_v(m).transpose();
  Eigen::RowVectorXd out(n);
  for (auto _ : st) {
    out.noalias() = v * geff;
    benchmark::DoNotOptimize(out.data());
  }
}

// G_eff from scratch: program + min(m, n) solves (all threads unless threads=1).
void BM_GeffFromScratch(benchmark::State& st, const char* name, int threads) {
  const int m = static_cast<int>(st.range(0)), n = static_cast<int>(st.range(1));
  const auto p = device(false);
  const auto g = random_g(m, n, p);
  for (auto _ : st) {
    auto s = make_crossbar_solver(p, method(name, threads));
    s->program(g);
    benchmark::DoNotOptimize(s->effective_matrix().data());
  }
}

}  // namespace

BENCHMARK_CAPTURE(BM_FromScratch, line_linear, "line", false)
    ->Args({128, 64})
    ->Args({576, 64})
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_FromScratch, direct_linear, "direct", false)
    ->Args({128, 64})
    ->Args({576, 64})
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_FromScratch, line_nonlinear, "line", true)
    ->Args({128, 64})
    ->Args({576, 64})
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_FromScratch, direct_nonlinear, "direct", true)
    ->Args({128, 64})
    ->Args({576, 64})
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_Reused, line, "line")->Args({576, 64})->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_Reused, direct_factorization, "direct")->Args({576, 64})->Unit(benchmark::kMillisecond);
BENCHMARK(BM_GeffReused)->Args({576, 64})->Unit(benchmark::kMicrosecond);
BENCHMARK_CAPTURE(BM_GeffFromScratch, line_1thread, "line", 1)
    ->Args({128, 64})
    ->Args({576, 64})
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_GeffFromScratch, line_all_threads, "line", 0)
    ->Args({128, 64})
    ->Args({576, 64})
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_GeffFromScratch, direct, "direct", 0)->Args({576, 64})->Unit(benchmark::kMillisecond);

BENCHMARK_MAIN();
