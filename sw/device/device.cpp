#include "sw/device/device.h"

#include <algorithm>
#include <cmath>

#include "sw/common/input_file.h"
#include "sw/common/seed.h"
#include "sw/common/yaml_section.h"

namespace xbarsim {

namespace {

constexpr double kUs = 1e-6;
// Sub-streams of a crossbar's stream, one per kind of draw.
constexpr uint64_t kProgramDraw = 0xD1, kFaultDraw = 0xD2, kNuDraw = 0xD3, kRelaxDraw = 0xD4, kNoiseDraw = 0xD5;

double poly(const std::vector<double>& c, double x) {
  double v = 0;
  for (auto it = c.rbegin(); it != c.rend(); ++it) v = v * x + *it;
  return v;
}

/// Where t falls in the tabled times: the index below and the weight of the one above (linear in ln t,
/// constant outside the table).
void locate(const std::vector<double>& times, double t, size_t& i, double& w) {
  i = 0;
  w = 0;
  if (times.size() < 2 || t <= times.front()) return;
  if (t >= times.back()) {
    i = times.size() - 1;
    return;
  }
  while (i + 1 < times.size() && times[i + 1] <= t) ++i;
  w = (std::log(t) - std::log(times[i])) / (std::log(times[i + 1]) - std::log(times[i]));
}

StatisticalModel::LogLinear log_linear(YamlSection& s, const std::string& key) {
  const std::vector<double> v = s.reals(key, 4, 4);
  StatisticalModel::LogLinear l{v[0], v[1], v[2], v[3]};
  if (!(l.min <= l.max)) throw InputError(s.where(key) + " has its min above its max");
  return l;
}

/// Section `key` of a model file, named `key` in messages (not ".key"); a section left empty is
/// an empty map, so that the message names its first missing key.
YamlSection model_section(const YAML::Node& root, const std::string& key, const std::string& origin) {
  const YAML::Node n = root[key];
  if (!n) throw InputError(origin + ": missing key '" + key + "'");
  return YamlSection(n.IsNull() ? YAML::Node(YAML::NodeType::Map) : n, key, origin, true);
}

/// A top-level word of a model file.
std::string model_word(const YAML::Node& root, const std::string& key, const std::string& origin) {
  const YAML::Node n = root[key];
  if (!n) throw InputError(origin + ": missing key '" + key + "'");
  if (!n.IsScalar() || n.Scalar().empty()) throw InputError(origin + ": '" + key + "' must be a name");
  return n.Scalar();
}

/// A flag: true or false, nothing else (a misspelt flag is not false).
bool model_flag(const std::string& word, const std::string& where) {
  if (word != "true" && word != "false") throw InputError(where + " must be true or false, got '" + excerpt(word) + "'");
  return word == "true";
}

/// A spread polynomial of x = G / g_max must not be negative on the model's range [x_min, 1]
/// (checked on a grid fine enough for the polynomials of degree <= 7 the files hold).
void check_spread(const std::vector<double>& c, double x_min, const std::string& where) {
  for (int k = 0; k <= 1000; ++k) {
    const double x = x_min + (1 - x_min) * k / 1000.0;
    if (poly(c, x) < 0)
      throw InputError(where + " is a spread: it must not be negative on the model's range, but is " +
                       std::to_string(poly(c, x)) + " uS at G / g_max = " + std::to_string(x));
  }
}

}  // namespace

const char* to_string(Compensation c) {
  switch (c) {
    case Compensation::None:
      return "none";
    case Compensation::Global:
      return "global";
    case Compensation::Column:
      return "column";
    case Compensation::Recalibrate:
      return "recalibrate";
  }
  return "?";
}

double StatisticalModel::LogLinear::at(double x) const {
  return std::clamp(intercept + slope * std::log(std::max(x, 1e-7)), min, max);
}

uint64_t counter_bits(uint64_t key, uint64_t index) { return mix64(key ^ mix64(index + 0x2545F4914F6CDD1Dull)); }

double counter_uniform(uint64_t key, uint64_t index) {
  return static_cast<double>(counter_bits(key, index) >> 11) * 0x1.0p-53;
}

double counter_normal(uint64_t key, uint64_t index) {
  const double u1 = (static_cast<double>(counter_bits(key, 2 * index) >> 11) + 0.5) * 0x1.0p-53;
  const double u2 = static_cast<double>(counter_bits(key, 2 * index + 1) >> 11) * 0x1.0p-53;
  return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * M_PI * u2);
}

namespace {

/// The standard normal quantile (Acklam's rational approximation, then one Newton step on erfc:
/// better than 1e-14 relative).
double normal_quantile(double p) {
  static const double a[] = {-3.969683028665376e+01, 2.209460984245205e+02, -2.759285104469687e+02,
                             1.383577518672690e+02,  -3.066479806614716e+01, 2.506628277459239e+00};
  static const double b[] = {-5.447609879822406e+01, 1.615858368580409e+02, -1.556989798598866e+02,
                             6.680131188771972e+01,  -1.328068155288572e+01};
  static const double c[] = {-7.784894002430293e-03, -3.223964580411365e-01, -2.400758277161838e+00,
                             -2.549732539343734e+00, 4.374664141464968e+00,  2.938163982698783e+00};
  static const double d[] = {7.784695709041462e-03, 3.224671290700398e-01, 2.445134137142996e+00,
                             3.754408661907416e+00};
  double x;
  if (p < 0.02425) {
    const double q = std::sqrt(-2 * std::log(p));
    x = (((((c[0] * q + c[1]) * q + c[2]) * q + c[3]) * q + c[4]) * q + c[5]) /
        ((((d[0] * q + d[1]) * q + d[2]) * q + d[3]) * q + 1);
  } else if (p > 1 - 0.02425) {
    const double q = std::sqrt(-2 * std::log(1 - p));
    x = -(((((c[0] * q + c[1]) * q + c[2]) * q + c[3]) * q + c[4]) * q + c[5]) /
        ((((d[0] * q + d[1]) * q + d[2]) * q + d[3]) * q + 1);
  } else {
    const double q = p - 0.5, r = q * q;
    x = (((((a[0] * r + a[1]) * r + a[2]) * r + a[3]) * r + a[4]) * r + a[5]) * q /
        (((((b[0] * r + b[1]) * r + b[2]) * r + b[3]) * r + b[4]) * r + 1);
  }
  const double e = 0.5 * std::erfc(-x / std::sqrt(2.0)) - p;
  return x - e * std::sqrt(2 * M_PI) * std::exp(x * x / 2);
}

/// 2^13 equiprobable normal deviates: the quantiles at (k + 1/2) / 2^13, scaled to unit variance
/// (the cut tails, beyond 3.8 sigma, hold 2e-3 of the variance). 32 KB: the table stays in the
/// first-level cache while a read's deviates index it at random (2^16 entries cost an L2 miss
/// each, as much as the rest of the noise).
const std::vector<float>& quantile_table() {
  static const std::vector<float> table = [] {
    const int n = 1 << kNormalTableBits;
    std::vector<double> q(n);
    double var = 0;
    for (int k = 0; k < n; ++k) {
      q[k] = normal_quantile((k + 0.5) / n);
      var += q[k] * q[k] / n;
    }
    std::vector<float> t(n);
    for (int k = 0; k < n; ++k) t[k] = static_cast<float>(q[k] / std::sqrt(var));
    return t;
  }();
  return table;
}

}  // namespace

const float* normal_table() { return quantile_table().data(); }

namespace {
/// Read `read`'s 64-bit stream of `key`.
uint64_t read_key(uint64_t key, uint64_t read) { return mix64(key ^ mix64(read + 0x6A09E667F3BCC909ull)); }
}  // namespace

uint32_t read_stream(uint64_t key, uint64_t read) {
  const uint64_t s = read_key(key, read);
  return static_cast<uint32_t>(s ^ (s >> 32));
}

uint64_t Device::read_noise_key(uint64_t image, uint64_t layer, uint64_t crossbar) const {
  constexpr uint64_t kReadNoiseStream = 0x4EAD;
  return derive_seed(spec_.seed, {kReadNoiseStream, image, layer, crossbar});
}

Eigen::MatrixXd Device::read(const Eigen::MatrixXd& g, uint64_t key, uint64_t read) const {
  const Eigen::MatrixXd sigma = read_sigma(g);
  const uint64_t rk = read_key(key, read);
  Eigen::MatrixXd out = g;
  for (Eigen::Index k = 0; k < out.size(); ++k)
    out.data()[k] = std::max(out.data()[k] + sigma.data()[k] * counter_normal(rk, static_cast<uint64_t>(k)), kOpenCellS);
  return out;
}

// One table entry per deviate at a hash of (read, index): Box-Muller's log and cosine cost as much
// as the read itself. Both loops vectorise (16 hashes and a gather per step): the pointers do not
// alias.
void normals_of_read(uint32_t stream, Eigen::Index n, float* __restrict out) {
  const float* __restrict t = normal_table();
  for (Eigen::Index c = 0; c < n; ++c) out[c] = t[read_hash(stream, static_cast<uint32_t>(c))];
}

void normals_of_column(const uint32_t* __restrict streams, Eigen::Index n, uint32_t c, float* __restrict out) {
  const float* __restrict t = normal_table();
  for (Eigen::Index r = 0; r < n; ++r) out[r] = t[read_hash(streams[r], c)];
}

void read_normals(uint64_t key, uint64_t read, Eigen::Index n, float* out) {
  normals_of_read(read_stream(key, read), n, out);
}

StatisticalModel parse_statistical_model(const std::string& text, const std::string& origin) {
  const YAML::Node root = load_yaml_map(text, origin, "a device model");
  check_yaml_sections(root, {"name", "source", "range", "programming", "drift", "relaxation", "noise_1f", "read",
                             "clip_to_range"},
                      origin);
  StatisticalModel m;
  m.name = model_word(root, "name", origin);
  m.source = model_word(root, "source", origin);
  {
    YamlSection r = model_section(root, "range", origin);
    m.g_min_s = r.number("g_min_us", true) * kUs;
    m.g_max_s = r.number("g_max_us", true) * kUs;
    r.finish();
    if (!(m.g_min_s < m.g_max_s)) throw InputError(origin + ": 'range.g_min_us' must be below 'range.g_max_us'");
  }
  {
    YamlSection p = model_section(root, "programming", origin);
    m.program_sigma_us = p.reals("sigma_us", 1, 8);
    p.finish();
    check_spread(m.program_sigma_us, m.g_min_s / m.g_max_s, p.where("sigma_us"));
  }
  if (root["drift"]) {
    YamlSection d = model_section(root, "drift", origin);
    m.drifts = true;
    m.drift_t0_s = d.number("t0_s", true);
    m.nu_mean = log_linear(d, "nu_mean");
    m.nu_std = log_linear(d, "nu_std");
    if (m.nu_std.min < 0) throw InputError(d.where("nu_std") + " is a spread: its min must be >= 0");
    d.finish();
  }
  if (root["relaxation"]) {
    YamlSection r = model_section(root, "relaxation", origin);
    m.relax_times_s = r.reals("times_s", 1, 64);
    const size_t n = m.relax_times_s.size();
    for (size_t k = 0; k < n; ++k)
      if (!(m.relax_times_s[k] > 0) || (k && !(m.relax_times_s[k] > m.relax_times_s[k - 1])))
        throw InputError(origin + ": 'relaxation.times_s' must be positive and increasing");
    const YAML::Node s = r.raw("sigma_us");
    if (!s.IsSequence() || s.size() != n)
      throw InputError(origin + ": 'relaxation.sigma_us' must hold one polynomial (a list of numbers) per time");
    for (const auto& item : s) {
      if (!item.IsSequence() || item.size() < 1 || item.size() > 8)
        throw InputError(origin + ": 'relaxation.sigma_us' must hold one polynomial (a list of numbers) per time");
      std::vector<double> c;
      for (const auto& v : item) {
        double x = 0;
        if (!v.IsScalar() || !parse_finite_double(v.Scalar(), x))
          throw InputError(origin + ": 'relaxation.sigma_us' holds '" + (v.IsScalar() ? v.Scalar() : "?") +
                           "', not a finite number");
        c.push_back(x);
      }
      check_spread(c, m.g_min_s / m.g_max_s, origin + ": 'relaxation.sigma_us'");
      m.relax_sigma_us.push_back(c);
    }
    m.relax_shift_us = r.reals("shift_us", n, n);
    if (r.has("incremental")) m.relax_incremental = model_flag(r.word("incremental"), r.where("incremental"));
    r.finish();
  }
  if (root["noise_1f"]) {
    YamlSection f = model_section(root, "noise_1f", origin);
    m.noise_t_read_s = f.number("t_read_s", true);
    m.noise_t_offset_s = f.number("t_offset_s");
    const std::string a = f.word("amplitude");
    if (a == "relative")
      m.noise_amplitude = StatisticalModel::Amplitude::Relative;
    else if (a == "log10_us")
      m.noise_amplitude = StatisticalModel::Amplitude::Log10Us;
    else
      throw InputError(origin + ": 'noise_1f.amplitude' must be relative or log10_us, got '" + a + "'");
    m.noise_coeff = f.number("coeff");
    m.noise_exponent = f.number("exponent");
    m.noise_max = f.number("max");
    f.finish();
  }
  {
    YamlSection r = model_section(root, "read", origin);
    m.read_relative = r.number("relative");
    m.read_sqrt_relative = r.number("sqrt_relative");
    m.read_sigma_s = r.number("sigma_us") * kUs;
    r.finish();
  }
  m.clip_to_range = model_flag(model_word(root, "clip_to_range", origin), origin + ": 'clip_to_range'");
  return m;
}

std::string device_model_text(const std::string& model) {
  if (model == "ideal" || model == "constant") return "";
  if (const char* text = builtin_device_model_yaml(model)) return text;
  try {
    return read_input_file(model, "the device model (device.model)", 1 << 20);
  } catch (const std::exception&) {
    return "";
  }
}

bool DeviceSpec::has_read_noise() const {
  switch (kind) {
    case DeviceKind::Ideal:
      return false;
    case DeviceKind::Constant:
      return read_sigma_s > 0;
    case DeviceKind::Statistical:
      return stat.read_relative > 0 || stat.read_sqrt_relative > 0 || stat.read_sigma_s > 0;
  }
  return false;
}

bool DeviceSpec::moves() const {
  switch (kind) {
    case DeviceKind::Ideal:
    case DeviceKind::Constant:
      return false;
    case DeviceKind::Statistical:
      return stat.drifts || !stat.relax_times_s.empty() ||
             stat.noise_amplitude != StatisticalModel::Amplitude::None;
  }
  return false;
}

bool DeviceSpec::perturbs_programming() const {
  switch (kind) {
    case DeviceKind::Ideal:
      return has_faults();
    case DeviceKind::Constant:
      return has_faults() || program_sigma_s > 0;
    case DeviceKind::Statistical:
      return true;
  }
  return true;
}

DeviceSpec parse_device_spec(const ConfigTree& cfg) {
  DeviceSpec d;
  d.model = cfg.get_string("device.model");
  d.program_sigma_s = cfg.get_double("device.program_sigma_us") * kUs;
  d.read_sigma_s = cfg.get_double("device.read_sigma_us") * kUs;
  d.time_s = cfg.get_double("device.time_s");
  d.compensation = require_enum<Compensation>(cfg, "device.compensation",
                                              {{"none", Compensation::None},
                                               {"global", Compensation::Global},
                                               {"column", Compensation::Column},
                                               {"recalibrate", Compensation::Recalibrate}});
  d.stuck_gmin = cfg.get_double("device.stuck_at_gmin");
  d.stuck_gmax = cfg.get_double("device.stuck_at_gmax");
  d.spare_columns = cfg.get_int32("device.spare_columns");
  d.seed = static_cast<uint64_t>(cfg.get_int("device.seed"));
  if (!(d.stuck_gmin + d.stuck_gmax <= 1))
    throw InputError("configuration keys 'device.stuck_at_gmin' + 'device.stuck_at_gmax' must sum to at most 1, got " +
                     std::to_string(d.stuck_gmin + d.stuck_gmax));
  if (!std::isfinite(d.time_s) || d.time_s < 0)
    throw InputError("configuration key 'device.time_s' must be a time >= 0 (s)");
  if (d.model == "ideal") {
    d.kind = DeviceKind::Ideal;
  } else if (d.model == "constant") {
    d.kind = DeviceKind::Constant;
  } else {
    d.kind = DeviceKind::Statistical;
    if (const char* text = builtin_device_model_yaml(d.model)) {
      d.stat = parse_statistical_model(text, "built-in configs/devices/" + d.model + ".yaml");
    } else if (d.model.find('/') != std::string::npos || d.model.find(".yaml") != std::string::npos ||
               d.model.find(".yml") != std::string::npos) {
      d.stat = parse_statistical_model(
          read_input_file(d.model, "the device model (device.model)", 1 << 20), d.model);
    } else {
      throw InputError("configuration key 'device.model': '" + excerpt(d.model) +
                       "' is not one of: ideal, constant, " + builtin_device_models() +
                       ", or a model file (a path ending in .yaml)");
    }
  }
  if (d.kind != DeviceKind::Constant)
    for (const char* key : {"device.program_sigma_us", "device.read_sigma_us"})
      if (cfg.get_double(key) != 0)
        throw InputError(std::string("configuration key '") + key + "' is the constant model's: set device.model: " +
                         "constant, or leave it 0 (" + d.model + " states its own)");
  const ConfigTree defaults;
  if (d.fixes_range()) {
    for (const char* key : {"crossbar.g_min", "crossbar.g_max"})
      if (cfg.get_double(key) != defaults.get_double(key))
        throw InputError(std::string("configuration key '") + key + "': device.model " + d.model +
                         " fixes the conductance range (" + std::to_string(d.stat.g_min_s / kUs) + ".." +
                         std::to_string(d.stat.g_max_s / kUs) +
                         " uS); leave crossbar.g_min/g_max at their defaults, or use device.model: constant");
    d.g_min_s = d.stat.g_min_s;
    d.g_max_s = d.stat.g_max_s;
  } else {
    d.g_min_s = cfg.get_double("crossbar.g_min");
    d.g_max_s = cfg.get_double("crossbar.g_max");
  }
  return d;
}

double Device::clip(double g) const {
  if (spec_.kind == DeviceKind::Constant || (spec_.kind == DeviceKind::Statistical && spec_.stat.clip_to_range))
    return std::clamp(g, spec_.g_min_s, spec_.g_max_s);
  return std::max(g, kOpenCellS);
}

double Device::program_sigma_s(double g_target) const {
  switch (spec_.kind) {
    case DeviceKind::Ideal:
      return 0;
    case DeviceKind::Constant:
      return spec_.program_sigma_s;
    case DeviceKind::Statistical:
      return std::abs(poly(spec_.stat.program_sigma_us, g_target / spec_.g_max_s)) * kUs;
  }
  return 0;
}

double Device::nu_mean(double g_target) const { return spec_.stat.nu_mean.at(g_target / spec_.g_max_s); }
double Device::nu_std(double g_target) const { return spec_.stat.nu_std.at(g_target / spec_.g_max_s); }

double Device::relax_sigma_s(double g_target, double t) const {
  const StatisticalModel& m = spec_.stat;
  if (spec_.kind != DeviceKind::Statistical || m.relax_times_s.empty() || !(t > 0)) return 0;
  size_t i;
  double w;
  locate(m.relax_times_s, t, i, w);
  const double x = g_target / spec_.g_max_s;
  double s = std::abs(poly(m.relax_sigma_us[i], x));
  if (w > 0) s = (1 - w) * s + w * std::abs(poly(m.relax_sigma_us[i + 1], x));
  return s * kUs;
}

double Device::relax_shift_s(double t) const {
  const StatisticalModel& m = spec_.stat;
  if (spec_.kind != DeviceKind::Statistical || m.relax_times_s.empty() || !(t > 0)) return 0;
  size_t i;
  double w;
  locate(m.relax_times_s, t, i, w);
  double s = m.relax_shift_us[i];
  if (w > 0) s = (1 - w) * s + w * m.relax_shift_us[i + 1];
  return s * kUs;
}

double Device::noise_sigma_s(double g_prog, double g_now, double t) const {
  const StatisticalModel& m = spec_.stat;
  if (spec_.kind != DeviceKind::Statistical || m.noise_amplitude == StatisticalModel::Amplitude::None) return 0;
  const double te = t + m.noise_t_offset_s;
  if (!(te > 0)) return 0;
  const double band = std::log((te + m.noise_t_read_s) / (2 * m.noise_t_read_s));
  if (!(band > 0)) return 0;
  double a = 0;
  switch (m.noise_amplitude) {
    case StatisticalModel::Amplitude::None:
      return 0;
    case StatisticalModel::Amplitude::Relative: {
      const double x = std::max(std::pow(std::abs(g_prog) / spec_.g_max_s, m.noise_exponent), 1e-3);
      a = std::abs(g_now) * std::min(m.noise_coeff / x, m.noise_max);
      break;
    }
    case StatisticalModel::Amplitude::Log10Us:
      a = std::min(m.noise_coeff * std::abs(std::log10(std::abs(g_now) / kUs)), m.noise_max) * kUs;
      break;
  }
  return a * std::sqrt(band);
}

void Device::place_faults(FaultMap& faults, Eigen::Index rows, Eigen::Index cols, uint64_t stream) const {
  faults.setZero(rows, cols);
  if (!spec_.has_faults()) return;
  const uint64_t key = derive_seed(stream, {kFaultDraw});
  for (Eigen::Index k = 0; k < rows * cols; ++k) {
    const double u = counter_uniform(key, static_cast<uint64_t>(k));
    faults.data()[k] = u < spec_.stuck_gmin ? -1 : u < spec_.stuck_gmin + spec_.stuck_gmax ? 1 : 0;
  }
}

void Device::program(Eigen::MatrixXd& g, FaultMap& faults, uint64_t stream) const {
  place_faults(faults, g.rows(), g.cols(), stream);
  const uint64_t key = derive_seed(stream, {kProgramDraw});
  const bool noisy = spec_.kind != DeviceKind::Ideal && !(spec_.kind == DeviceKind::Constant && !(spec_.program_sigma_s > 0));
  for (Eigen::Index k = 0; k < g.size(); ++k) {
    double& v = g.data()[k];
    if (noisy) v = clip(v + program_sigma_s(v) * counter_normal(key, static_cast<uint64_t>(k)));
    const int8_t f = faults.data()[k];
    if (f) v = f < 0 ? spec_.g_min_s : spec_.g_max_s;
  }
}

Eigen::MatrixXd Device::at_time(const Eigen::MatrixXd& g_target, const Eigen::MatrixXd& g_prog, const FaultMap& faults,
                                double t, uint64_t stream) const {
  if (!spec_.moves()) return g_prog;
  const StatisticalModel& m = spec_.stat;
  Eigen::MatrixXd g = g_prog;
  const uint64_t nu_key = derive_seed(stream, {kNuDraw}), relax_key = derive_seed(stream, {kRelaxDraw}),
                 noise_key = derive_seed(stream, {kNoiseDraw});
  const double shift = relax_shift_s(t);
  const double drift_ratio = m.drifts && t > 0 ? (t + m.drift_t0_s) / m.drift_t0_s : 1.0;
  for (Eigen::Index k = 0; k < g.size(); ++k) {
    if (faults.size() && faults.data()[k]) continue;  // a stuck cell never moves
    const auto idx = static_cast<uint64_t>(k);
    const double gt = g_target.data()[k], gp = g_prog.data()[k];
    double v = gp;
    if (drift_ratio > 1) {
      const double nu = std::abs(nu_mean(gt) + nu_std(gt) * counter_normal(nu_key, idx));
      v *= std::pow(drift_ratio, -nu);
    }
    if (!m.relax_times_s.empty() && t > 0) {
      const double s = relax_sigma_s(gt, t);
      const double inc = m.relax_incremental ? s : std::sqrt(std::max(s * s - std::pow(program_sigma_s(gt), 2), 0.0));
      v += shift + inc * counter_normal(relax_key, idx);
    }
    v += noise_sigma_s(gp, v, t) * counter_normal(noise_key, idx);
    g.data()[k] = clip(v);
  }
  return g;
}

Eigen::MatrixXd Device::read_sigma(const Eigen::MatrixXd& g) const {
  switch (spec_.kind) {
    case DeviceKind::Ideal:
      return Eigen::MatrixXd::Zero(g.rows(), g.cols());
    case DeviceKind::Constant:
      return Eigen::MatrixXd::Constant(g.rows(), g.cols(), spec_.read_sigma_s);
    case DeviceKind::Statistical: {
      const StatisticalModel& m = spec_.stat;
      return (g.array().square() * (m.read_relative * m.read_relative) +
              g.array().abs() * (m.read_sqrt_relative * m.read_sqrt_relative * spec_.g_max_s) +
              m.read_sigma_s * m.read_sigma_s)
          .sqrt()
          .matrix();
    }
  }
  return Eigen::MatrixXd::Zero(g.rows(), g.cols());
}

double Device::read_sigma_s(double g) const {
  switch (spec_.kind) {
    case DeviceKind::Ideal:
      return 0;
    case DeviceKind::Constant:
      return spec_.read_sigma_s;
    case DeviceKind::Statistical: {
      const StatisticalModel& m = spec_.stat;
      return std::sqrt(g * g * (m.read_relative * m.read_relative) +
                       std::abs(g) * (m.read_sqrt_relative * m.read_sqrt_relative * spec_.g_max_s) +
                       m.read_sigma_s * m.read_sigma_s);
    }
  }
  return 0;
}

double Device::read_spread_s(double g_target) const {
  return std::hypot(program_sigma_s(g_target), read_sigma_s(g_target));
}

}  // namespace xbarsim
