#include "sw/analog/analog_layer.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>
#include <sstream>
#include <type_traits>

#include "sw/analog/error_metrics.h"
#include "sw/analog/synthetic.h"
#include "sw/mitigation/conversion.h"

namespace xbarsim {

void AnalogConfig::set_method(const std::string& name, const std::string& key) {
  static const char* kMethods[] = {"none", "calibration", "conversion", "conversion+calibration",
                                   "matrix-conversion", "matrix-conversion+calibration"};
  bool ok = false;
  for (const char* m : kMethods) ok = ok || name == m;
  if (!ok) {
    std::string list;
    for (const char* m : kMethods) list += (list.empty() ? "" : ", ") + std::string(m);
    throw InputError("configuration key '" + key + "': '" + name + "' is not one of: " + list);
  }
  method = name;
  calibrate = name.find("calibration") != std::string::npos;
  conversion = name.rfind("matrix-conversion", 0) == 0 ? ConversionKind::Matrix
               : name.rfind("conversion", 0) == 0      ? ConversionKind::Signal
                                                        : ConversionKind::None;
}

AnalogConfig parse_analog_config(const ConfigTree& cfg, const std::string& method_key) {
  AnalogConfig c;
  c.xbar = parse_crossbar_params(cfg);
  c.solver = parse_solver_options(cfg);
  c.max_rows = require_size_or_unbounded(cfg, "mapping.max_rows");
  c.max_cols = require_size_or_unbounded(cfg, "mapping.max_cols");
  c.differential = require_one_of(cfg, "mapping.negative", {"shift", "differential"}) == "differential";
  c.analog_sum = require_one_of(cfg, "mapping.sum_x", {"digital", "analog"}) == "analog";
  c.g_headroom = require_nonnegative(cfg, "mapping.g_headroom");
  if (c.g_headroom >= 1 || c.xbar.g_max_s * (1 - c.g_headroom) <= c.xbar.g_min_s)
    throw InputError("configuration key 'mapping.g_headroom' leaves no conductance range (needs g_max (1 - h) > g_min)");
  c.set_method(cfg.get_string(method_key), method_key);
  c.conversion_signal = require_one_of(cfg, "conversion.signal", {"constant", "max_input", "mean_input"});
  if (cfg.get_string("conversion.amplitude") == "optimize") {
    c.optimize_amplitude = true;
  } else if (cfg.get_string("conversion.amplitude") == "paper") {
    c.paper_amplitudes = true;
  } else {
    c.conversion_amplitude = require_positive(cfg, "conversion.amplitude");
    if (c.conversion_amplitude > 1)
      throw InputError("configuration key 'conversion.amplitude' is a fraction of crossbar.v_in_max (0 < a <= 1)");
  }
  c.column_scaling = cfg.get_bool("conversion.column_scaling");
  c.conversion_max_iterations = cfg.get_int32("conversion.max_iterations");
  c.conversion_tolerance = require_positive(cfg, "conversion.tolerance");
  if (c.conversion_max_iterations < 1) throw InputError("configuration key 'conversion.max_iterations' must be >= 1");
  c.calibration_samples = cfg.get_int32("calibration.samples");
  if (c.calibration_samples < 2) throw InputError("configuration key 'calibration.samples' must be >= 2");
  c.calibration_signal = require_one_of(cfg, "calibration.signal", {"random", "random_decreasing", "shuffled"});
  c.calibration_seed = static_cast<uint64_t>(cfg.get_int("calibration.seed"));
  c.dac_bits = parse_bits(cfg, "converters.dac_bits");
  c.adc_bits = parse_bits(cfg, "converters.adc_bits");
  c.adc_margin = require_nonnegative(cfg, "converters.adc_margin");
  c.adc_offset_subtraction = cfg.get_bool("converters.adc_offset_subtraction");
  c.sigma_s = require_nonnegative(cfg, "noise.sigma_us") * 1e-6;
  c.noise_seed = static_cast<uint64_t>(cfg.get_int("noise.seed"));
  return c;
}

struct AnalogLayer::Crossbar {
  Block blk;
  int pcols = 0;
  double s = 1;      ///< S per weight unit
  double w_lo = 0;   ///< shift: A = W - w_lo
  double a_sum = 0;  ///< analog sum column: constant A
  Eigen::MatrixXd a;  ///< non-negative mapped matrix, rows x pcols
  Eigen::VectorXd beta;
  Eigen::MatrixXd g_prog;
  std::unique_ptr<CrossbarSolver> solver;
  Eigen::MatrixXd geff_d;  ///< alpha * G_eff (A per input unit), linear devices
  Eigen::MatrixXf geff_f;  ///< the same in float for network inference
  Eigen::VectorXd adc_lo, adc_hi;
  Eigen::VectorXd adc_offset;  ///< per physical column: offset current per unit sum(X) removed before the ADC
  ColumnFit fit;
};

AnalogLayer::AnalogLayer(const AnalogConfig& cfg, const Eigen::MatrixXd& w, double x_max, bool signed_inputs,
                         uint64_t salt)
    : cfg_(cfg), w_(w), x_max_(x_max), signed_(signed_inputs), salt_(salt) {
  if (w.rows() < 1 || w.cols() < 1) throw InputError("analog layer: empty weight matrix");
  if (!(x_max > 0) || !std::isfinite(x_max)) throw InputError("analog layer: input full scale must be > 0");
  alpha_ = cfg.xbar.v_in_max_v / x_max;
  // Signed inputs: sign-magnitude, so that 0 is exactly a DAC level.
  dac_q_ = Quantizer{signed_inputs ? std::max(cfg.dac_bits - 1, cfg.dac_bits > 0 ? 1 : 0) : cfg.dac_bits, 0.0, x_max};
  blocks_ = partition(static_cast<int>(w.rows()), static_cast<int>(w.cols()), cfg.max_rows, cfg.max_cols);
}

AnalogLayer::~AnalogLayer() = default;
AnalogLayer::AnalogLayer(AnalogLayer&&) noexcept = default;

const Block& AnalogLayer::block(int b) const { return blocks_.at(b); }

Eigen::MatrixXd AnalogLayer::calibration_vectors(const Eigen::MatrixXd& calib) const {
  const int k = static_cast<int>(w_.rows()), count = cfg_.calibration_samples;
  std::mt19937_64 rng(cfg_.calibration_seed * 0x9E3779B97F4A7C15ull + salt_);
  if (cfg_.calibration_signal == "shuffled" && calib.rows() > 0) {
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
  if (cfg_.calibration_signal == "random_decreasing")
    for (int a = 0; a < count; ++a) out.row(a) /= (a + 1);
  return out;
}

void AnalogLayer::program(const Eigen::MatrixXd& calib, const SolverOptions& solver) {
  cfg_.solver = solver;
  program(calib);
}

void AnalogLayer::program(const Eigen::MatrixXd& calib_in) {
  if (calib_in.size() > 0 && calib_in.cols() != w_.rows())
    throw InputError("analog layer: calibration vectors have the wrong length");
  const CrossbarParams& p = cfg_.xbar;
  const Eigen::MatrixXd cal = dac(calibration_vectors(calib_in));
  // Vectors for ADC range estimation: the real inputs (at most 2048) and the calibration set.
  Eigen::MatrixXd range_x;
  {
    // Nonlinear devices need a Newton solve per vector: estimate ranges on fewer vectors.
    const Eigen::Index cap = cfg_.xbar.is_linear() ? 2048 : 128;
    const Eigen::Index take = std::min<Eigen::Index>(calib_in.rows(), cap);
    range_x.resize(take + cal.rows(), w_.rows());
    std::mt19937_64 rng(salt_ + 17);
    for (Eigen::Index a = 0; a < take; ++a)
      range_x.row(a) = calib_in.row(calib_in.rows() <= cap ? a : static_cast<Eigen::Index>(rng() % calib_in.rows()));
    range_x.bottomRows(cal.rows()) = cal;
    range_x = dac(range_x);
  }
  xbars_.clear();
  reports_.clear();
  for (size_t b = 0; b < blocks_.size(); ++b) {
    auto xb = std::make_unique<Crossbar>();
    const Block& blk = blocks_[b];
    xb->blk = blk;
    const Eigen::MatrixXd wb = w_.block(blk.row0, blk.col0, blk.rows, blk.cols);
    // Conductance span for weights; the headroom above it is left for conversion.
    const double g_span = p.g_max_s * (1 - cfg_.g_headroom) - p.g_min_s;
    // Weights -> non-negative matrix A -> G = g_min + s * A.
    if (cfg_.differential) {
      const double wmax = std::max(wb.cwiseAbs().maxCoeff(), 1e-300);
      xb->s = g_span / wmax;
      xb->pcols = 2 * blk.cols;
      xb->a.resize(blk.rows, xb->pcols);
      for (int j = 0; j < blk.cols; ++j) {
        xb->a.col(2 * j) = wb.col(j).cwiseMax(0.0);
        xb->a.col(2 * j + 1) = (-wb.col(j)).cwiseMax(0.0);
      }
    } else {
      xb->w_lo = std::min(wb.minCoeff(), 0.0);
      double span = wb.maxCoeff() - xb->w_lo;
      if (!(span > 0)) span = 1.0;
      xb->s = g_span / span;
      xb->pcols = blk.cols;
      xb->a = wb.array() - xb->w_lo;
    }
    if (cfg_.analog_sum) {
      xb->a_sum = 0.5 * g_span / xb->s;  // mid-range conductance
      xb->a.conservativeResize(Eigen::NoChange, xb->pcols + 1);
      xb->a.col(xb->pcols).setConstant(xb->a_sum);
      ++xb->pcols;
    }
    const Eigen::MatrixXd g_target = (p.g_min_s + xb->s * xb->a.array()).matrix();
    xb->beta = Eigen::VectorXd::Ones(xb->pcols);
    CrossbarReport rep;
    rep.block = blk;
    rep.physical_cols = xb->pcols;
    xb->solver = make_crossbar_solver(p, cfg_.solver);

    const Eigen::MatrixXd cal_b = cal.middleCols(blk.row0, blk.rows);
    const Eigen::MatrixXd ideal_partial = cal_b * wb;

    auto signal_for = [&](double amplitude) -> Eigen::VectorXd {
      if (cfg_.conversion_signal == "max_input" && cal_b.rows() > 0) {
        Eigen::MatrixXd src = calib_in.size() ? dac(calib_in).middleCols(blk.row0, blk.rows) : cal_b;
        return alpha_ * src.colwise().maxCoeff().transpose();
      }
      if (cfg_.conversion_signal == "mean_input" && cal_b.rows() > 0) {
        Eigen::MatrixXd src = calib_in.size() ? dac(calib_in).middleCols(blk.row0, blk.rows) : cal_b;
        return alpha_ * src.colwise().mean().transpose();
      }
      return Eigen::VectorXd::Constant(blk.rows, amplitude * p.v_in_max_v);
    };

    auto install = [&](const Eigen::MatrixXd& gp) {
      xb->g_prog = gp;
      xb->solver->program(gp);
      if (p.is_linear()) {
        xb->geff_d = alpha_ * xb->solver->effective_matrix();
        xb->geff_f = xb->geff_d.cast<float>();
      }
    };
    // Error of the un-calibrated, un-quantized partial output on the calibration set.
    auto cal_error = [&]() {
      return relative_error(raw_partial_of(*xb, currents_of(*xb, cal), cal), ideal_partial).mean_relative_error;
    };

    if (cfg_.conversion == ConversionKind::None) {
      install(g_target);
    } else if (cfg_.conversion == ConversionKind::Signal) {
      // The paper's per-size amplitudes (its Tables: 0.1 up to 144 rows, 0.05 up to 288,
      // 0.01 up to 576, 0.001 beyond).
      const double paper_amp = blk.rows <= 150 ? 0.1 : blk.rows <= 300 ? 0.05 : blk.rows <= 600 ? 0.01 : 0.001;
      std::vector<double> amps = {cfg_.paper_amplitudes ? paper_amp : cfg_.conversion_amplitude};
      if (cfg_.optimize_amplitude && cfg_.conversion_signal == "constant")
        amps = {1.0, 0.5, 0.2, 0.1, 0.05, 0.02, 0.01, 0.005, 0.002, 0.001};
      double best = std::numeric_limits<double>::infinity();
      Eigen::MatrixXd best_g;
      for (double a : amps) {
        const ConversionResult r = convert_signal(p, g_target, signal_for(a));
        if (amps.size() > 1) {
          install(r.g_prime);
          const double e = cal_error();
          if (!(e < best)) continue;
          best = e;
        }
        best_g = r.g_prime;
        rep.out_of_range_cells = r.out_of_range();
        rep.conversion_amplitude = a;
      }
      install(best_g);
    } else {
      MatrixConversionOptions mo;
      mo.column_scaling = cfg_.column_scaling;
      mo.max_iterations = cfg_.conversion_max_iterations;
      mo.tolerance = cfg_.conversion_tolerance;
      const Eigen::VectorXd v_op =
          cal_b.rows() ? Eigen::VectorXd(alpha_ * cal_b.cwiseAbs().colwise().mean().transpose())
                       : Eigen::VectorXd::Constant(blk.rows, 0.1 * p.v_in_max_v);
      const ConversionResult r = convert_matrix(p, cfg_.solver, g_target, v_op, mo);
      xb->beta = r.column_gain;
      rep.out_of_range_cells = r.out_of_range();
      rep.min_column_gain = r.column_gain.minCoeff();
      rep.conversion_residual = r.residual;
      install(r.g_prime);
    }
    if (cfg_.sigma_s > 0) {
      std::mt19937_64 rng(cfg_.noise_seed * 0x9E3779B97F4A7C15ull + salt_ * 1000003ull + b);
      std::normal_distribution<double> nd(0.0, cfg_.sigma_s);
      Eigen::MatrixXd gp = xb->g_prog;
      for (Eigen::Index k = 0; k < gp.size(); ++k)
        gp.data()[k] = std::min(std::max(gp.data()[k] + nd(rng), p.g_min_s), p.g_max_s);
      install(gp);
    }
    xbars_.push_back(std::move(xb));
    const int idx = static_cast<int>(xbars_.size()) - 1;
    Crossbar& x = *xbars_.back();
    // Offset subtraction before the ADC: the shift current (g_min - beta s w_lo) sum(X)
    // of each column, mirrored from the sum(X) reference, so the ADC range spans the
    // weight part only.
    x.adc_offset = Eigen::VectorXd::Zero(x.pcols);
    if (cfg_.adc_offset_subtraction)
      for (int c = 0; c < x.pcols; ++c) {
        if (cfg_.analog_sum && c == x.pcols - 1) continue;  // the reference column itself
        x.adc_offset(c) = alpha_ * (p.g_min_s - (cfg_.differential ? 0.0 : x.beta(c) * x.s * x.w_lo));
      }
    // ADC ranges from the (offset-subtracted) currents of the range-estimation vectors.
    x.adc_lo = Eigen::VectorXd::Zero(x.pcols);
    x.adc_hi = Eigen::VectorXd::Zero(x.pcols);
    if (cfg_.adc_bits > 0) {
      Eigen::MatrixXd cur = currents_of(x, range_x);
      const Eigen::VectorXd sx = range_x.middleCols(blk.row0, blk.rows).rowwise().sum();
      for (int c = 0; c < x.pcols; ++c) {
        cur.col(c) -= x.adc_offset(c) * sx;
        const double lo = cur.col(c).minCoeff(), hi = cur.col(c).maxCoeff();
        const double pad = std::max(cfg_.adc_margin * (hi - lo), 1e-12 * std::max(std::abs(hi), 1e-12));
        x.adc_lo(c) = lo - pad;
        x.adc_hi(c) = hi + pad;
      }
    }
    x.fit = identity_fit(blk.cols);
    if (cfg_.calibrate) {
      Mat<double> cur = currents_of(x, cal);
      adc_inplace<double>(idx, cur, cal);
      x.fit = fit_columns(raw_partial_of(x, cur, cal), ideal_partial);
    }
    reports_.push_back(rep);
  }
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

Eigen::MatrixXd AnalogLayer::currents_of(const Crossbar& x, const Eigen::MatrixXd& xq) const {
  Mat<double> cur;
  analog_of<double>(x, xq, cur);
  return cur;
}

Eigen::MatrixXd AnalogLayer::raw_partial_of(const Crossbar& x, const Eigen::MatrixXd& iq,
                                            const Eigen::MatrixXd& xq) const {
  Mat<double> y = Mat<double>::Zero(iq.rows(), x.blk.cols);
  recover_of<double>(x, iq, xq, y, 0, false);
  return y;
}

template <typename S, typename XQ>
static Eigen::Matrix<S, Eigen::Dynamic, 1> input_sums(const XQ& xq, int row0, int rows) {
  return xq.middleCols(row0, rows).rowwise().sum().template cast<S>();
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
    if constexpr (std::is_same_v<S, float>)
      currents.noalias() = xq.middleCols(x.blk.row0, x.blk.rows) * x.geff_f;
    else
      currents.noalias() = xq.middleCols(x.blk.row0, x.blk.rows) * x.geff_d;
    return;
  }
  const Eigen::MatrixXd v = alpha_ * xq.middleCols(x.blk.row0, x.blk.rows).template cast<double>();
  currents = x.solver->column_currents(v).template cast<S>();
}

template <typename S>
void AnalogLayer::adc_inplace(int b, Mat<S>& currents, const RowMat<S>& xq) const {
  if (cfg_.adc_bits <= 0) return;
  const Crossbar& x = *xbars_.at(b);
  const Eigen::Matrix<S, Eigen::Dynamic, 1> sum_x = input_sums<S>(xq, x.blk.row0, x.blk.rows);
  for (Eigen::Index c = 0; c < currents.cols(); ++c) {
    const FastQuantizer q(Quantizer{cfg_.adc_bits, x.adc_lo(c), x.adc_hi(c)});
    const S k = static_cast<S>(x.adc_offset(c));
    S* col = currents.col(c).data();
    for (Eigen::Index a = 0; a < currents.rows(); ++a) {
      const S offset = k * sum_x(a);
      col[a] = static_cast<S>(q.apply(col[a] - offset)) + offset;
    }
  }
}

template <typename S>
void AnalogLayer::recover_add(int b, const Mat<S>& iq, const RowMat<S>& xq, Mat<S>& y, bool calibrated) const {
  const Crossbar& x = *xbars_.at(b);
  recover_of<S>(x, iq, xq, y, x.blk.col0, calibrated);
}

template <typename S>
void AnalogLayer::recover_of(const Crossbar& x, const Mat<S>& iq, const RowMat<S>& xq, Mat<S>& y, int y_col0,
                             bool calibrated) const {
  const Eigen::Index n = iq.rows();
  const S gmin = static_cast<S>(cfg_.xbar.g_min_s);
  const S inv_alpha = static_cast<S>(1.0 / alpha_);
  Eigen::Matrix<S, Eigen::Dynamic, 1> sum_x;
  if (cfg_.analog_sum) {  // I_sum / alpha = (g_min + beta s a_sum) * sum(X)
    const int c = x.pcols - 1;
    sum_x = iq.col(c) * static_cast<S>(1.0 / (alpha_ * (cfg_.xbar.g_min_s + x.beta(c) * x.s * x.a_sum)));
  } else {
    sum_x = input_sums<S>(xq, x.blk.row0, x.blk.rows);
  }
  const S* sx = sum_x.data();
  const S w_lo = static_cast<S>(x.w_lo);
  for (int j = 0; j < x.blk.cols; ++j) {
    const S gain = calibrated ? static_cast<S>(x.fit.gain(j)) : S(1);
    const S off = calibrated ? static_cast<S>(x.fit.offset(j)) : S(0);
    S* out = y.col(y_col0 + j).data();
    if (cfg_.differential) {
      const S kp = static_cast<S>(1.0 / (x.beta(2 * j) * x.s)), km = static_cast<S>(1.0 / (x.beta(2 * j + 1) * x.s));
      const S* ip = iq.col(2 * j).data();
      const S* im = iq.col(2 * j + 1).data();
      for (Eigen::Index r = 0; r < n; ++r) {
        const S p = (ip[r] * inv_alpha - gmin * sx[r]) * kp - (im[r] * inv_alpha - gmin * sx[r]) * km;
        out[r] += gain * p + off;
      }
    } else {
      const S k = static_cast<S>(1.0 / (x.beta(j) * x.s));
      const S* ic = iq.col(j).data();
      for (Eigen::Index r = 0; r < n; ++r) out[r] += gain * ((ic[r] * inv_alpha - gmin * sx[r]) * k + w_lo * sx[r]) + off;
    }
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
  RowMat<S> xq_buf;
  const RowMat<S>* xq = &x;
  if (dac_q_.enabled() && !quantized) {
    xq_buf = x;
    dac_inplace<S>(xq_buf);
    xq = &xq_buf;
  }
  y.setZero(x.rows(), w_.cols());
  Mat<S> cur;
  for (int b = 0; b < crossbars(); ++b) {
    analog<S>(b, *xq, cur);
    adc_inplace<S>(b, cur, *xq);
    recover_add<S>(b, cur, *xq, y);
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
  Mat<double> cur;
  analog<double>(b, xq, cur);
  adc_inplace<double>(b, cur, xq);
  Mat<double> y = Mat<double>::Zero(x.rows(), blocks_.at(b).cols);
  recover_of<double>(*xbars_.at(b), cur, xq, y, 0, true);
  return y;
}

#define XBARSIM_INSTANTIATE(S)                                                                                  \
  template void AnalogLayer::forward<S>(const RowMat<S>&, Mat<S>&, bool) const;                               \
  template void AnalogLayer::dac_values<S>(S*, Eigen::Index) const;                                           \
  template void AnalogLayer::dac_inplace<S>(RowMat<S>&) const;                                                \
  template void AnalogLayer::analog<S>(int, const RowMat<S>&, Mat<S>&) const;                                 \
  template void AnalogLayer::adc_inplace<S>(int, Mat<S>&, const RowMat<S>&) const;                            \
  template void AnalogLayer::recover_add<S>(int, const Mat<S>&, const RowMat<S>&, Mat<S>&, bool) const;
XBARSIM_INSTANTIATE(float)
XBARSIM_INSTANTIATE(double)
#undef XBARSIM_INSTANTIATE

}  // namespace xbarsim
