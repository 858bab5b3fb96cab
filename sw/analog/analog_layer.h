#pragma once
/// One matrix-vector layer Y = X * W executed on resistive crossbars, in three parts:
///  - weight mapping (weight_mapping.h): partitioning, shift or differential pairs, sum(X)
///    column -> target conductances and the physical column layout;
///  - programming (analog_programming.cpp): conversion, programming noise, ADC ranging and
///    calibration, in named steps;
///  - the programmed crossbars and the forward stages (dac, analog, adc, recover) that use
///    them (analog_layer.cpp). SystemC-free; the SystemC modules call the same stages, so
///    both engines compute bit-identical results.
#include <Eigen/Dense>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "sw/analog/analog_spec.h"
#include "sw/analog/calibration.h"
#include "sw/analog/input_slicing.h"
#include "sw/analog/partition.h"
#include "sw/analog/quantizer.h"
#include "sw/analog/ranging.h"
#include "sw/analog/weight_mapping.h"
#include "sw/circuit/crossbar_solver.h"
#include "sw/common/config.h"
#include "sw/device/device.h"

namespace xbarsim {

/// Everything that configures an analog layer: the typed specs of the sections crossbar,
/// solver, mapping, mitigation, conversion, calibration, converters and device.
struct AnalogConfig {
  CrossbarParams xbar;
  SolverOptions solver;
  MappingSpec mapping;
  MitigationSpec mitigation;
  ConversionSpec conversion;
  CalibrationSpec calibration;
  ConvertersSpec converters;
  RangingSpec ranging;
  DeviceSpec device;
  /// Sets the mitigation from a method name; throws InputError naming `key`.
  void set_method(const std::string& name, const std::string& key) { mitigation = mitigation_from_name(name, key); }
  /// The DACs pre-distort (and carry lookup tables): converters.dac_predistortion with a sinh
  /// memristor; with a linear one the table would be the identity.
  bool dac_predistorts() const { return converters.dac_predistortion && xbar.memristor.model == MemristorModel::Sinh; }
};

/// `c` with the cells' conductance range settled: a device model that fixes one (statistical)
/// gives it to the crossbar; otherwise the device takes crossbar.g_min/g_max.
AnalogConfig with_device_range(AnalogConfig c);

/// Reads and validates the sections above; the method comes from `method_key`.
AnalogConfig parse_analog_config(const ConfigTree& cfg, const std::string& method_key = "mitigation.method");

/// Whether two configurations program the same conductances (AnalogLayer::program's conversion,
/// device programming and circuit state): they differ at most in the readout, which programming
/// applies after the conductances are written (ADC ranging and calibration) and the time the
/// layer is read at: converters.adc_bits, adc_range, adc_margin, adc_offset_subtraction and
/// adc_columns_per_adc (cost only), whether the method calibrates (not its conversion),
/// device.time_s and device.compensation, and solver.threads (no result depends on it).
/// Everything else (crossbar, solver, mapping, conversion, calibration, the device's model, seed,
/// faults and read noise, the readout noise, DAC and input bits, pre-distortion) programs. A new field of AnalogConfig is compared here unless it is read out only.
bool programs_alike(const AnalogConfig& a, const AnalogConfig& b);

/// Statistics of one programmed crossbar.
struct CrossbarReport {
  Block block;                      ///< rows/columns of W it holds
  int physical_cols = 0;            ///< columns incl. differential pairs / sum column
  int out_of_range_cells = 0;       ///< conversion wanted G' outside [g_min, g_max] (clipped)
  double min_column_gain = 1;       ///< matrix conversion column scaling (1 = full range)
  double conversion_amplitude = 0;  ///< constant-signal amplitude used (fraction of v_in_max)
  double conversion_residual = 0;   ///< matrix conversion max |G_eff - T| / max T
  int stuck_cells = 0;              ///< cells stuck at g_min or g_max (device.stuck_at_*), after spares
  int spare_columns_used = 0;       ///< columns replaced by spare columns
  long long clipped_weights = 0;    ///< weights outside their column's range (ranging.weights), held at its end
  /// Per weight column of the block: the magnitude mapped to the top of the conductance span
  /// over the largest |w| of the column (1 = nothing clipped).
  Eigen::VectorXd weight_clip;
};

/// A grouped convolution's rows (Conv `group`): rows r = p * channels + c (window position p,
/// input channel c innermost, eval's im2col order), input channel c in group c / (channels /
/// count), and the outputs split evenly into `count` groups. Each group is programmed onto
/// crossbars of its own (its K / count rows by its N / count columns): no crossbar holds the
/// zeros between groups.
struct RowGroups {
  int count = 1;
  int channels = 0;  ///< input channels (rows per window position); unused when count is 1
};

class AnalogLayer {
 public:
  /// Vectors used to estimate ADC ranges: nonlinear devices need a Newton solve per vector.
  static constexpr int kRangeVectorsLinear = 2048, kRangeVectorsNonlinear = 128;
  /// Stream ids of the random picks (derived with calibration.seed and the layer's salt).
  static constexpr uint64_t kCalibrationPickStream = 0xCA1, kRangePickStream = 0x5A7;
  /// The "images" of the reads programming and compensation make (read noise streams): an
  /// inference image is its index in the dataset, below these.
  static constexpr uint64_t kRangeReads = ~0ull - 1, kCalibrationReads = ~0ull - 2, kReferenceReads = ~0ull - 3,
                            kConversionReads = ~0ull - 4;

  /// `w` is K x N (inputs x outputs). Inputs span [0, x_max] (or [-x_max, x_max] when
  /// `signed_inputs`) and map to [0, v_in_max] volts. `salt` decorrelates the random
  /// choices (noise, calibration picks) of different layers.
  /// `groups`: a grouped layer's block-diagonal `w` is programmed group by group (RowGroups);
  /// the crossbars then read the inputs in group order (arrange_inputs).
  AnalogLayer(const AnalogConfig& cfg, const Eigen::MatrixXd& w, double x_max, bool signed_inputs, uint64_t salt = 0,
              const RowGroups& groups = {});
  ~AnalogLayer();
  AnalogLayer(AnalogLayer&&) noexcept;

  /// Maps, converts, programs (device.model: programming error, faults) every crossbar, sets ADC
  /// ranges and calibrates (reads at t = 0), then moves to device.time_s (drift, compensation).
  /// `calib` (C x K) holds real input vectors for calibration and range estimation; when
  /// empty, calibration uses random vectors (50 % sparse).
  void program(const Eigen::MatrixXd& calib);
  /// The same with other solver options (e.g. one thread when layers program in parallel).
  void program(const Eigen::MatrixXd& calib, const SolverOptions& solver);
  /// Gives the programmed crossbars the readout of `cfg` (programs_alike: its ADCs, whether it
  /// calibrates, device.time_s and compensation) without converting or writing them again: only
  /// program()'s last steps run again (ADC ranging and calibration, moving to the time), on the
  /// same inputs, so the layer equals one programmed from scratch with `cfg` and `calib`, bit for bit. `calib` must be what program() was given.
  /// std::invalid_argument when `cfg` does not program alike or nothing is programmed; on any
  /// error the layer keeps its readout.
  void set_readout(const AnalogConfig& cfg, const Eigen::MatrixXd& calib);
  /// A copy of what set_readout changes (the configuration, every crossbar's ADC ranges and
  /// calibration), to put back with restore_readout (a caller's all-or-nothing over layers).
  struct SavedReadout;
  std::shared_ptr<const SavedReadout> save_readout() const;
  void restore_readout(const SavedReadout& saved);

  template <typename S>
  using Mat = Eigen::Matrix<S, Eigen::Dynamic, Eigen::Dynamic>;
  /// Input vectors, one per row (row-major so that one iteration's vector is contiguous).
  template <typename S>
  using RowMat = Eigen::Matrix<S, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

  /// Y (vectors x N) = the crossbar computation of X * W, all stages (double precision).
  Eigen::MatrixXd forward(const Eigen::MatrixXd& x, uint64_t image = 0) const;
  /// Recovered, calibrated partial output of crossbar b (vectors x block cols), double.
  Eigen::MatrixXd partial(int b, const Eigen::MatrixXd& x) const;

  // The stages of forward(), in order; float (network inference) and double (studies).
  // forward() is exactly their composition, so callers composing them (the SystemC
  // modules) compute bit-identical results. Two forms:
  //  - one read per vector (not input_slicing().serial()): dac_inplace, then analog,
  //    adc_inplace and recover_add on xq (vectors x K DAC values) and currents (vectors x
  //    physical columns);
  //  - bit-serial reads: dac_inplace, slice_inputs (the DAC codes whose digits the reads
  //    apply), then the same three stages on the reads of a range of vectors (ReadCurrents).
  //    forward() runs them on a few vectors at a time; every read's result is independent of
  //    the range it is computed in.
  //  A grouped layer's stages read the inputs in group order: arrange_inputs after the DAC.
  /// `quantized`: the inputs are already DAC values (see dac_values), skip the DAC stage.
  /// `image`: the dataset index of the image the vectors belong to (vector r of x is read r of
  /// the image): it keys the read noise, so every read draws the same on any thread count.
  template <typename S>
  void forward(const RowMat<S>& x, Mat<S>& y, bool quantized = false, uint64_t image = 0) const;
  /// "crossbar of rows 144..287, weight columns 0..63 (of 4)", for messages.
  std::string crossbar_name(const Block& blk) const;
  /// DAC quantization of n values in place. Unsigned inputs: 2^bits levels on [0, x_max];
  /// signed: sign and bits-1 magnitude bits (zero is a level, so quantizing activations
  /// before or after im2col gives identical vectors).
  template <typename S>
  void dac_values(S* data, Eigen::Index n) const;
  template <typename S>
  void dac_inplace(RowMat<S>& x) const;  ///< DAC quantization (input units)
  /// Reorders the inputs' columns into the crossbars' row order (a grouped layer: group by
  /// group; otherwise nothing to do).
  template <typename S>
  void arrange_inputs(RowMat<S>& x) const;
  /// Column currents (A); row r of xq is read r of `image` (its read noise).
  template <typename S>
  void analog(int b, const RowMat<S>& xq, Mat<S>& currents, uint64_t image = 0) const;
  template <typename S>
  void adc_inplace(int b, Mat<S>& currents, const RowMat<S>& xq) const;  ///< ADC quantization
  /// Adds the partial output of crossbar b (shift/differential recovery with sum(X), the
  /// shift-and-add of weight slices, then calibration when `calibrated`) into columns
  /// [col0, col0 + cols) of y; iq and xq hold y.rows() rows.
  template <typename S>
  void recover_add(int b, const Mat<S>& iq, const RowMat<S>& xq, Mat<S>& y, bool calibrated = true) const;

  /// A row-major matrix whose storage only grows: a buffer reshaped for every layer and
  /// crossbar allocates (and touches its pages) once.
  template <typename T>
  class Rows {
   public:
    void resize(Eigen::Index rows, Eigen::Index cols) {
      rows_ = rows;
      cols_ = cols;
      data_.resize(static_cast<size_t>(rows * cols));
    }
    Eigen::Index rows() const { return rows_; }
    Eigen::Index cols() const { return cols_; }
    T* row(Eigen::Index r) { return data_.data() + r * cols_; }
    const T* row(Eigen::Index r) const { return data_.data() + r * cols_; }
    T& operator()(Eigen::Index r, Eigen::Index c) { return data_[static_cast<size_t>(r * cols_ + c)]; }
    T operator()(Eigen::Index r, Eigen::Index c) const { return data_[static_cast<size_t>(r * cols_ + c)]; }
    T* data() { return data_.data(); }
    Eigen::Map<RowMat<T>> matrix() { return {data_.data(), rows_, cols_}; }
    Eigen::Map<const RowMat<T>> matrix() const { return {data_.data(), rows_, cols_}; }

   private:
    std::vector<T> data_;
    Eigen::Index rows_ = 0, cols_ = 0;
  };
  /// Bit-serial reads of a batch of vectors (vectors x K): each vector's DAC code per input,
  /// as its (m+1)-bit two's complement pattern (InputSlicing::pattern); read s of a vector
  /// applies digit s of its codes (InputSlicing::digit).
  using Codes = Rows<int32_t>;
  /// One crossbar's bit-serial reads of the vectors [first, first + vectors): row
  /// (r - first) * slices + s is read s of vector r, LSB first.
  template <typename S>
  struct ReadCurrents {
    Eigen::Index first = 0, vectors = 0;
    Rows<S> i;             ///< reads x physical columns: column currents (A)
    std::vector<S> sum_x;  ///< per read: its inputs summed over the crossbar's rows
  };
  /// The DAC codes of quantized inputs xq (vectors x K). Only for input_slicing().serial().
  template <typename S>
  void slice_inputs(const RowMat<S>& xq, Codes& codes) const;
  /// Column currents of crossbar b for the reads of vectors [first, first + vectors) of codes.
  template <typename S>
  void analog(int b, const Codes& codes, Eigen::Index first, Eigen::Index vectors, ReadCurrents<S>& cur,
              uint64_t image = 0) const;
  /// ADC quantization of bit-serial reads (the range of read s with converters.adc_range: per_read).
  template <typename S>
  void adc_inplace(int b, ReadCurrents<S>& cur) const;
  /// Adds the partial output of crossbar b for cur's vectors into their rows of y: every read
  /// recovered, weighted by its input slice's place and added (shift-and-add), then calibrated.
  template <typename S>
  void recover_add(int b, const ReadCurrents<S>& cur, Mat<S>& y, bool calibrated = true) const;
  /// The values (input units) the reads of vectors [first, first + vectors) apply to rows
  /// [row0, row0 + rows), one row per read in ReadCurrents order.
  template <typename S>
  void read_values(const Codes& codes, Eigen::Index first, Eigen::Index vectors, int row0, int rows,
                   RowMat<S>& out) const;

  int inputs() const { return static_cast<int>(w_.rows()); }
  int outputs() const { return static_cast<int>(w_.cols()); }
  int crossbars() const { return static_cast<int>(blocks_.size()); }
  double x_max() const { return x_max_; }           ///< the inputs' full scale
  bool signed_inputs() const { return signed_; }    ///< inputs span [-x_max, x_max]
  const Block& block(int b) const;
  const std::vector<CrossbarReport>& reports() const { return reports_; }
  /// The time after programming the crossbars are read at (device.time_s).
  double time_s() const { return time_s_; }
  /// Reads made for drift compensation at time_s (reference reads per crossbar, summed).
  long long compensation_reads() const { return compensation_reads_; }
  /// The conductances crossbar b holds now (S): after programming and time_s.
  const Eigen::MatrixXd& conductances(int b) const;
  /// A per S per input unit: an isolated cell of conductance G passes alpha * G * x (V per
  /// unit for linear memristors; with pre-distortion h(v_in_max) / x_max, h the memristor I/G).
  double volts_per_unit() const { return alpha_; }
  /// The DAC's output voltages for quantized inputs x (pre-distorted when configured).
  Eigen::MatrixXd volts(const Eigen::MatrixXd& x) const;
  const AnalogConfig& config() const { return cfg_; }
  /// How inputs are streamed (one slice unless bit-serial).
  const InputSlicing& input_slicing() const { return slicing_; }
  /// The DAC stage quantizes (activation bits are set).
  bool quantizes_inputs() const { return dac_q_.enabled(); }
  /// Adds `offset` (per output column, output units) to the layer's outputs, replacing the
  /// offsets given before: the digital bias's correction (ranging.bias_correction, measured by
  /// the network's backend), kept when the readout is set again (calibration refitted). A new
  /// program() starts without. std::invalid_argument before program() or for another width.
  void set_output_offsets(const Eigen::VectorXd& offset);
  /// The offsets set_output_offsets gave (empty: none).
  const Eigen::VectorXd& output_offsets() const { return bias_; }
  /// The ranges the layer is programmed and read out with (ranging.*), for reports.
  struct RangeSummary {
    long long weights = 0, clipped_weights = 0;  ///< weights on the crossbars, and held at their range's end
    double weight_clip = 1;  ///< mean over weight columns of the magnitude mapped to the span's top over the column's largest |w|
    /// Mean over the measured ADC ranges (columns, references) of the range without its margin
    /// over the extent of the column's calibration currents (1: nothing clipped; 0 without ADC ranges).
    double adc_clip = 0;
    double adc_full_scale_a = 0;   ///< the widest ADC range of the layer (A, margin included)
    double output_offset_rms = 0;  ///< root mean square of the output offsets (output units)
  };
  RangeSummary range_summary() const;
  /// Per crossbar (block order), the ranges of its weight columns (ranging.weights and
  /// weight_scale, the mse clip with the device's programming and read spread): what program()
  /// maps, before anything is programmed.
  std::vector<WeightRanges> block_ranges() const;

 private:
  struct Crossbar;
  struct ProgrammingInputs;
  struct LayerInputs;
  Eigen::MatrixXd calibration_vectors(const Eigen::MatrixXd& calib) const;
  Eigen::MatrixXd range_vectors(const Eigen::MatrixXd& calib_in, const Eigen::MatrixXd& cal) const;
  /// What programming reads from `calib` (program()'s argument), for the whole layer; without
  /// `real_inputs` no calib_q (the readout steps do not read it).
  LayerInputs layer_inputs(const Eigen::MatrixXd& calib, bool real_inputs = true) const;
  /// The share of `in` crossbar `blk` reads while it is programmed.
  ProgrammingInputs crossbar_inputs(const LayerInputs& in, const Block& blk) const;
  // Programming steps (analog_programming.cpp), in order, for one crossbar.
  void install(Crossbar& x, const Eigen::MatrixXd& g) const;
  void convert(Crossbar& x, const ProgrammingInputs& in, CrossbarReport& rep) const;
  void convert_signal_amplitudes(Crossbar& x, const ProgrammingInputs& in, CrossbarReport& rep) const;
  /// The device writes the conversion's conductances: programming error, stuck cells, spare
  /// columns; the crossbar then holds its state at t = 0.
  void write_cells(Crossbar& x, CrossbarReport& rep) const;
  /// The read-noise model of a linear crossbar at its installed conductances (Crossbar::noise_p1).
  void fit_read_noise(Crossbar& x) const;
  /// The reads the read-noise model is fitted at: up to kNoisePoints of the range-estimation
  /// reads (the values each read applies), evenly spaced.
  Eigen::MatrixXd read_noise_points(const ProgrammingInputs& in) const;
  static constexpr int kNoisePoints = 16;
  /// Installs the state at time t after programming (a device that moves).
  void settle(Crossbar& x, double t) const;
  /// Per physical column: the reference reads' summed current after the ADC (compensation).
  Eigen::VectorXd reference_sums(const Crossbar& x, const ProgrammingInputs& in) const;
  /// Moves every crossbar to device.time_s and compensates (from the t = 0 readout).
  void move_to_time(const LayerInputs& in);
  /// Adds one read's device fluctuation and readout noise to the currents of reads whose
  /// values (input units, reads x crossbar rows) are `values`; read r is read first_read + r of image.
  /// `pre_var`, `pre_cross` (reads x columns by row, optional): the squared inputs times p1 and
  /// the inputs times p2, when the caller has them (bit-serial reads of binary digits).
  template <typename S, typename V>
  void add_read_noise(const Crossbar& x, const V& values, S* currents, Eigen::Index ld, bool row_major,
                      Eigen::Index first_read, uint64_t image, const float* pre_var = nullptr,
                      const float* pre_cross = nullptr) const;
  /// Nonlinear devices with read noise: every read solved with its own fluctuating conductances.
  Eigen::MatrixXd noisy_solves(const Crossbar& x, const Eigen::MatrixXd& volts, Eigen::Index first_read,
                               uint64_t image) const;
  template <typename S>
  void compensate(const Crossbar& x, S* currents, Eigen::Index reads, Eigen::Index ld, bool row_major) const;
  /// The offset each column's ADC subtracts (adc_offset), before its range is measured.
  void set_adc_offsets(Crossbar& x) const;
  /// The ADC ranges come from measured currents (an ADC, and converters.adc_range not full).
  bool measures_adc_ranges() const;
  /// The range-estimation reads' offset-subtracted currents of a crossbar (reads x columns) and
  /// the ADC reference each read uses; empty when the ranges are not measured.
  struct AdcSamples {
    Eigen::MatrixXd cur;
    Eigen::VectorXi range;
  };
  AdcSamples adc_samples(const Crossbar& x, const Eigen::MatrixXd& range_x) const;
  /// Column c's samples of reference g (of `ranges`).
  static std::vector<double> column_samples(const AdcSamples& a, int c, int g, int ranges);
  /// Sets x's ADC ranges (ranging.adc on its samples, or the layer's `pooled` range: rows lo, hi
  /// by reference) and the converters' tables.
  void set_adc_ranges(Crossbar& x, const AdcSamples& samples, const Eigen::MatrixXd* pooled) const;
  void set_full_adc_ranges(Crossbar& x) const;
  void calibrate(Crossbar& x, const ProgrammingInputs& in) const;
  /// Per weight column of x: the resolution of its recovered output (output units), one ADC
  /// code of each of its reads and physical columns combined as independent errors (root sum
  /// of squares); zeros without an ADC.
  Eigen::VectorXd output_steps(const Crossbar& x) const;
  /// The readout steps of crossbars whose conductances are written (the layer's, in block
  /// order): ADC offsets and ranges (per column, or one for the layer), then calibration, each
  /// crossbar reading its own rows of `in`; afterwards (also on a throw) every crossbar reads
  /// the layer's inputs at its rows again (in0 = its block's row0).
  void read_out_all(std::vector<std::unique_ptr<Crossbar>>& xbars, const LayerInputs& in) const;
  /// Adds `add` (per output column) to the offset of the first crossbar holding each column.
  void fold_output_offsets(std::vector<std::unique_ptr<Crossbar>>& xbars, const Eigen::VectorXd& add) const;
  template <typename S>
  void analog_of(const Crossbar& x, const RowMat<S>& xq, Mat<S>& currents, uint64_t image) const;
  template <typename S, typename XQ>
  void adc_of(const Crossbar& x, Mat<S>& currents, const XQ& xq) const;
  template <typename S>
  void recover_of(const Crossbar& x, const Mat<S>& iq, const RowMat<S>& xq, Mat<S>& y, int y_col0,
                  bool calibrated) const;
  template <typename S>
  void analog_of(const Crossbar& x, const Codes& codes, Eigen::Index first, Eigen::Index vectors,
                 ReadCurrents<S>& cur, uint64_t image) const;
  template <typename S>
  void adc_of(const Crossbar& x, ReadCurrents<S>& cur) const;
  template <typename S>
  void recover_of(const Crossbar& x, const ReadCurrents<S>& cur, Mat<S>& y, int y_col0, bool calibrated) const;
  template <typename S>
  void forward_serial(const RowMat<S>& xq, Mat<S>& y, uint64_t image) const;
  /// Double-precision helpers used while programming (xq: DAC values, vectors x K).
  Eigen::MatrixXd dac(const Eigen::MatrixXd& x) const;
  /// Column currents of one read per vector (not bit-serial).
  Eigen::MatrixXd currents_of(const Crossbar& x, const Eigen::MatrixXd& xq, uint64_t image) const;
  /// Crossbar x's column currents minus the ADC's offset for every read of xq, one row per
  /// read (ReadCurrents order), and the range of ADC reference each read uses.
  Eigen::MatrixXd offset_currents(const Crossbar& x, const Eigen::MatrixXd& xq, Eigen::VectorXi& range,
                                  uint64_t image) const;
  /// Crossbar x's recovered output for xq (vectors x its weight columns): converted by the
  /// ADC when `adc`, calibrated when `calibrated`.
  Eigen::MatrixXd partial_of(const Crossbar& x, const Eigen::MatrixXd& xq, bool adc, bool calibrated,
                             uint64_t image) const;
  /// The mean magnitude of the values the reads of xq apply to each of x's rows.
  Eigen::VectorXd mean_read_values(const Crossbar& x, const Eigen::MatrixXd& xq) const;

  AnalogConfig cfg_;
  Eigen::MatrixXd w_;
  double x_max_;
  bool signed_;
  uint64_t salt_;
  double alpha_;  ///< A/S per input unit (see volts_per_unit)
  Quantizer dac_q_;
  InputSlicing slicing_;
  std::vector<Block> blocks_;
  /// A grouped layer: the input column each crossbar row reads (w_'s rows are in this order).
  Eigen::VectorXi order_;
  std::vector<std::unique_ptr<Crossbar>> xbars_;
  std::vector<CrossbarReport> reports_;
  Device device_;
  double time_s_ = 0;
  long long compensation_reads_ = 0;
  Eigen::VectorXd bias_;
};

}  // namespace xbarsim
