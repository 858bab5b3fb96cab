#pragma once
/// One matrix-vector layer Y = X * W executed on resistive crossbars, with the paper's
/// mapping (shift method or differential pairs), partitioning, conversion, programming
/// noise, DAC/ADC quantization and calibration. SystemC-free; the SystemC modules call its
/// stages (dac, analog, adc, recover) so both engines compute bit-identical results.
#include <Eigen/Dense>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "sw/analog/calibration.h"
#include "sw/analog/partition.h"
#include "sw/analog/quantizer.h"
#include "sw/circuit/crossbar_solver.h"
#include "sw/common/config.h"

namespace xbarsim {

enum class ConversionKind { None, Signal, Matrix };

/// Everything that configures an analog layer (YAML sections crossbar, solver, mapping,
/// conversion, calibration, converters, noise).
struct AnalogConfig {
  CrossbarParams xbar;
  SolverOptions solver;
  int max_rows = 0;  ///< 0 = unbounded
  int max_cols = 0;
  bool differential = false;  ///< mapping.negative = differential
  bool analog_sum = false;    ///< mapping.sum_x = analog
  double g_headroom = 0;      ///< mapping.g_headroom: weights map to [g_min, g_max (1 - headroom)]
  std::string method = "conversion+calibration";
  ConversionKind conversion = ConversionKind::Signal;
  bool calibrate = true;
  std::string conversion_signal = "constant";  ///< constant | max_input | mean_input
  double conversion_amplitude = 0.1;           ///< fraction of v_in_max
  bool optimize_amplitude = false;
  bool paper_amplitudes = false;  ///< conversion.amplitude = paper: per crossbar size as in the paper
  bool column_scaling = true;
  int conversion_max_iterations = 60;
  double conversion_tolerance = 1e-9;  ///< matrix conversion: max |G_eff - T| / max T
  int calibration_samples = 10;
  std::string calibration_signal = "shuffled";  ///< random | random_decreasing | shuffled
  uint64_t calibration_seed = 7;
  int dac_bits = 0;  ///< 0 = none
  int adc_bits = 0;
  double adc_margin = 0.05;
  bool adc_offset_subtraction = true;  ///< subtract the sum(X) shift current before the ADC
  double sigma_s = 0;  ///< programming noise (S)
  uint64_t noise_seed = 11;

  /// Sets method, conversion and calibrate from a method name; throws InputError naming `key`.
  void set_method(const std::string& name, const std::string& key);
};

/// Reads and validates the sections above; the method comes from `method_key`.
AnalogConfig parse_analog_config(const ConfigTree& cfg, const std::string& method_key = "mitigation.method");

/// Statistics of one programmed crossbar.
struct CrossbarReport {
  Block block;                 ///< rows/columns of W it holds
  int physical_cols = 0;       ///< columns incl. differential pairs / sum column
  int out_of_range_cells = 0;  ///< conversion wanted G' outside [g_min, g_max] (clipped)
  double min_column_gain = 1;  ///< matrix conversion column scaling (1 = full range)
  double conversion_amplitude = 0;  ///< constant-signal amplitude used (fraction of v_in_max)
  double conversion_residual = 0;   ///< matrix conversion max |G_eff - T| / max T
};

class AnalogLayer {
 public:
  /// `w` is K x N (inputs x outputs). Inputs span [0, x_max] (or [-x_max, x_max] when
  /// `signed_inputs`) and map to [0, v_in_max] volts. `salt` decorrelates the random
  /// choices (noise, calibration picks) of different layers.
  AnalogLayer(const AnalogConfig& cfg, const Eigen::MatrixXd& w, double x_max, bool signed_inputs, uint64_t salt = 0);
  ~AnalogLayer();
  AnalogLayer(AnalogLayer&&) noexcept;

  /// Maps, converts, programs (with noise) every crossbar, sets ADC ranges and calibrates.
  /// `calib` (C x K) holds real input vectors for calibration and range estimation; when
  /// empty, calibration uses random vectors (50 % sparse).
  void program(const Eigen::MatrixXd& calib);
  /// The same with other solver options (e.g. one thread when layers program in parallel).
  void program(const Eigen::MatrixXd& calib, const SolverOptions& solver);

  template <typename S>
  using Mat = Eigen::Matrix<S, Eigen::Dynamic, Eigen::Dynamic>;
  /// Input vectors, one per row (row-major so that one iteration's vector is contiguous).
  template <typename S>
  using RowMat = Eigen::Matrix<S, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

  /// Y (vectors x N) = the crossbar computation of X * W, all stages (double precision).
  Eigen::MatrixXd forward(const Eigen::MatrixXd& x) const;
  /// Recovered, calibrated partial output of crossbar b (vectors x block cols), double.
  Eigen::MatrixXd partial(int b, const Eigen::MatrixXd& x) const;

  // The stages of forward(), in order; float (network inference) and double (studies).
  // forward() is exactly their composition, so callers composing them (the SystemC
  // modules) compute bit-identical results.
  /// `quantized`: the inputs are already DAC values (see dac_values), skip the DAC stage.
  template <typename S>
  void forward(const RowMat<S>& x, Mat<S>& y, bool quantized = false) const;
  /// DAC quantization of n values in place. Unsigned inputs: 2^bits levels on [0, x_max];
  /// signed: sign and bits-1 magnitude bits (zero is a level, so quantizing activations
  /// before or after im2col gives identical vectors).
  template <typename S>
  void dac_values(S* data, Eigen::Index n) const;
  template <typename S>
  void dac_inplace(RowMat<S>& x) const;  ///< DAC quantization (input units)
  template <typename S>
  void analog(int b, const RowMat<S>& xq, Mat<S>& currents) const;  ///< column currents (A)
  template <typename S>
  void adc_inplace(int b, Mat<S>& currents, const RowMat<S>& xq) const;  ///< ADC quantization
  /// Adds the partial output of crossbar b (shift/differential recovery with sum(X), then
  /// calibration when `calibrated`) into columns [col0, col0 + cols) of y.
  template <typename S>
  void recover_add(int b, const Mat<S>& iq, const RowMat<S>& xq, Mat<S>& y, bool calibrated = true) const;

  int inputs() const { return static_cast<int>(w_.rows()); }
  int outputs() const { return static_cast<int>(w_.cols()); }
  int crossbars() const { return static_cast<int>(blocks_.size()); }
  const Block& block(int b) const;
  const std::vector<CrossbarReport>& reports() const { return reports_; }
  double volts_per_unit() const { return alpha_; }
  const AnalogConfig& config() const { return cfg_; }

 private:
  struct Crossbar;
  Eigen::MatrixXd calibration_vectors(const Eigen::MatrixXd& calib) const;
  template <typename S>
  void analog_of(const Crossbar& x, const RowMat<S>& xq, Mat<S>& currents) const;
  template <typename S>
  void recover_of(const Crossbar& x, const Mat<S>& iq, const RowMat<S>& xq, Mat<S>& y, int y_col0,
                  bool calibrated) const;
  /// Double-precision helpers used while programming.
  Eigen::MatrixXd dac(const Eigen::MatrixXd& x) const;
  Eigen::MatrixXd currents_of(const Crossbar& x, const Eigen::MatrixXd& xq) const;
  Eigen::MatrixXd raw_partial_of(const Crossbar& x, const Eigen::MatrixXd& iq, const Eigen::MatrixXd& xq) const;

  AnalogConfig cfg_;
  Eigen::MatrixXd w_;
  double x_max_;
  bool signed_;
  uint64_t salt_;
  double alpha_;  ///< V per input unit
  Quantizer dac_q_;
  std::vector<Block> blocks_;
  std::vector<std::unique_ptr<Crossbar>> xbars_;
  std::vector<CrossbarReport> reports_;
};

}  // namespace xbarsim
