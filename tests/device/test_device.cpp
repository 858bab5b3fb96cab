// The device models against their published formulas (issue 40, "Done when": statistics, faults,
// reproducibility). Every expected value is computed here from the numbers of the sources, typed
// in below (aihwkit's PCMLikeNoiseModel, ReRamWan2022NoiseModel and ReRamCMONoiseModel, as
// docs/physics.md cites them): never from Device's own formula helpers or the model files.
//
// Statistics: 10^6 cells per state bin (a 1000 x 1000 matrix of one target, a stream of its own).
// Tolerances are sampling errors: kZ = 5 standard errors, so a correct model fails a check with
// probability below 6e-7 (the draws are seeded, so a pass is reproducible; a model off by a few
// standard errors of 10^6 cells, i.e. ~0.5 % in sigma, fails).
//  - a mean: SE = sd / sqrt(n);
//  - a standard deviation: SE = sd sqrt((kurtosis - 1) / (4 n)) (the delta method on the sample
//    variance, kurtosis from the sample: 3 for a normal, so sd / sqrt(2 n));
//  - a median of a normal: SE = sqrt(pi / 2) sd / sqrt(n);
//  - a quantile q of a sample against a reference Monte Carlo of the formulas (m draws): the
//    reference's CDF at the sample's quantile differs from q by SE = sqrt(q (1 - q) (1/n + 1/m))
//    (both empirical CDFs are binomial at a point); no density estimate needed.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

#include "sw/analog/analog_layer.h"
#include "sw/common/config.h"
#include "sw/common/seed.h"
#include "sw/device/device.h"

using namespace xbarsim;

namespace {

constexpr double kUs = 1e-6;
constexpr double kDay = 86400.0, kTwoDays = 172800.0, kYear = 365.25 * 86400.0;
constexpr int kSide = 1000;  // 1000 x 1000 = 10^6 cells per bin
constexpr double kZ = 5;     // standard errors of every statistical check

DeviceSpec preset(const std::string& name) {
  return parse_device_spec(ConfigTree::load("", {"device.model=" + name}));
}

/// Programs 10^6 cells of target g_target (S) on stream `stream`: the targets and the programmed state.
struct Bin {
  Eigen::MatrixXd target, prog;
  FaultMap faults;
};
Bin program_bin(const Device& d, double g_target, uint64_t stream) {
  Bin b;
  b.target = Eigen::MatrixXd::Constant(kSide, kSide, g_target);
  b.prog = b.target;
  d.program(b.prog, b.faults, stream);
  return b;
}

struct Stats {
  double n = 0, mean = 0, sd = 0, kurtosis = 3;
  /// Standard errors of the mean and of the sd.
  double se_mean() const { return sd / std::sqrt(n); }
  double se_sd() const { return sd * std::sqrt((kurtosis - 1) / (4 * n)); }
};
Stats stats(const double* v, size_t n) {
  Stats s;
  s.n = static_cast<double>(n);
  double sum = 0;
  for (size_t i = 0; i < n; ++i) sum += v[i];
  s.mean = sum / s.n;
  double m2 = 0, m4 = 0;
  for (size_t i = 0; i < n; ++i) {
    const double d = v[i] - s.mean, d2 = d * d;
    m2 += d2;
    m4 += d2 * d2;
  }
  m2 /= s.n;
  m4 /= s.n;
  s.sd = std::sqrt(m2 * s.n / (s.n - 1));
  s.kurtosis = m2 > 0 ? m4 / (m2 * m2) : 3;
  return s;
}
Stats stats(const std::vector<double>& v) { return stats(v.data(), v.size()); }

double quantile(std::vector<double> v, double q) {
  const auto k = static_cast<std::ptrdiff_t>(q * static_cast<double>(v.size() - 1));
  std::nth_element(v.begin(), v.begin() + k, v.end());
  return v[static_cast<size_t>(k)];
}
/// The quantiles qs (increasing) of v: one copy, nth_element on what is left above the last one.
std::vector<double> quantiles(const std::vector<double>& v, const std::vector<double>& qs) {
  std::vector<double> c = v, out;
  auto from = c.begin();
  for (double q : qs) {
    const auto k = c.begin() + static_cast<std::ptrdiff_t>(q * static_cast<double>(c.size() - 1));
    std::nth_element(from, k, c.end());
    out.push_back(*k);
    from = k;
  }
  return out;
}
/// The fractions of v at or below each of xs.
std::vector<double> cdf(const std::vector<double>& v, const std::vector<double>& xs) {
  std::vector<double> n(xs.size(), 0.0);
  for (double x : v)
    for (size_t i = 0; i < xs.size(); ++i) n[i] += x <= xs[i];
  for (double& f : n) f /= static_cast<double>(v.size());
  return n;
}

double normal_cdf(double z) { return 0.5 * std::erfc(-z / std::sqrt(2.0)); }
double normal_pdf(double z) { return std::exp(-0.5 * z * z) / std::sqrt(2 * M_PI); }

/// Mean and sd of max(N(mu, s^2), c) in closed form (a draw clamped at c: the open cell).
void clamped_normal(double mu, double s, double c, double& mean, double& sd) {
  const double a = (c - mu) / s, below = normal_cdf(a), above = 1 - below, pdf = normal_pdf(a);
  mean = c * below + mu * above + s * pdf;
  const double second = c * c * below + (mu * mu + s * s) * above + s * pdf * (mu + c);
  sd = std::sqrt(second - mean * mean);
}

/// Expects the sample's mean and sd to be mu and sigma within kZ standard errors.
void expect_moments(const Stats& s, double mu, double sigma, const std::string& what) {
  EXPECT_NEAR(s.mean, mu, kZ * s.se_mean()) << what << ": mean";
  EXPECT_NEAR(s.sd, sigma, kZ * s.se_sd()) << what << ": sd";
}

/// Expects sample `a` (the code's) and sample `b` (a Monte Carlo of the formulas) to have the
/// same mean, sd and quantiles within kZ standard errors of their difference.
void expect_same_distribution(const std::vector<double>& a, const std::vector<double>& b, const std::string& what) {
  const Stats sa = stats(a), sb = stats(b);
  EXPECT_NEAR(sa.mean, sb.mean, kZ * std::hypot(sa.se_mean(), sb.se_mean())) << what << ": mean";
  EXPECT_NEAR(sa.sd, sb.sd, kZ * std::hypot(sa.se_sd(), sb.se_sd())) << what << ": sd";
  const double n = static_cast<double>(a.size()), m = static_cast<double>(b.size());
  const std::vector<double> qs = {0.01, 0.05, 0.25, 0.5, 0.75, 0.95, 0.99};
  const std::vector<double> f = cdf(b, quantiles(a, qs));
  for (size_t i = 0; i < qs.size(); ++i) {
    const double q = qs[i];
    EXPECT_NEAR(f[i], q, kZ * std::sqrt(q * (1 - q) * (1 / n + 1 / m))) << what << ": quantile " << q;
  }
}

std::vector<double> as_vector(const Eigen::MatrixXd& m) { return {m.data(), m.data() + m.size()}; }

// ---- The published numbers (docs/physics.md, device models; aihwkit's fits), typed in here. ----

// pcm-joshi2020: Nandakumar et al. 2019 / Joshi et al. 2020 as aihwkit's PCMLikeNoiseModel.
namespace pcm {
constexpr double g_max_us = 25.0;
/// Programming sigma (uS) at x = G_T / g_max: 0.26348 + 1.9650 x - 1.1731 x^2 (g_max = the 25 uS reference).
double sigma_prog_us(double x) { return 0.26348 + 1.9650 * x - 1.1731 * x * x; }
double nu_mean(double x) { return std::clamp(-0.0155 * std::log(std::max(x, 1e-7)) + 0.0244, 0.049, 0.1); }
double nu_std(double x) { return std::clamp(-0.0125 * std::log(std::max(x, 1e-7)) - 0.0059, 0.008, 0.045); }
constexpr double t0_s = 20.0, t_read_s = 250e-9;
/// Q_s of the accumulated 1/f noise at x_prog = G_prog / g_max.
double q_s(double x_prog) { return std::min(0.0088 / std::max(std::pow(x_prog, 0.65), 1e-3), 0.2); }
/// G(t) / G_prog of one cell: drift (nu = |N(mu, s)|) then 1/f noise, clamped at 0; t after programming.
double ratio(double g_prog_us, double x_target, double t, std::mt19937_64& rng) {
  std::normal_distribution<double> n01;
  const double te = t + t0_s;
  const double nu = std::abs(nu_mean(x_target) + nu_std(x_target) * n01(rng));
  const double g_drift = g_prog_us * std::pow(te / t0_s, -nu);
  const double s = q_s(g_prog_us / g_max_us) * std::sqrt(std::log((te + t_read_s) / (2 * t_read_s)));
  return std::max(g_drift + std::abs(g_drift) * s * n01(rng), 0.0) / g_prog_us;
}
/// One read's sigma: aihwkit's PCM_READ weight noise of the StandardHWATrainingPreset,
/// w_noise = 0.0175 on |w| with max |w| = 1: var(dG) = 0.0175^2 G g_max.
double read_sigma_us(double g_us) { return 0.0175 * std::sqrt(g_us * g_max_us); }
}  // namespace pcm

// rram-wan2022: Wan et al. 2022 (NeuRRAM) as aihwkit's ReRamWan2022NoiseModel, g_max 40 uS.
namespace wan {
constexpr double g_max_us = 40.0;
double poly(const double (&c)[5], double x) { return c[0] + x * (c[1] + x * (c[2] + x * (c[3] + x * c[4]))); }
constexpr double at_1s[5] = {0.348, 16.030, -43.853, 45.393, -16.815};
constexpr double at_1day[5] = {0.701, 22.086, -50.773, 47.095, -16.458};
constexpr double at_2days[5] = {0.782, 20.274, -43.507, 37.062, -11.934};
}  // namespace wan

// rram-cmo: Falcone et al. 2025 / Lombardo et al. 2024 as aihwkit's ReRamCMONoiseModel (0.2 %).
namespace cmo {
constexpr double g_min_us = 9.0, g_max_us = 88.2;
double sigma_prog_us(double g_us) { return 0.00081107 + 0.00106879 * g_us; }
/// G(t) - G_prog of one cell t seconds after programming: relaxation (mean -0.08900206 ln t,
/// spread 0.04201137 ln t + 0.41183342), then 1/f + RTN noise 0.0277316483 log10(G) sqrt(ln((t + 1e-6) / 2e-6)),
/// clipped to [g_min, g_max].
double change(double g_prog_us, double t, std::mt19937_64& rng) {
  std::normal_distribution<double> n01;
  const double lt = std::log(t);
  const double g_drift = g_prog_us - 0.08900206 * lt + (0.04201137 * lt + 0.41183342) * n01(rng);
  const double s = 0.0277316483 * std::log10(g_drift) * std::sqrt(std::log((t + 1e-6) / 2e-6));
  return std::clamp(g_drift + s * n01(rng), g_min_us, g_max_us) - g_prog_us;
}
}  // namespace cmo

}  // namespace

// ---------------------------------------------------------------------------------------------
// pcm-joshi2020

TEST(DeviceStatistics, PcmProgrammingSigmaFollowsThePolynomial) {
  const Device d(preset("pcm-joshi2020"));
  for (double x : {0.1, 0.25, 0.5, 0.75, 1.0}) {  // G_T >= 2.5 uS: the clamp at 0 is > 5 sigma away
    const double gt = x * pcm::g_max_us;
    const Bin b = program_bin(d, gt * kUs, derive_seed(40, {1, static_cast<uint64_t>(x * 100)}));
    const Stats s = stats(as_vector((b.prog - b.target) / kUs));
    std::printf("pcm  program  G_T %6.2f uS: sd %.5f uS, expected %.5f; mean %+.5f\n", gt, s.sd,
                pcm::sigma_prog_us(x), s.mean);
    expect_moments(s, 0.0, pcm::sigma_prog_us(x), "pcm programming at x = " + std::to_string(x));
  }
}

TEST(DeviceStatistics, PcmDriftExponentIsAFoldedNormalOfTheTarget) {
  // Drift alone (the model without its 1/f noise): G(t) = G_prog ((t + t0) / t0)^-nu, so every
  // cell's nu is -ln(G(t) / G_prog) / ln((t + t0) / t0); nu = |N(mu(x), s(x))| has the folded
  // normal's mean and sd (closed form).
  DeviceSpec spec = preset("pcm-joshi2020");
  spec.stat.noise_amplitude = StatisticalModel::Amplitude::None;
  const Device d(spec);
  for (double x : {0.05, 0.1, 0.25, 1.0}) {  // mu and s on their slopes (x < 0.2) and clipped (x = 1)
    const Bin b = program_bin(d, x * pcm::g_max_us * kUs, derive_seed(40, {2, static_cast<uint64_t>(x * 100)}));
    for (double t : {kYear}) {  // a cell's nu is the same at every time
      const Eigen::MatrixXd g = d.at_time(b.target, b.prog, b.faults, t, derive_seed(40, {2, static_cast<uint64_t>(x * 100)}));
      const double lr = std::log((t + pcm::t0_s) / pcm::t0_s);
      std::vector<double> nu(static_cast<size_t>(g.size()));
      for (Eigen::Index k = 0; k < g.size(); ++k) nu[static_cast<size_t>(k)] = -std::log(g.data()[k] / b.prog.data()[k]) / lr;
      const double mu = pcm::nu_mean(x), s = pcm::nu_std(x);
      const double mean = s * std::sqrt(2 / M_PI) * std::exp(-mu * mu / (2 * s * s)) + mu * (1 - 2 * normal_cdf(-mu / s));
      const double sd = std::sqrt(mu * mu + s * s - mean * mean);
      const Stats st = stats(nu);
      std::printf("pcm  nu       x %.2f t %.0e s: mean %.5f (expected %.5f), sd %.5f (expected %.5f)\n", x, t,
                  st.mean, mean, st.sd, sd);
      expect_moments(st, mean, sd, "pcm nu at x = " + std::to_string(x) + ", t = " + std::to_string(t));
    }
  }
}

TEST(DeviceStatistics, PcmStateAtOneDayAndOneYearMatchesTheFormulas) {
  // Drift and accumulated 1/f noise together: G(t) / G_prog against a Monte Carlo of the formulas
  // (10^6 cells, std::mt19937_64, the programmed state drawn from the programming formula too).
  const Device d(preset("pcm-joshi2020"));
  for (double x : {0.1, 0.25, 1.0}) {  // nu on its slope, at its floor with a larger Q_s, and at the top
    const double gt = x * pcm::g_max_us;
    const uint64_t stream = derive_seed(40, {3, static_cast<uint64_t>(x * 100)});
    const Bin b = program_bin(d, gt * kUs, stream);
    for (double t : {kDay, kYear}) {
      const Eigen::MatrixXd g = d.at_time(b.target, b.prog, b.faults, t, stream);
      const std::vector<double> ratio = as_vector(g.cwiseQuotient(b.prog));
      std::mt19937_64 rng(static_cast<uint64_t>(1000 * x + t));
      std::normal_distribution<double> n01;
      std::vector<double> ref(ratio.size());
      for (double& r : ref) r = pcm::ratio(std::max(gt + pcm::sigma_prog_us(x) * n01(rng), 0.0), x, t, rng);
      std::printf("pcm  G(t)/G_prog x %.2f t %.0e s: median %.5f (formulas %.5f; drift alone at the median nu %.5f)\n",
                  x, t, quantile(ratio, 0.5), quantile(ref, 0.5),
                  std::pow((t + pcm::t0_s) / pcm::t0_s, -pcm::nu_mean(x)));
      expect_same_distribution(ratio, ref, "pcm G(t)/G_prog at x = " + std::to_string(x) + ", t = " + std::to_string(t));
    }
  }
}

// ---------------------------------------------------------------------------------------------
// rram-wan2022

TEST(DeviceStatistics, RramWan2022SpreadAroundTheTargetAtOneSecondOneDayAndAfter) {
  // sigma_t(x) is the total spread around the target t after programming (programming = 1 s);
  // 1 day and 2 days are tabled, later times keep the 2-day spread. A draw is clamped at the
  // open cell (~0): the expected mean and sd are those of the clamped normal (closed form).
  const Device d(preset("rram-wan2022"));
  for (double gt : {10.0, 14.0, 20.0, 30.0, 40.0}) {  // the peak (14 uS) and the top; >= 2.7 sigma above 0
    const double x = gt / wan::g_max_us;
    const uint64_t stream = derive_seed(40, {4, static_cast<uint64_t>(gt)});
    const Bin b = program_bin(d, gt * kUs, stream);
    const struct {
      const char* name;
      double t;
      const double (&c)[5];
    } cases[] = {{"1 s (programmed)", 0.0, wan::at_1s}, {"1 day", kDay, wan::at_1day}, {"1 year", kYear, wan::at_2days}};
    Eigen::MatrixXd year;
    for (const auto& c : cases) {
      const Eigen::MatrixXd g = c.t > 0 ? d.at_time(b.target, b.prog, b.faults, c.t, stream) : b.prog;
      if (c.t == kYear) year = g;
      const std::vector<double> v = as_vector(g / kUs);
      double mean, sd;
      clamped_normal(gt, wan::poly(c.c, x), 0.0, mean, sd);
      const Stats s = stats(v);
      const double median = quantile(v, 0.5);
      std::printf("wan  G_T %4.1f uS %-16s: sd %.4f uS (expected %.4f), mean %.4f (%.4f), median %.4f\n", gt, c.name,
                  s.sd, sd, s.mean, mean, median);
      expect_moments(s, mean, sd, std::string("wan2022 at G_T = ") + std::to_string(gt) + ", " + c.name);
      EXPECT_NEAR(median, gt, kZ * std::sqrt(M_PI / 2) * wan::poly(c.c, x) / 1000.0) << gt << " " << c.name;
    }
    // Constant after the last tabled time: a cell at 1 year is where it was at 2 days, bit for bit.
    EXPECT_TRUE(year == d.at_time(b.target, b.prog, b.faults, kTwoDays, stream));
  }
}

// ---------------------------------------------------------------------------------------------
// rram-cmo

TEST(DeviceStatistics, RramCmoProgrammingAndRelaxationMatchTheFormulas) {
  const Device d(preset("rram-cmo"));
  for (double gt : {15.0, 30.0, 50.0, 70.0, 85.0}) {  // inside [9, 88.2] by > 30 programming sigmas
    const uint64_t stream = derive_seed(40, {5, static_cast<uint64_t>(gt)});
    const Bin b = program_bin(d, gt * kUs, stream);
    const Stats s = stats(as_vector((b.prog - b.target) / kUs));
    std::printf("cmo  program  G_T %4.1f uS: sd %.6f uS, expected %.6f; mean %+.6f\n", gt, s.sd, cmo::sigma_prog_us(gt),
                s.mean);
    expect_moments(s, 0.0, cmo::sigma_prog_us(gt), "cmo programming at " + std::to_string(gt));
    if (gt == 30.0 || gt == 70.0) continue;  // the change hardly depends on G: three bins show it
    for (double t : {kDay, kYear}) {
      // The change after programming (relaxation and read noise, clipped to the range) against a
      // Monte Carlo of the formulas from programmed states drawn from the programming formula.
      const std::vector<double> change = as_vector((d.at_time(b.target, b.prog, b.faults, t, stream) - b.prog) / kUs);
      std::mt19937_64 rng(static_cast<uint64_t>(gt * 7 + t));
      std::normal_distribution<double> n01;
      std::vector<double> ref(change.size());
      for (double& r : ref) r = cmo::change(gt + cmo::sigma_prog_us(gt) * n01(rng), t, rng);
      const Stats sc = stats(change), sr = stats(ref);
      std::printf("cmo  G_T %4.1f uS t %.0e s: change mean %+.4f uS (formulas %+.4f, -0.0890 ln t = %+.4f), sd %.4f (%.4f)\n",
                  gt, t, sc.mean, sr.mean, -0.08900206 * std::log(t), sc.sd, sr.sd);
      expect_same_distribution(change, ref, "cmo change at " + std::to_string(gt) + ", t = " + std::to_string(t));
    }
  }
}

// ---------------------------------------------------------------------------------------------
// One read's fluctuation

TEST(DeviceStatistics, ReadSigmaIsThePublishedOneAndReadsDrawStandardNormals) {
  // The sigma of one read (a formula: exact to rounding) ...
  const Device p(preset("pcm-joshi2020")), w(preset("rram-wan2022")), c(preset("rram-cmo"));
  Eigen::MatrixXd g(1, 5);
  g << 1, 5, 10, 20, 25;
  g *= kUs;
  const Eigen::MatrixXd sp = p.read_sigma(g) / kUs;
  for (int k = 0; k < 5; ++k) EXPECT_NEAR(sp(k), pcm::read_sigma_us(g(k) / kUs), 1e-12) << g(k);
  // RRAM: no per-read figure is published; aihwkit's note: "about 1 %" short-term read noise,
  // which the presets take as 1 % of G.
  for (const Device* d : {&w, &c}) {
    const Eigen::MatrixXd s = d->read_sigma(g * 3);
    for (int k = 0; k < 5; ++k) EXPECT_NEAR(s(k), 0.01 * 3 * g(k), 1e-12 * g(k)) << g(k);
  }
  // ... and the normals every read scales it with: 10^6 of them are N(0, 1) (read_normals feeds
  // the fast path, counter_normal the full solves), mean, sd and quantiles.
  const int n = kSide * kSide;
  std::vector<float> z(static_cast<size_t>(n));
  read_normals(derive_seed(40, {6}), 17, n, z.data());
  std::vector<double> zr(z.begin(), z.end()), zc(static_cast<size_t>(n));
  for (int k = 0; k < n; ++k) zc[static_cast<size_t>(k)] = counter_normal(derive_seed(40, {7}), static_cast<uint64_t>(k));
  for (const auto* v : {&zr, &zc}) {
    const Stats s = stats(*v);
    expect_moments(s, 0.0, 1.0, "standard normals");
    const std::vector<double> qs = {0.001, 0.02, 0.1587, 0.5, 0.8413, 0.98, 0.999}, x = quantiles(*v, qs);
    for (size_t i = 0; i < qs.size(); ++i)
      EXPECT_NEAR(normal_cdf(x[i]), qs[i], kZ * std::sqrt(qs[i] * (1 - qs[i]) / n)) << "quantile " << qs[i];
  }
}

// ---------------------------------------------------------------------------------------------
// Stuck-at faults

TEST(DeviceFaults, StuckFractionsAreBinomialAndStuckCellsNeverMove) {
  DeviceSpec spec = preset("pcm-joshi2020");
  spec.stuck_gmin = 0.01;
  spec.stuck_gmax = 0.03;
  const Device d(spec);
  const double gt = 12.5 * kUs;
  const Bin b = program_bin(d, gt, derive_seed(40, {8}));
  const double n = static_cast<double>(b.prog.size());
  const double at_min = static_cast<double>((b.faults < 0).count()), at_max = static_cast<double>((b.faults > 0).count());
  std::printf("stuck: %.0f at g_min (expected %.0f +- %.0f), %.0f at g_max (%.0f +- %.0f) of %.0f\n", at_min,
              n * 0.01, std::sqrt(n * 0.01 * 0.99), at_max, n * 0.03, std::sqrt(n * 0.03 * 0.97), n);
  EXPECT_NEAR(at_min, n * 0.01, kZ * std::sqrt(n * 0.01 * 0.99));  // binomial sd sqrt(n p (1 - p))
  EXPECT_NEAR(at_max, n * 0.03, kZ * std::sqrt(n * 0.03 * 0.97));
  // A stuck cell ignores programming and holds g_min / g_max exactly at every time; a free cell moves.
  const Eigen::MatrixXd later = d.at_time(b.target, b.prog, b.faults, kYear, derive_seed(40, {8}));
  long moved_free = 0;
  for (Eigen::Index k = 0; k < b.prog.size(); ++k) {
    const int f = b.faults.data()[k];
    if (f) {
      const double stuck = f < 0 ? spec.g_min_s : spec.g_max_s;
      ASSERT_EQ(b.prog.data()[k], stuck) << k;
      ASSERT_EQ(later.data()[k], stuck) << k;
    } else {
      moved_free += later.data()[k] != b.prog.data()[k];
    }
  }
  EXPECT_EQ(moved_free, static_cast<long>(n - at_min - at_max));
  EXPECT_EQ(spec.g_min_s, 0.1 * kUs);  // the preset's range, what the stuck cells hold
  EXPECT_EQ(spec.g_max_s, 25.0 * kUs);
}

namespace {
/// An 8 x 4 layer on ideal wires, no mitigation, exact cells except the stuck ones.
AnalogConfig fault_config(double stuck_gmin, double stuck_gmax, int spares, uint64_t seed) {
  AnalogConfig c;
  c.xbar.r_wire_ohm = c.xbar.r_in_ohm = c.xbar.r_out_ohm = 1e-9;
  c.set_method("none", "test");
  c.converters.dac_bits = c.converters.adc_bits = 0;
  c.device.stuck_gmin = stuck_gmin;
  c.device.stuck_gmax = stuck_gmax;
  c.device.spare_columns = spares;
  c.device.seed = seed;
  return c;
}
}  // namespace

TEST(DeviceFaults, SpareColumnsReplaceTheColumnsThatErrMost) {
  // Hand check on 8 x 4 crossbars (shift mapping: 4 physical columns). The conductances asked are
  // those of the fault-free layer. Without spares a cell is either as asked or stuck exactly at
  // g_min / g_max; the fault error of a column is sum |G - G_asked| over its cells. With one
  // spare, the column of largest fault error is replaced when its spare errs less, the other
  // columns stay bit for bit, and the layer's fault error and output error fall.
  Eigen::MatrixXd w(8, 4);
  for (int i = 0; i < 8; ++i)
    for (int j = 0; j < 4; ++j) w(i, j) = std::sin(1.7 * i + 0.9 * j + 0.3);
  Eigen::MatrixXd x = Eigen::MatrixXd::Zero(16, 8);
  for (int r = 0; r < 16; ++r)
    for (int i = 0; i < 8; ++i) x(r, i) = 0.5 + 0.5 * std::cos(0.37 * r * (i + 1));
  AnalogLayer ideal(fault_config(0, 0, 0, 1), w, 1.0, false);
  ideal.program(Eigen::MatrixXd());
  const Eigen::MatrixXd asked = ideal.conductances(0);
  const double g_min = ideal.config().xbar.g_min_s, g_max = ideal.config().xbar.g_max_s;
  const Eigen::MatrixXd y_ideal = ideal.forward(x);
  double err_without = 0, err_with = 0, out_without = 0, out_with = 0;
  int replaced = 0;
  for (uint64_t seed = 1; seed <= 20; ++seed) {
    AnalogLayer plain(fault_config(0.1, 0.1, 0, seed), w, 1.0, false), spared(fault_config(0.1, 0.1, 1, seed), w, 1.0, false);
    plain.program(Eigen::MatrixXd());
    spared.program(Eigen::MatrixXd());
    const Eigen::MatrixXd g0 = plain.conductances(0), g1 = spared.conductances(0);
    ASSERT_EQ(g0.cols(), 4);
    Eigen::VectorXd col_err(4);
    int stuck = 0, differ = 0;
    for (int c = 0; c < 4; ++c) {
      col_err(c) = 0;
      for (int r = 0; r < 8; ++r) {
        const double g = g0(r, c);
        if (g != asked(r, c)) {
          ASSERT_TRUE(g == g_min || g == g_max) << "seed " << seed << " cell " << r << "," << c << ": " << g;
          col_err(c) += std::abs(g - asked(r, c));
          ++differ;
        }
        stuck += g == g_min || g == g_max;  // a cell asked at g_min and stuck there is stuck too
      }
    }
    EXPECT_LE(plain.reports()[0].stuck_cells, stuck) << seed;
    EXPECT_GE(plain.reports()[0].stuck_cells, differ) << seed;
    EXPECT_EQ(plain.reports()[0].spare_columns_used, 0);
    int worst;
    const double worst_err = col_err.maxCoeff(&worst);
    const int used = spared.reports()[0].spare_columns_used;
    EXPECT_LE(used, 1);
    for (int c = 0; c < 4; ++c) {
      if (!(used && c == worst)) {
        EXPECT_TRUE(g1.col(c) == g0.col(c)) << "seed " << seed << " column " << c;
      }
    }
    double spare_err = 0;
    for (int r = 0; r < 8; ++r) {
      const double g = g1(r, worst);
      if (g != asked(r, worst)) {
        ASSERT_TRUE(g == g_min || g == g_max) << "seed " << seed << " spare cell " << r;
        spare_err += std::abs(g - asked(r, worst));
      }
    }
    if (used) {
      EXPECT_LT(spare_err, worst_err) << seed;
    } else {
      EXPECT_TRUE(worst_err == 0 || g1.col(worst) == g0.col(worst)) << seed;
    }
    replaced += used;
    err_without += col_err.sum();
    err_with += col_err.sum() - (used ? worst_err - spare_err : 0);
    out_without += (plain.forward(x) - y_ideal).squaredNorm();
    out_with += (spared.forward(x) - y_ideal).squaredNorm();
  }
  std::printf("spares: %d of 20 crossbars used their spare; fault error %.3g S -> %.3g S, output error^2 %.3g -> %.3g\n",
              replaced, err_without, err_with, out_without, out_with);
  EXPECT_GT(replaced, 10);
  EXPECT_LT(err_with, err_without);
  EXPECT_LT(out_with, out_without);
}

// ---------------------------------------------------------------------------------------------
// Reproducibility

TEST(DeviceReproducibility, DrawsDependOnTheCellNotTheOrder) {
  // The same (seed, layer, crossbar, cell) draws the same in any evaluation order: a counter-based
  // stream evaluated backwards equals it forwards; a layer's conductances do not depend on the
  // thread count, on which layers were programmed before it, or on an earlier time being visited.
  std::vector<double> fwd(1000), bwd(1000);
  for (int k = 0; k < 1000; ++k) fwd[static_cast<size_t>(k)] = counter_normal(99, static_cast<uint64_t>(k));
  for (int k = 999; k >= 0; --k) bwd[static_cast<size_t>(k)] = counter_normal(99, static_cast<uint64_t>(k));
  EXPECT_EQ(fwd, bwd);

  const DeviceSpec spec = preset("pcm-joshi2020");
  const Device d(spec);
  Eigen::MatrixXd target(50, 40);
  for (Eigen::Index k = 0; k < target.size(); ++k) target.data()[k] = (1 + k % 24) * kUs;
  Bin b;
  b.target = target;
  b.prog = target;
  d.program(b.prog, b.faults, 5);
  const Eigen::MatrixXd direct = d.at_time(b.target, b.prog, b.faults, kYear, 5);
  (void)d.at_time(b.target, b.prog, b.faults, kDay, 5);
  EXPECT_TRUE(d.at_time(b.target, b.prog, b.faults, kYear, 5) == direct);

  Eigen::MatrixXd w(60, 20);
  for (Eigen::Index k = 0; k < w.size(); ++k) w.data()[k] = std::sin(0.37 * static_cast<double>(k));
  AnalogConfig c;
  c.set_method("conversion", "test");
  c.mapping.max_rows = 16;
  c.mapping.max_cols = 8;
  c.device = spec;
  c.device.time_s = kDay;
  c.device.stuck_gmin = 0.02;
  auto conductances = [&](int threads, bool other_first) {
    if (other_first) {
      AnalogLayer other(c, w, 1.0, false, 2);
      other.program(Eigen::MatrixXd());
    }
    SolverOptions s = c.solver;
    s.threads = threads;
    AnalogLayer layer(c, w, 1.0, false, 1);
    layer.program(Eigen::MatrixXd(), s);
    std::vector<Eigen::MatrixXd> g;
    for (int x = 0; x < layer.crossbars(); ++x) g.push_back(layer.conductances(x));
    return g;
  };
  const auto a = conductances(1, false);
  EXPECT_EQ(a.size(), 4u * 3u);
  EXPECT_TRUE(a == conductances(2, true));
  // ... and different crossbars draw differently (the stream is the crossbar's).
  EXPECT_FALSE(a[0] == a[1]);
}
