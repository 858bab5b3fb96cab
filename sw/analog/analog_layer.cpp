#include "sw/analog/analog_layer.h"

#if defined(__AVX512F__)
#include <immintrin.h>
#endif
#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>
#include <sstream>
#include <type_traits>

#include "sw/analog/error_metrics.h"
#include "sw/analog/synthetic.h"
#include "sw/analog/analog_layer_impl.h"
#include "sw/circuit/device_models.h"
#include "sw/common/seed.h"
#include "sw/mitigation/conversion.h"

namespace xbarsim {

AnalogConfig parse_analog_config(const ConfigTree& cfg, const std::string& method_key) {
  AnalogConfig c;
  c.xbar = parse_crossbar_params(cfg);
  c.solver = parse_solver_options(cfg);
  c.mapping = parse_mapping_spec(cfg, c.xbar);
  c.mitigation = mitigation_from_name(cfg.get_string(method_key), method_key);
  c.conversion = parse_conversion_spec(cfg);
  c.calibration = parse_calibration_spec(cfg);
  if (c.calibration.samples < 2) throw InputError("configuration key 'calibration.samples' must be >= 2");
  c.converters = parse_converters_spec(cfg);
  c.noise = parse_noise_spec(cfg);
  if (c.converters.adc_range == AdcRange::Full) {
    const char* missing = c.mapping.cell_bits == 0              ? "crossbar.cell_bits (a level to count)"
                          : c.converters.activation_bits() == 0 ? "converters.dac_bits or input_bits (a read step)"
                          : !c.converters.adc_offset_subtraction
                              ? "converters.adc_offset_subtraction: true (a range from zero)"
                              : nullptr;
    if (missing)
      throw InputError(std::string("configuration key 'converters.adc_range' (full): the full range counts cell levels "
                                   "times DAC steps, so it needs ") +
                       missing);
  }
  if (c.dac_predistorts() && c.mitigation.conversion() == ConversionKind::Matrix)
    throw InputError("configuration key 'converters.dac_predistortion': not combinable with the matrix conversion (" +
                     std::string(c.mitigation.name()) +
                     "), which targets I = V G at the applied voltage; use conversion or conversion+calibration");
  return c;
}

AnalogLayer::AnalogLayer(const AnalogConfig& cfg, const Eigen::MatrixXd& w, double x_max, bool signed_inputs,
                         uint64_t salt)
    : cfg_(cfg), w_(w), x_max_(x_max), signed_(signed_inputs), salt_(salt) {
  if (w.rows() < 1 || w.cols() < 1) throw InputError("analog layer: empty weight matrix");
  if (!(x_max > 0) || !std::isfinite(x_max)) throw InputError("analog layer: input full scale must be > 0");
  alpha_ = cfg.xbar.v_in_max_v / x_max;
  // With pre-distortion I/G = h(V(x)) = alpha x, full scale at v_in_max.
  if (cfg.dac_predistorts())
    alpha_ = MemristorDevice(cfg.xbar.memristor).current_per_siemens(cfg.xbar.v_in_max_v) / x_max;
  // Signed inputs: sign-magnitude, so that 0 is exactly a DAC level.
  const int bits = cfg.converters.activation_bits();
  dac_q_ = Quantizer{signed_inputs ? std::max(bits - 1, bits > 0 ? 1 : 0) : bits, 0.0, x_max};
  slicing_ = make_input_slicing(bits, cfg.converters.dac_bits, signed_inputs, x_max);
  blocks_ = crossbar_blocks(static_cast<int>(w.rows()), static_cast<int>(w.cols()), cfg.mapping);
}

AnalogLayer::~AnalogLayer() = default;
AnalogLayer::AnalogLayer(AnalogLayer&&) noexcept = default;

const Block& AnalogLayer::block(int b) const { return blocks_.at(b); }

Eigen::MatrixXd AnalogLayer::calibration_vectors(const Eigen::MatrixXd& calib) const {
  const int k = static_cast<int>(w_.rows()), count = cfg_.calibration.samples;
  std::mt19937_64 rng(derive_seed(cfg_.calibration.seed, {kCalibrationPickStream, salt_}));
  if (cfg_.calibration.signal == CalibrationSignal::Shuffled && calib.rows() > 0) {
    std::vector<int> idx(calib.rows());
    std::iota(idx.begin(), idx.end(), 0);
    std::shuffle(idx.begin(), idx.end(), rng);
    Eigen::MatrixXd out(count, k);
    for (int a = 0; a < count; ++a) out.row(a) = calib.row(idx[a % idx.size()]);
    return out;
  }
  // Random signals with the sparsity of the real inputs (50 % when none are given).
  double sparsity = 0.5;
  if (calib.size() > 0) sparsity = static_cast<double>((calib.array() == 0).count()) / calib.size();
  Eigen::MatrixXd out = synthetic_inputs(count, k, sparsity, x_max_, rng());
  if (signed_) {
    std::uniform_int_distribution<int> sign(0, 1);
    for (Eigen::Index a = 0; a < out.size(); ++a)
      if (sign(rng)) out.data()[a] = -out.data()[a];
  }
  if (cfg_.calibration.signal == CalibrationSignal::RandomDecreasing)
    for (int a = 0; a < count; ++a) out.row(a) /= (a + 1);
  return out;
}

Eigen::MatrixXd AnalogLayer::range_vectors(const Eigen::MatrixXd& calib_in, const Eigen::MatrixXd& cal) const {
  // The real inputs (a sample of them) and the calibration set, quantized by the DAC.
  const Eigen::Index cap = cfg_.xbar.is_linear() ? kRangeVectorsLinear : kRangeVectorsNonlinear;
  const Eigen::Index take = std::min<Eigen::Index>(calib_in.rows(), cap);
  Eigen::MatrixXd range_x(take + cal.rows(), w_.rows());
  std::mt19937_64 rng(derive_seed(cfg_.calibration.seed, {kRangePickStream, salt_}));
  for (Eigen::Index a = 0; a < take; ++a)
    range_x.row(a) = calib_in.row(calib_in.rows() <= cap ? a : static_cast<Eigen::Index>(rng() % calib_in.rows()));
  range_x.bottomRows(cal.rows()) = cal;
  return dac(range_x);
}

void AnalogLayer::program(const Eigen::MatrixXd& calib, const SolverOptions& solver) {
  cfg_.solver = solver;
  program(calib);
}

void AnalogLayer::program(const Eigen::MatrixXd& calib_in) {
  if (calib_in.size() > 0 && calib_in.cols() != w_.rows())
    throw InputError("analog layer: calibration vectors have the wrong length");
  const Eigen::MatrixXd cal = dac(calibration_vectors(calib_in));
  const Eigen::MatrixXd cal_s = sliced(cal);
  const Eigen::MatrixXd range_s = sliced(range_vectors(calib_in, cal));
  const Eigen::MatrixXd calib_q = calib_in.size() ? dac(calib_in) : Eigen::MatrixXd();
  xbars_.clear();
  reports_.clear();
  for (size_t b = 0; b < blocks_.size(); ++b) {
    try {
      const Block& blk = blocks_[b];
      auto xb = std::make_unique<Crossbar>();
      static_cast<MappedWeights&>(*xb) =
          map_weights(w_.block(blk.row0, blk.col0, blk.rows, blk.cols), blk, cfg_.mapping, cfg_.xbar);
      xb->beta = Eigen::VectorXd::Ones(xb->pcols);
      xb->solver = make_crossbar_solver(cfg_.xbar, cfg_.solver);
      const ProgrammingInputs in{
          cal.middleCols(blk.row0, blk.rows),
          calib_q.size() ? Eigen::MatrixXd(calib_q.middleCols(blk.row0, blk.rows)) : Eigen::MatrixXd(), cal, cal_s,
          cal.middleCols(blk.row0, blk.rows) * w_.block(blk.row0, blk.col0, blk.rows, blk.cols)};
      CrossbarReport rep;
      rep.block = blk;
      rep.physical_cols = xb->pcols;
      convert(*xb, in, rep);
      add_programming_noise(*xb, static_cast<int>(b));
      set_adc_ranges(*xb, range_s);
      calibrate(*xb, in);
      xbars_.push_back(std::move(xb));
      reports_.push_back(rep);
    } catch (const std::exception&) {
      rethrow_with_context("programming its " + crossbar_name(blocks_[b]));
    }
  }
}

std::string AnalogLayer::crossbar_name(const Block& blk) const {
  return "crossbar of rows " + std::to_string(blk.row0) + ".." + std::to_string(blk.row0 + blk.rows - 1) +
         ", weight columns " + std::to_string(blk.col0) + ".." + std::to_string(blk.col0 + blk.cols - 1) + " (of " +
         std::to_string(crossbars()) + ")";
}

Eigen::MatrixXd AnalogLayer::volts(const Eigen::MatrixXd& x) const {
  if (!cfg_.dac_predistorts()) return alpha_ * x;
  // The lookup table's entry for each code: h(V) = alpha x; h is odd, so signed inputs keep
  // their sign.
  const MemristorDevice mem(cfg_.xbar.memristor);
  return x.unaryExpr([&](double u) { return mem.voltage_for(alpha_ * u); });
}

Eigen::MatrixXd AnalogLayer::dac(const Eigen::MatrixXd& x) const {
  Eigen::MatrixXd out = x;
  dac_values<double>(out.data(), out.size());
  return out;
}

template <typename S>
void AnalogLayer::dac_values(S* d, Eigen::Index n) const {
  if (!dac_q_.enabled()) return;
  const FastQuantizer q(dac_q_);
  if (signed_) {
    for (Eigen::Index k = 0; k < n; ++k) d[k] = static_cast<S>(d[k] < 0 ? -q.apply(-d[k]) : q.apply(d[k]));
  } else {
    for (Eigen::Index k = 0; k < n; ++k) d[k] = static_cast<S>(q.apply(d[k]));
  }
}

Eigen::MatrixXd AnalogLayer::sliced(const Eigen::MatrixXd& xq) const {
  if (!slicing_.serial()) return xq;
  const RowMat<double> in = xq;
  RowMat<double> out;
  slice_inputs<double>(in, out);
  return out;
}

template <typename S>
void AnalogLayer::slice_inputs(const RowMat<S>& xq, RowMat<S>& xs) const {
  const InputSlicing& sl = slicing_;
  const Eigen::Index n = xq.rows(), k = xq.cols(), size = n * k;
  xs.resize(n * sl.slices, k);
  // The (m+1)-bit two's complement pattern of each code (the code itself when unsigned).
  thread_local std::vector<int32_t> pattern;
  pattern.resize(static_cast<size_t>(size));
  const int32_t m = sl.magnitude_bits, digit_max = static_cast<int32_t>(sl.digit_max());
  const int32_t pattern_mask = static_cast<int32_t>((1L << (m + 1)) - 1),
                low_mask = static_cast<int32_t>((1L << m) - 1);
  const S* in = xq.data();
  for (Eigen::Index i = 0; i < size; ++i)
    pattern[i] = static_cast<int32_t>(std::floor(static_cast<double>(in[i]) / sl.step + 0.5)) & pattern_mask;
  const int magnitude_slices = sl.slices - (sl.sign_slice ? 1 : 0);
  const S unit = static_cast<S>(sl.x_max / static_cast<double>(digit_max)), full = static_cast<S>(sl.x_max);
  const int32_t* p = pattern.data();
  for (int s = 0; s < magnitude_slices; ++s) {
    S* out = xs.data() + s * size;
    const int shift = s * sl.dac_bits;
    for (Eigen::Index i = 0; i < size; ++i) out[i] = static_cast<S>(((p[i] & low_mask) >> shift) & digit_max) * unit;
  }
  if (sl.sign_slice) {
    S* out = xs.data() + (sl.slices - 1) * size;
    for (Eigen::Index i = 0; i < size; ++i) out[i] = static_cast<S>((p[i] >> m) & 1) * full;
  }
}

Eigen::MatrixXd AnalogLayer::currents_of(const Crossbar& x, const Eigen::MatrixXd& xq) const {
  Mat<double> cur;
  analog_of<double>(x, xq, cur);
  return cur;
}

Eigen::MatrixXd AnalogLayer::raw_partial_of(const Crossbar& x, const Eigen::MatrixXd& iq,
                                            const Eigen::MatrixXd& xq) const {
  Mat<double> y = Mat<double>::Zero(iq.rows() / slicing_.slices, x.blk.cols);
  recover_of<double>(x, iq, xq, y, 0, false);
  return y;
}

template <typename S, typename XQ>
static Eigen::Matrix<S, Eigen::Dynamic, 1> input_sums(const XQ& xq, int row0, int rows) {
  return xq.middleCols(row0, rows).rowwise().sum().template cast<S>();
}

/// Bit k set when in[k] != 0, for w <= 64 values.
template <typename S>
static inline uint64_t nonzero_mask(const S* in, int w) {
  uint64_t mask = 0;
#if defined(__AVX512F__)
  if constexpr (std::is_same_v<S, float>) {
    for (int k = 0; k < w; k += 16) {
      const __mmask16 live = w - k >= 16 ? __mmask16(0xFFFF) : __mmask16((1u << (w - k)) - 1);
      const __m512 v = _mm512_maskz_loadu_ps(live, in + k);
      mask |= static_cast<uint64_t>(_mm512_mask_cmpneq_ps_mask(live, v, _mm512_setzero_ps())) << k;
    }
    return mask;
  }
#endif
  for (int k = 0; k < w; ++k) mask |= static_cast<uint64_t>(in[k] != S(0)) << k;
  return mask;
}

/// currents = xq.middleCols(row0, g.rows()) * g for reads whose digits are mostly zero (bit
/// planes): every non-zero input adds its row of g, in row order. Reads go in tiles of
/// kTile rows accumulated by rows, then written into the column-major currents.
template <typename S>
static void accumulate_reads(const AnalogLayer::RowMat<S>& g, const AnalogLayer::RowMat<S>& xq, int row0,
                             AnalogLayer::Mat<S>& currents) {
  constexpr Eigen::Index kTile = 16;
  constexpr int kChunk = 64 / sizeof(S) * 4;  // four vector registers of 512 bits
  const Eigen::Index reads = xq.rows(), rows = g.rows(), cols = g.cols();
  currents.resize(reads, cols);
  thread_local std::vector<S> tile;
  thread_local std::vector<int> nonzero;
  tile.resize(static_cast<size_t>(kTile * cols));
  nonzero.resize(static_cast<size_t>(rows));
  for (Eigen::Index i0 = 0; i0 < reads; i0 += kTile) {
    const Eigen::Index n = std::min(kTile, reads - i0);
    std::fill(tile.begin(), tile.begin() + n * cols, S(0));  // the columns past the last chunk
    for (Eigen::Index t = 0; t < n; ++t) {
      const S* in = xq.row(i0 + t).data() + row0;
      int count = 0;
      for (Eigen::Index k0 = 0; k0 < rows; k0 += 64) {  // a bit mask per 64 inputs, then its set bits
        const int w = static_cast<int>(std::min<Eigen::Index>(64, rows - k0));
        uint64_t mask = nonzero_mask(in + k0, w);
        for (; mask; mask &= mask - 1) nonzero[count++] = static_cast<int>(k0) + __builtin_ctzll(mask);
      }
      S* a = tile.data() + t * cols;
      // Columns in chunks of kChunk, accumulated in registers.
      Eigen::Index c0 = 0;
      for (; c0 + kChunk <= cols; c0 += kChunk) {
        using Chunk = Eigen::Array<S, kChunk, 1>;
        Chunk sum = Chunk::Zero();
        for (int q = 0; q < count; ++q)
          sum += in[nonzero[q]] * Eigen::Map<const Chunk, Eigen::Unaligned>(g.row(nonzero[q]).data() + c0);
        Eigen::Map<Chunk, Eigen::Unaligned>(a + c0) = sum;
      }
      for (int q = 0; q < count; ++q) {
        const S v = in[nonzero[q]];
        const S* gr = g.row(nonzero[q]).data();
        for (Eigen::Index c = c0; c < cols; ++c) a[c] += v * gr[c];
      }
    }
    for (Eigen::Index c = 0; c < cols; ++c) {
      S* out = currents.col(c).data() + i0;
      for (Eigen::Index t = 0; t < n; ++t) out[t] = tile[t * cols + c];
    }
  }
}

template <typename S>
void AnalogLayer::dac_inplace(RowMat<S>& x) const {
  dac_values<S>(x.data(), x.size());
}

template <typename S>
void AnalogLayer::analog(int b, const RowMat<S>& xq, Mat<S>& currents) const {
  analog_of<S>(*xbars_.at(b), xq, currents);
}

template <typename S>
void AnalogLayer::analog_of(const Crossbar& x, const RowMat<S>& xq, Mat<S>& currents) const {
  if (cfg_.xbar.is_linear()) {
    // I = V * G_eff with V = alpha * X: alpha is folded into the stored matrix.
    if (slicing_.serial()) {
      if constexpr (std::is_same_v<S, float>)
        accumulate_reads<S>(x.geff_rows_f, xq, x.blk.row0, currents);
      else
        accumulate_reads<S>(x.geff_rows_d, xq, x.blk.row0, currents);
      return;
    }
    if constexpr (std::is_same_v<S, float>)
      currents.noalias() = xq.middleCols(x.blk.row0, x.blk.rows) * x.geff_f;
    else
      currents.noalias() = xq.middleCols(x.blk.row0, x.blk.rows) * x.geff_d;
    return;
  }
  const Eigen::MatrixXd v = volts(xq.middleCols(x.blk.row0, x.blk.rows).template cast<double>());
  currents = x.solver->column_currents(v).template cast<S>();
}

template <typename S>
void AnalogLayer::adc_inplace(int b, Mat<S>& currents, const RowMat<S>& xq) const {
  adc_of<S>(*xbars_.at(b), currents, xq);
}

template <typename S, typename XQ>
void AnalogLayer::adc_of(const Crossbar& x, Mat<S>& currents, const XQ& xq) const {
  if (cfg_.converters.adc_bits <= 0) return;
  using Col = Eigen::Array<S, Eigen::Dynamic, 1>;
  const Col sum_x = input_sums<S>(xq, x.blk.row0, x.blk.rows).array();
  Col offset(currents.rows());
  Eigen::ArrayXd v(currents.rows());
  const Eigen::Index ranges = x.adc_lo.cols(), per_range = currents.rows() / ranges;
  for (Eigen::Index c = 0; c < currents.cols(); ++c) {
    offset = static_cast<S>(x.adc_offset(c)) * sum_x;
    auto col = currents.col(c).array();
    v = (col - offset).template cast<double>();
    // FastQuantizer::apply on the offset-subtracted current, vectorised, over each read's range
    // (the code by multiplying with 1 / step).
    for (Eigen::Index g = 0; g < ranges; ++g) {
      const FastQuantizer q(Quantizer{cfg_.converters.adc_bits, x.adc_lo(c, g), x.adc_hi(c, g)});
      auto seg = v.segment(g * per_range, ranges == 1 ? v.size() : per_range);
      if (q.on) seg = ((seg.max(q.lo).min(q.hi) - q.lo) * (1.0 / q.step) + 0.5).floor() * q.step + q.lo;
    }
    col = v.template cast<S>() + offset;
  }
}
template void AnalogLayer::adc_of<double, Eigen::MatrixXd>(const Crossbar&, Mat<double>&, const Eigen::MatrixXd&) const;

template <typename S>
void AnalogLayer::recover_add(int b, const Mat<S>& iq, const RowMat<S>& xq, Mat<S>& y, bool calibrated) const {
  const Crossbar& x = *xbars_.at(b);
  recover_of<S>(x, iq, xq, y, x.blk.col0, calibrated);
}

template <typename S>
void AnalogLayer::recover_of(const Crossbar& x, const Mat<S>& iq, const RowMat<S>& xq, Mat<S>& y, int y_col0,
                             bool calibrated) const {
  const Eigen::Index n = y.rows();  // iq and xq: slices x n rows
  const int slices = slicing_.slices;
  const S gmin = static_cast<S>(cfg_.xbar.g_min_s);
  const S inv_alpha = static_cast<S>(1.0 / alpha_);
  Eigen::Matrix<S, Eigen::Dynamic, 1> sum_x;
  if (cfg_.mapping.analog_sum()) {  // I_sum / alpha = (g_min + beta s a_sum) * sum(X)
    const int c = x.pcols - 1;
    sum_x = iq.col(c) * static_cast<S>(1.0 / (alpha_ * (cfg_.xbar.g_min_s + x.beta(c) * x.s(c) * x.a_sum)));
  } else {
    sum_x = input_sums<S>(xq, x.blk.row0, x.blk.rows);
  }
  // Per physical column: sign / (beta s), so (I / alpha - g_min sum(X)) times it is the
  // column's signed share of its weight column's product (its slice's place included).
  Eigen::Matrix<S, Eigen::Dynamic, 1> k(x.pcols);
  for (int c = 0; c < x.pcols; ++c) k(c) = static_cast<S>(x.sign(c) / (x.beta(c) * x.s(c)));
  const S w_lo = static_cast<S>(x.w_lo);
  const int per = x.per_weight;
  Eigen::Matrix<S, Eigen::Dynamic, 1> acc(n), part(n);
  for (int j = 0; j < x.blk.cols; ++j) {
    const S gain = calibrated ? static_cast<S>(x.fit.gain(j)) : S(1);
    const S off = calibrated ? static_cast<S>(x.fit.offset(j)) : S(0);
    S* out = y.col(y_col0 + j).data();
    if (slices == 1 && per <= 2) {  // one read, one column or a pair: in one pass
      const S* i0 = iq.col(j * per).data();
      const S* sx = sum_x.data();
      const S k0 = k(j * per);
      if (per == 1) {
        for (Eigen::Index r = 0; r < n; ++r)
          out[r] += gain * ((i0[r] * inv_alpha - gmin * sx[r]) * k0 + w_lo * sx[r]) + off;
      } else {
        const S* i1 = iq.col(j * per + 1).data();
        const S k1 = -k(j * per + 1);
        for (Eigen::Index r = 0; r < n; ++r) {
          const S p = (i0[r] * inv_alpha - gmin * sx[r]) * k0 - (i1[r] * inv_alpha - gmin * sx[r]) * k1;
          out[r] += gain * (p + w_lo * sx[r]) + off;
        }
      }
      continue;
    }
    S* ac = acc.data();
    S* pa = slices == 1 ? ac : part.data();  // one read: its product is the output
    for (int s = 0; s < slices; ++s) {
      const S* sx = sum_x.data() + s * n;
      // Shift-and-add of the weight's columns for read s.
      for (int q = 0; q < per; ++q) {
        const int c = j * per + q;
        const S kc = k(c);
        const S* ic = iq.col(c).data() + s * n;
        if (q == 0)
          for (Eigen::Index r = 0; r < n; ++r) pa[r] = (ic[r] * inv_alpha - gmin * sx[r]) * kc;
        else
          for (Eigen::Index r = 0; r < n; ++r) pa[r] += (ic[r] * inv_alpha - gmin * sx[r]) * kc;
      }
      for (Eigen::Index r = 0; r < n; ++r) pa[r] += w_lo * sx[r];
      // Shift-and-add of the input slices.
      if (slices > 1) {
        const S ws = static_cast<S>(slicing_.weight[s]);
        if (s == 0)
          for (Eigen::Index r = 0; r < n; ++r) ac[r] = ws * pa[r];
        else
          for (Eigen::Index r = 0; r < n; ++r) ac[r] += ws * pa[r];
      }
    }
    for (Eigen::Index r = 0; r < n; ++r) out[r] += gain * ac[r] + off;
  }
}

template <typename S>
void AnalogLayer::forward(const RowMat<S>& x, Mat<S>& y, bool quantized) const {
  if (x.cols() != w_.rows()) {
    std::ostringstream os;
    os << "analog layer: input vectors have " << x.cols() << " values, the layer expects " << w_.rows();
    throw InputError(os.str());
  }
  if (xbars_.empty()) throw InputError("analog layer used before program()");
  RowMat<S> xq_buf, xs_buf;
  const RowMat<S>* xq = &x;
  if (dac_q_.enabled() && !quantized) {
    xq_buf = x;
    dac_inplace<S>(xq_buf);
    xq = &xq_buf;
  }
  if (slicing_.serial()) {
    slice_inputs<S>(*xq, xs_buf);
    xq = &xs_buf;
  }
  y.setZero(x.rows(), w_.cols());
  Mat<S> cur;
  for (int b = 0; b < crossbars(); ++b) {
    try {
      analog<S>(b, *xq, cur);
      adc_inplace<S>(b, cur, *xq);
      recover_add<S>(b, cur, *xq, y);
    } catch (const std::exception&) {
      rethrow_with_context(crossbar_name(blocks_[b]));
    }
  }
}

Eigen::MatrixXd AnalogLayer::forward(const Eigen::MatrixXd& x) const {
  const RowMat<double> xr = x;
  Mat<double> y;
  forward<double>(xr, y);
  return y;
}

Eigen::MatrixXd AnalogLayer::partial(int b, const Eigen::MatrixXd& x) const {
  RowMat<double> xq = x;
  dac_inplace<double>(xq);
  if (slicing_.serial()) xq = sliced(xq);
  Mat<double> cur;
  analog<double>(b, xq, cur);
  adc_inplace<double>(b, cur, xq);
  Mat<double> y = Mat<double>::Zero(x.rows(), blocks_.at(b).cols);
  recover_of<double>(*xbars_.at(b), cur, xq, y, 0, true);
  return y;
}

#define XBARSIM_INSTANTIATE(S)                                                     \
  template void AnalogLayer::forward<S>(const RowMat<S>&, Mat<S>&, bool) const;    \
  template void AnalogLayer::dac_values<S>(S*, Eigen::Index) const;                \
  template void AnalogLayer::dac_inplace<S>(RowMat<S>&) const;                     \
  template void AnalogLayer::slice_inputs<S>(const RowMat<S>&, RowMat<S>&) const;  \
  template void AnalogLayer::analog<S>(int, const RowMat<S>&, Mat<S>&) const;      \
  template void AnalogLayer::adc_inplace<S>(int, Mat<S>&, const RowMat<S>&) const; \
  template void AnalogLayer::recover_add<S>(int, const Mat<S>&, const RowMat<S>&, Mat<S>&, bool) const;
XBARSIM_INSTANTIATE(float)
XBARSIM_INSTANTIATE(double)
#undef XBARSIM_INSTANTIATE

}  // namespace xbarsim
