#pragma once
/// The device model: what happens to a cell's conductance when it is programmed, as time passes
/// after programming, and on every read. A part of its own with a typed spec and a kind
/// (section `device.`); the crossbar core calls program(), at_time() and read_sigma() and knows
/// nothing of the model behind them.
///  - ideal: programmed exactly, never moves, reads exactly (the paper's assumption; default);
///  - constant: a constant Gaussian programming error and read fluctuation (device.program_sigma_us,
///    device.read_sigma_us) on crossbar.g_min..g_max;
///  - statistical: a published model as data (configs/devices/<name>.yaml, compiled in, or a YAML
///    file of the same form): state-dependent programming error, drift (a power law with a
///    per-cell exponent), relaxation (a spread growing after programming), accumulated 1/f noise
///    and one read's fluctuation, on the model's own conductance range.
/// Stuck-at faults (device.stuck_at_gmin/gmax) apply to every kind. Every random draw comes from
/// a counter-based stream of (device.seed, layer, crossbar, cell): a cell keeps its draws at
/// every time t, so its trajectory is coherent and bit-identical on any thread count.
#include <Eigen/Dense>
#include <cstdint>
#include <string>
#include <vector>

#include "sw/common/config.h"
#include "sw/common/seed.h"

namespace xbarsim {

enum class DeviceKind { Ideal, Constant, Statistical };
enum class Compensation { None, Global, Column, Recalibrate };
const char* to_string(Compensation c);

/// A published model's figures (the form of configs/devices/*.yaml; docs/physics.md, device
/// models). Conductances in S, times in s; x = G_target / g_max.
struct StatisticalModel {
  std::string name, source;
  double g_min_s = 0, g_max_s = 0;
  std::vector<double> program_sigma_us;  ///< sigma_prog(x) = sum_k c_k x^k, uS
  /// clip(intercept + slope ln x, min, max): slope, intercept, min, max.
  struct LogLinear {
    double slope = 0, intercept = 0, min = 0, max = 0;
    double at(double x) const;
  };
  bool drifts = false;  ///< G(t) = G_prog ((t + t0) / t0)^-nu, nu = |N(nu_mean(x), nu_std(x))|
  double drift_t0_s = 0;
  LogLinear nu_mean, nu_std;
  /// Relaxation: a spread (and mean shift) at tabled times, linear in ln t between them and
  /// constant outside; total around the target, or added to the programmed state (incremental).
  std::vector<double> relax_times_s;
  std::vector<std::vector<double>> relax_sigma_us;  ///< per time: polynomial of x, uS
  std::vector<double> relax_shift_us;               ///< per time, uS
  bool relax_incremental = false;
  /// Accumulated 1/f noise: sigma = A(G) sqrt(ln((t + t_offset + t_read) / (2 t_read))).
  enum class Amplitude { None, Relative, Log10Us };
  Amplitude noise_amplitude = Amplitude::None;
  double noise_t_read_s = 0, noise_t_offset_s = 0, noise_coeff = 0, noise_exponent = 0, noise_max = 0;
  /// One read: sigma^2 = (relative G)^2 + sqrt_relative^2 G g_max + sigma^2.
  double read_relative = 0, read_sqrt_relative = 0, read_sigma_s = 0;
  bool clip_to_range = false;  ///< states outside [g_min, g_max] are clipped to it
};

/// Parses a model file's text; InputError naming `origin` and the key for anything missing or
/// malformed.
StatisticalModel parse_statistical_model(const std::string& yaml_text, const std::string& origin);
/// The compiled-in model of that name (configs/devices/<name>.yaml), or nullptr.
const char* builtin_device_model_yaml(const std::string& name);
/// The text that states model `model` (a device.model value): the compiled-in YAML of a preset,
/// a model file's contents, "" for ideal and constant (or a file that cannot be read). Results
/// keyed by the configuration key them by it too, so an edited model file is a new design.
std::string device_model_text(const std::string& model);
/// The names of the compiled-in models, comma-separated.
std::string builtin_device_models();

/// Section `device.` (and converters.readout_noise_na, the readout's part of a read).
struct DeviceSpec {
  DeviceKind kind = DeviceKind::Ideal;
  std::string model = "ideal";  ///< as written in device.model
  double program_sigma_s = 0;   ///< constant: programming error sigma (S)
  double read_sigma_s = 0;      ///< constant: one read's sigma (S)
  StatisticalModel stat;        ///< statistical
  double time_s = 0;            ///< inference time after programming (s); calibration reads at 0
  Compensation compensation = Compensation::None;
  double stuck_gmin = 0, stuck_gmax = 0;  ///< fractions of cells stuck at g_min / g_max
  int spare_columns = 0;                  ///< per crossbar
  uint64_t seed = 11;
  /// The conductance range the cells live on (S): the model's (statistical) or crossbar.g_min/g_max.
  double g_min_s = 0, g_max_s = 0;
  /// The range the model fixes (statistical), or false (crossbar.g_min/g_max hold).
  bool fixes_range() const { return kind == DeviceKind::Statistical; }
  bool has_faults() const { return stuck_gmin > 0 || stuck_gmax > 0; }
  /// A cell's read fluctuates (the readout's noise is the crossbar's: converters.readout_noise_na).
  bool has_read_noise() const;
  /// The state changes after programming (at_time is not the identity for t > 0).
  bool moves() const;
  /// Programs conductances other than the targets (error or faults).
  bool perturbs_programming() const;
};

/// Reads and validates section `device.`; a statistical model is loaded from its built-in name
/// or its file here. g_min_s/g_max_s: the model's range, or crossbar.g_min/g_max (a model that
/// fixes the range refuses crossbar.g_min/g_max set away from their defaults).
DeviceSpec parse_device_spec(const ConfigTree& cfg);

/// Per cell of one crossbar: stuck (-1 at g_min, +1 at g_max) or free (0).
using FaultMap = Eigen::Array<int8_t, Eigen::Dynamic, Eigen::Dynamic>;

/// The device model of a spec. Cheap to copy; every method is const and thread-safe.
class Device {
 public:
  explicit Device(const DeviceSpec& spec) : spec_(spec) {}
  const DeviceSpec& spec() const { return spec_; }
  /// Programs the cells of one crossbar: `g` holds the targets (S) and receives the programmed
  /// conductances; `faults` the stuck cells. `stream`: the crossbar's (derive_seed of the
  /// layer and crossbar); cell k of column c draws from (stream, c, k) only.
  void program(Eigen::MatrixXd& g, FaultMap& faults, uint64_t stream) const;
  /// Places stuck cells only (program() calls it): each cell stuck at g_min with probability
  /// stuck_gmin, at g_max with stuck_gmax, from (stream, column, cell).
  void place_faults(FaultMap& faults, Eigen::Index rows, Eigen::Index cols, uint64_t stream) const;
  /// The state t seconds after programming of cells programmed to `g_prog` with targets
  /// `g_target` (what the drift exponent and relaxation depend on): drift, relaxation and
  /// accumulated noise; stuck cells keep their conductance. At t = 0 the programmed state
  /// (plus the noise accumulated by the first read, for models with 1/f noise).
  Eigen::MatrixXd at_time(const Eigen::MatrixXd& g_target, const Eigen::MatrixXd& g_prog, const FaultMap& faults,
                          double t, uint64_t stream) const;
  /// One read's standard deviation of every cell's conductance (S), at state `g`.
  Eigen::MatrixXd read_sigma(const Eigen::MatrixXd& g) const;
  /// The same for one cell.
  double read_sigma_s(double g) const;
  /// The standard deviation (S) around its target of what one read sees of a cell programmed to
  /// g_target, right after programming: the programming error and one read's fluctuation (what
  /// ranging.weights: mse weighs against the weight code's rounding and clipping; later drift
  /// and relaxation are the compensation's). 0 for ideal cells.
  double read_spread_s(double g_target) const;
  /// The stream of the reads image `image` makes of crossbar `crossbar` of layer `layer` (its salt).
  uint64_t read_noise_key(uint64_t image, uint64_t layer, uint64_t crossbar) const;
  /// The conductances one read sees: g plus read_sigma(g) times read `read`'s draws of stream
  /// `key` (cell k draws index k), at least an open cell. Nonlinear devices solve with them.
  Eigen::MatrixXd read(const Eigen::MatrixXd& g, uint64_t key, uint64_t read) const;
  /// The lowest conductance a draw may reach (an open cell): 1 nS.
  static constexpr double kOpenCellS = 1e-9;

  // The model's formulas, for tests and the Python binding (x = G_target / g_max).
  double program_sigma_s(double g_target) const;
  double nu_mean(double g_target) const;
  double nu_std(double g_target) const;
  /// Relaxation at time t: the spread (S) and mean shift (S) around the target (total) or the
  /// programmed state (incremental).
  double relax_sigma_s(double g_target, double t) const;
  double relax_shift_s(double t) const;
  /// The accumulated 1/f noise sigma (S) of a cell programmed to g_prog and now at g_now.
  double noise_sigma_s(double g_prog, double g_now, double t) const;

 private:
  double clip(double g) const;
  DeviceSpec spec_;
};

/// Normal deviates of a counter-based stream: the same value for the same (key, index) in any
/// order (Box-Muller on two SplitMix64 draws).
double counter_normal(uint64_t key, uint64_t index);
/// A uniform deviate in [0, 1) of (key, index).
double counter_uniform(uint64_t key, uint64_t index);
/// n standard normal deviates (float) of read `read` of stream `key`: the same values for the same
/// (key, read) in any order or batch; each one of 2^13 equiprobable quantiles of the normal
/// distribution (unit variance, tails cut at 3.8 sigma), picked by a 32-bit hash of the read's
/// stream and the deviate's index.
void read_normals(uint64_t key, uint64_t read, Eigen::Index n, float* out);
/// Its parts, for callers filling draws in another order: read r's 32-bit stream, and deviate c
/// of it, the table entry at the top bits of a 32-bit hash of (stream, c) (vectorises: a
/// multiply-xorshift hash per deviate and a gather from a table in the first-level cache).
uint32_t read_stream(uint64_t key, uint64_t read);
constexpr int kNormalTableBits = 13;
inline uint32_t read_hash(uint32_t stream, uint32_t c) {
  uint32_t h = stream + c * 0x9E3779B9u;
  h ^= h >> 16;
  h *= 0x85EBCA6Bu;
  h ^= h >> 13;
  h *= 0xC2B2AE35u;
  h ^= h >> 16;
  return h >> (32 - kNormalTableBits);
}
/// The 2^13 deviates (unit variance).
const float* normal_table();
/// Deviates 0 .. n-1 of the read whose stream is `stream` (a row of draws).
void normals_of_read(uint32_t stream, Eigen::Index n, float* out);
/// Deviate c of each of n reads (their streams), a column of draws.
void normals_of_column(const uint32_t* streams, Eigen::Index n, uint32_t c, float* out);

}  // namespace xbarsim
