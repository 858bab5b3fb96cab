// Programming of an analog layer's crossbars, in named steps: conversion (the paper's signal
// conversion or matrix conversion), programming noise, ADC ranging and calibration.
#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <tuple>

#include "sw/common/cancel.h"

#include "sw/analog/analog_layer_impl.h"
#include "sw/analog/error_metrics.h"
#include "sw/circuit/device_models.h"
#include "sw/common/seed.h"
#include "sw/mitigation/conversion.h"

namespace xbarsim {

namespace {

/// The conversion controller's parameters.
struct ConversionController {
  /// The paper's constant-signal amplitudes (fraction of v_in_max) by crossbar rows: 0.1 up
  /// to 150 rows, 0.05 up to 300, 0.01 up to 600, 0.001 beyond (its tables).
  static double paper_amplitude(int rows) {
    return rows <= 150 ? 0.1 : rows <= 300 ? 0.05 : rows <= 600 ? 0.01 : 0.001;
  }
  /// Amplitudes tried by conversion.amplitude = optimize (fraction of v_in_max).
  static constexpr double kOptimizeAmplitudes[] = {1.0, 0.5, 0.2, 0.1, 0.05, 0.02, 0.01, 0.005, 0.002, 0.001};
  /// Matrix conversion's linearisation point without calibration inputs (fraction of v_in_max).
  static constexpr double kDefaultOperatingPoint = 0.1;
  /// Smallest ADC range padding relative to the range end, so a constant column keeps a step.
  static constexpr double kMinAdcPadRelative = 1e-12;
};

}  // namespace

void AnalogLayer::install(Crossbar& x, const Eigen::MatrixXd& g) const {
  x.g_prog = g;
  x.solver->program(g);
  if (cfg_.xbar.is_linear()) {
    x.geff_d = alpha_ * x.solver->effective_matrix();
    x.geff_f = x.geff_d.cast<float>();
    if (slicing_.serial()) {
      x.geff_rows_d = x.geff_d;
      x.geff_rows_f = x.geff_f;
    }
    if (cfg_.device.has_read_noise() && x.noise_points.rows()) fit_read_noise(x);
  }
  x.recover_k = x.sign.array() / (x.beta.array() * x.s.array());
}

void AnalogLayer::convert_signal_amplitudes(Crossbar& x, const ProgrammingInputs& in, CrossbarReport& rep) const {
  const CrossbarParams& p = cfg_.xbar;
  const ConversionSpec& cs = cfg_.conversion;
  // The conversion signal in input units (the applied voltages are the DAC's for it, the
  // targets alpha x * G).
  auto signal_for = [&](double amplitude) -> Eigen::VectorXd {
    if (cs.signal != ConversionSignal::Constant && in.cal_b.rows() > 0) {
      const Eigen::MatrixXd& src = in.calib_b.size() ? in.calib_b : in.cal_b;
      if (cs.signal == ConversionSignal::MaxInput) return src.colwise().maxCoeff().transpose();
      return src.colwise().mean().transpose();
    }
    return Eigen::VectorXd::Constant(x.blk.rows, amplitude * x_max_);
  };
  std::vector<double> amps = {
      cs.amplitude_mode == AmplitudeMode::Paper ? ConversionController::paper_amplitude(x.blk.rows) : cs.amplitude};
  if (cs.amplitude_mode == AmplitudeMode::Optimize && cs.signal == ConversionSignal::Constant)
    amps.assign(std::begin(ConversionController::kOptimizeAmplitudes),
                std::end(ConversionController::kOptimizeAmplitudes));
  double best = std::numeric_limits<double>::infinity();
  Eigen::MatrixXd best_g;
  for (double a : amps) {
    const Eigen::VectorXd xs = signal_for(a);
    const ConversionResult r = convert_signal(p, x.g_target, volts(xs), alpha_ * xs);
    if (amps.size() > 1) {  // keep the amplitude with the lowest un-calibrated error
      install(x, r.g_prime);
      const double e = relative_error(partial_of(x, in.cal_b, /*adc=*/false, /*calibrated=*/false, kConversionReads),
                                      in.ideal_partial)
                           .mean_relative_error;
      if (!(e < best)) continue;
      best = e;
    }
    best_g = r.g_prime;
    rep.out_of_range_cells = r.out_of_range();
    rep.conversion_amplitude = a;
  }
  install(x, best_g);
}

void AnalogLayer::convert(Crossbar& x, const ProgrammingInputs& in, CrossbarReport& rep) const {
  switch (cfg_.mitigation.conversion()) {
    case ConversionKind::None:
      install(x, x.g_target);
      return;
    case ConversionKind::Signal:
      convert_signal_amplitudes(x, in, rep);
      return;
    case ConversionKind::Matrix: {
      MatrixConversionOptions mo;
      mo.column_scaling = cfg_.conversion.column_scaling;
      mo.max_iterations = cfg_.conversion.max_iterations;
      mo.tolerance = cfg_.conversion.tolerance;
      // The mean applied voltage of each row over the calibration reads.
      const Eigen::VectorXd v_op =
          in.cal_b.rows() ? Eigen::VectorXd(alpha_ * mean_read_values(x, in.cal_b))
                          : Eigen::VectorXd::Constant(
                                x.blk.rows, ConversionController::kDefaultOperatingPoint * cfg_.xbar.v_in_max_v);
      const ConversionResult r = convert_matrix(cfg_.xbar, cfg_.solver, x.g_target, v_op, mo);
      x.beta = r.column_gain;
      rep.out_of_range_cells = r.out_of_range();
      rep.min_column_gain = r.column_gain.minCoeff();
      rep.conversion_residual = r.residual;
      install(x, r.g_prime);
      return;
    }
  }
}

void AnalogLayer::write_cells(Crossbar& x, CrossbarReport& rep) const {
  const DeviceSpec& d = cfg_.device;
  if (!d.perturbs_programming() && !d.moves()) {  // ideal cells hold what conversion asked
    if (x.noise_points.rows()) fit_read_noise(x);
    return;
  }
  const Eigen::MatrixXd asked = x.g_prog;
  Eigen::MatrixXd g = asked;
  device_.program(g, x.faults, x.stream);
  if (d.spare_columns > 0 && d.has_faults()) {
    // Spare columns replace the columns whose stuck cells err most (sum of |G_stuck - G_asked|):
    // a spare is a fresh column with its own cells (faults and programming error), kept when it
    // errs less.
    const auto fault_error = [](const auto& stuck, const auto& written, const auto& wanted) {
      return (stuck != 0).template cast<double>().matrix().dot((written - wanted).cwiseAbs());
    };
    Eigen::VectorXd err(x.pcols);
    for (int c = 0; c < x.pcols; ++c) err(c) = fault_error(x.faults.col(c), g.col(c), asked.col(c));
    std::vector<int> order(static_cast<size_t>(x.pcols));
    for (int c = 0; c < x.pcols; ++c) order[static_cast<size_t>(c)] = c;
    std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return err(a) > err(b); });
    for (int k = 0; k < std::min(d.spare_columns, x.pcols); ++k) {
      const int c = order[static_cast<size_t>(k)];
      if (!(err(c) > 0)) break;
      Eigen::MatrixXd col = asked.col(c);
      FaultMap f;
      device_.program(col, f, derive_seed(x.stream, {0x5BA5E, static_cast<uint64_t>(k)}));
      const double e = fault_error(f.col(0), col.col(0), asked.col(c));
      if (e < err(c)) {
        g.col(c) = col;
        x.faults.col(c) = f.col(0);
        ++rep.spare_columns_used;
      }
    }
  }
  rep.stuck_cells = static_cast<int>((x.faults != 0).count());
  if (d.moves()) {
    x.g_asked = asked;
    x.g_written = g;
    install(x, device_.at_time(asked, g, x.faults, 0.0, x.stream));
  } else {
    install(x, g);
  }
}

Eigen::MatrixXd AnalogLayer::read_noise_points(const ProgrammingInputs& in) const {
  Eigen::MatrixXd reads;
  if (slicing_.serial()) {
    Codes codes;
    slice_inputs<double>(in.range_b, codes);
    RowMat<double> v;
    read_values<double>(codes, 0, in.range_b.rows(), 0, static_cast<int>(in.range_b.cols()), v);
    reads = v;
  } else {
    reads = in.range_b;
  }
  std::vector<Eigen::Index> live;
  for (Eigen::Index r = 0; r < reads.rows(); ++r)
    if ((reads.row(r).array() != 0).any()) live.push_back(r);
  const size_t k = std::min<size_t>(live.size(), kNoisePoints);
  Eigen::MatrixXd out(static_cast<Eigen::Index>(k), reads.cols());
  for (size_t a = 0; a < k; ++a) out.row(static_cast<Eigen::Index>(a)) = reads.row(live[a * live.size() / k]);
  return out;
}

void AnalogLayer::fit_read_noise(Crossbar& x) const {
  const CrossbarParams& p = cfg_.xbar;
  const int m = x.blk.rows, n = x.pcols;
  const Eigen::MatrixXd& g = x.g_prog;
  // The cells as the network sees them: the memristor in series with a linear access transistor.
  const bool series = p.transistor.model == TransistorModel::Linear;
  const Eigen::MatrixXd gc = series ? Eigen::MatrixXd(g.unaryExpr([&](double v) { return linear_cell_conductance(p, v); }))
                                    : g;
  SolverOptions one = cfg_.solver;
  one.threads = 1;
  // T_ij, the transfer of a current across cell (i, j) to column j's output current. By
  // reciprocity it is the voltage across the cell when column j's output drives 1 V through
  // r_out with every row grounded through r_in: the same crossbar transposed and flipped (its
  // rows are the columns, driven from their output end; its columns the rows, ending in r_in).
  CrossbarParams q = p;
  q.r_in_ohm = p.r_out_ohm;
  q.r_out_ohm = p.r_in_ohm;
  q.transistor.model = TransistorModel::None;
  q.memristor.model = MemristorModel::Linear;
  Eigen::MatrixXd gn(n, m);
  for (int r = 0; r < n; ++r)
    for (int c = 0; c < m; ++c) gn(r, c) = gc(m - 1 - c, n - 1 - r);
  const std::unique_ptr<CrossbarSolver> adjoint = make_crossbar_solver(q, one);
  adjoint->program(gn);
  Eigen::MatrixXd t(m, n);
  for (int j = 0; j < n; ++j) {
    Eigen::VectorXd e = Eigen::VectorXd::Zero(n);
    e(n - 1 - j) = 1.0;
    const CircuitSolution s = adjoint->solve(e);
    for (int i = 0; i < m; ++i) t(i, j) = s.v_top(n - 1 - j, m - 1 - i) - s.v_bottom(n - 1 - j, m - 1 - i);
  }
  if (series) t = t.cwiseProduct(gc.cwiseQuotient(g));  // across the memristor alone
  // The exact sensitivities s_ij = dV_ij T_ij at the fitting reads, and per cell the least-squares
  // fit s_ij = V_i A_ij - I_j B_ij (the row's drive, the column's rise with its current).
  Eigen::ArrayXXd s11 = Eigen::ArrayXXd::Zero(m, n), s12 = s11, s22 = s11, r1 = s11, r2 = s11;
  for (Eigen::Index k = 0; k < x.noise_points.rows(); ++k) {
    const Eigen::VectorXd v = alpha_ * x.noise_points.row(k).transpose();
    const CircuitSolution op = x.solver->solve(v);
    const Eigen::ArrayXXd s = (op.v_top - op.v_mid).array() * t.array();
    const Eigen::ArrayXXd a1 = v.array().replicate(1, n);
    const Eigen::ArrayXXd a2 = -op.column_current.transpose().array().replicate(m, 1);
    s11 += a1 * a1;
    s12 += a1 * a2;
    s22 += a2 * a2;
    r1 += a1 * s;
    r2 += a2 * s;
  }
  Eigen::ArrayXXd a(m, n), b(m, n);
  for (Eigen::Index k = 0; k < a.size(); ++k) {
    const double det = s11(k) * s22(k) - s12(k) * s12(k);
    if (det > 1e-9 * s11(k) * s22(k) && det > 0) {
      a(k) = (r1(k) * s22(k) - r2(k) * s12(k)) / det;
      b(k) = (s11(k) * r2(k) - s12(k) * r1(k)) / det;
    } else {  // one kind of read (or a row never driven): the row term alone, or the transfer
      a(k) = s11(k) > 0 ? r1(k) / s11(k) : t(k);
      b(k) = 0;
    }
  }
  const Eigen::ArrayXXd var = device_.read_sigma(g).array().square();
  x.noise_p1 = (alpha_ * alpha_ * var * a * a).cast<float>().matrix();
  x.noise_p2 = (alpha_ * var * a * b).cast<float>().matrix();
  x.noise_p3 = (var * b * b).colwise().sum().cast<float>().matrix();
}

void AnalogLayer::settle(Crossbar& x, double t) const {
  if (!cfg_.device.moves()) return;
  install(x, device_.at_time(x.g_asked, x.g_written, x.faults, t, x.stream));
}

Eigen::VectorXd AnalogLayer::reference_sums(const Crossbar& x, const ProgrammingInputs& in) const {
  // The calibration vectors read through the array (with their read noise): each column's summed
  // current, measured by the readout before its ADC (the gain it sets applies there).
  if (slicing_.serial()) {
    Codes codes;
    slice_inputs<double>(in.cal_b, codes);
    ReadCurrents<double> cur;
    analog_of<double>(x, codes, 0, in.cal_b.rows(), cur, kReferenceReads);
    return cur.i.matrix().colwise().sum().transpose();
  }
  return currents_of(x, in.cal_b, kReferenceReads).colwise().sum().transpose();
}

void AnalogLayer::move_to_time(const LayerInputs& layer_in) {
  const DeviceSpec& d = cfg_.device;
  const double t = d.time_s;
  compensation_reads_ = 0;
  const bool references = d.compensation == Compensation::Global || d.compensation == Compensation::Column;
  for (size_t b = 0; b < xbars_.size(); ++b) {
    Crossbar& x = *xbars_[b];
    x.comp.resize(0);
    x.in0 = 0;
    const ProgrammingInputs in = crossbar_inputs(layer_in, blocks_[b]);
    // The reference at t = 0 (the state the readout was set in), then the state at t (each
    // installed only when the crossbar is not already in it: a new G_eff is a solve per column).
    double state = time_s_;
    if (references && state != 0) {
      settle(x, 0);
      state = 0;
    }
    x.ref0 = references ? reference_sums(x, in) : Eigen::VectorXd();
    if (state != t) settle(x, t);
    if (d.compensation == Compensation::Recalibrate) compensation_reads_ += in.cal_b.rows() + in.range_b.rows();
    if (references) {
      const Eigen::VectorXd now = reference_sums(x, in);
      compensation_reads_ += in.cal_b.rows();
      x.comp = now;  // the column sums at t, turned into gains below
    }
    x.in0 = blocks_[b].row0;
  }
  time_s_ = t;
  if (d.compensation == Compensation::Recalibrate) {
    // The readout again at t: every crossbar reads its own rows (in0 = 0), then the bias.
    read_out_all(xbars_, layer_in);
  }
  if (!references) return;
  // global: one gain for the layer, sum of |references at 0| / sum at t; column: per column.
  double r0 = 0, rt = 0;
  for (const auto& x : xbars_) {
    r0 += x->ref0.cwiseAbs().sum();
    rt += x->comp.cwiseAbs().sum();
  }
  for (auto& xp : xbars_) {
    Crossbar& x = *xp;
    Eigen::VectorXd gain(x.pcols);
    for (int c = 0; c < x.pcols; ++c) {
      const double num = d.compensation == Compensation::Global ? r0 : std::abs(x.ref0(c));
      const double den = d.compensation == Compensation::Global ? rt : std::abs(x.comp(c));
      gain(c) = den > 0 && num > 0 ? num / den : 1.0;
    }
    x.comp = gain;
  }
}

Eigen::MatrixXd AnalogLayer::noisy_solves(const Crossbar& x, const Eigen::MatrixXd& v, Eigen::Index first_read,
                                          uint64_t image) const {
  const uint64_t key = device_.read_noise_key(image, salt_, static_cast<uint64_t>(x.index));
  SolverOptions one = cfg_.solver;
  one.threads = 1;
  Eigen::MatrixXd out(v.rows(), x.pcols);
  const double ro = cfg_.converters.readout_noise_a;
  std::vector<float> z(static_cast<size_t>(x.pcols) + 1);
  for (Eigen::Index r = 0; r < v.rows(); ++r) {
    const std::unique_ptr<CrossbarSolver> s = make_crossbar_solver(cfg_.xbar, one);
    s->program(device_.read(x.g_prog, key, static_cast<uint64_t>(first_read + r)));
    out.row(r) = s->column_currents(v.row(r));
    if (ro > 0) {
      read_normals(key, static_cast<uint64_t>(first_read + r), x.pcols, z.data());
      for (int c = 0; c < x.pcols; ++c) out(r, c) += ro * z[static_cast<size_t>(c)];
    }
  }
  return out;
}

void AnalogLayer::set_adc_offsets(Crossbar& x) const {
  // Offset subtraction before the ADC: the shift current (g_min - beta s w_lo) sum(X) of each
  // column (g_min sum(X) with differential pairs or multi-level cells), mirrored from the
  // sum(X) reference, so the ADC range spans the weight part only.
  x.adc_offset = Eigen::VectorXd::Zero(x.pcols);
  if (cfg_.converters.adc_offset_subtraction)
    for (int c = 0; c < x.pcols; ++c) {
      if (cfg_.mapping.analog_sum() && c == x.pcols - 1) continue;  // the reference column itself
      x.adc_offset(c) = alpha_ * (cfg_.xbar.g_min_s - (x.offset_has_w_lo ? x.beta(c) * x.s(c) * x.w_lo : 0.0));
    }
}

bool AnalogLayer::measures_adc_ranges() const {
  return cfg_.converters.adc_bits > 0 && cfg_.converters.adc_range != AdcRange::Full;
}

AnalogLayer::AdcSamples AnalogLayer::adc_samples(const Crossbar& x, const Eigen::MatrixXd& range_x) const {
  AdcSamples a;
  if (measures_adc_ranges()) a.cur = offset_currents(x, range_x, a.range, kRangeReads);
  return a;
}

void AnalogLayer::set_adc_ranges(Crossbar& x, const AdcSamples& samples, const Eigen::MatrixXd* pooled) const {
  const int ranges = cfg_.converters.adc_range == AdcRange::PerRead ? slicing_.slices : 1;
  x.adc_lo = Eigen::MatrixXd::Zero(x.pcols, ranges);
  x.adc_hi = Eigen::MatrixXd::Zero(x.pcols, ranges);
  x.adc_span = Eigen::MatrixXd::Zero(x.pcols, ranges);
  x.adc_chosen = Eigen::MatrixXd::Zero(x.pcols, ranges);
  if (cfg_.converters.adc_bits > 0 && cfg_.converters.adc_range == AdcRange::Full) {
    set_full_adc_ranges(x);
  } else if (cfg_.converters.adc_bits > 0) {
    // ADC ranges from the (offset-subtracted) currents of the range-estimation reads (per read
    // of a vector with a reference per read), by ranging.adc; with ranging.adc_scope: layer one
    // range for every column of the layer but a sum(X) reference (`pooled`: lo, hi per range).
    const double levels = std::ldexp(1.0, cfg_.converters.adc_bits) - 1;
    for (int c = 0; c < x.pcols; ++c) {
      const bool reference = cfg_.mapping.analog_sum() && c == x.pcols - 1;
      for (int g = 0; g < ranges; ++g) {
        double lo, hi;
        const std::vector<double> v = column_samples(samples, c, g, ranges);
        if (!v.empty()) {
          const auto [mn, mx] = std::minmax_element(v.begin(), v.end());
          x.adc_span(c, g) = *mx - *mn;
        }
        if (pooled && !reference) {
          lo = (*pooled)(0, g);
          hi = (*pooled)(1, g);
        } else {
          std::tie(lo, hi) = value_range(v, cfg_.ranging.adc, cfg_.ranging.adc_percentile, levels);
        }
        x.adc_chosen(c, g) = hi - lo;
        const double pad = std::max(cfg_.converters.adc_margin * (hi - lo),
                                    ConversionController::kMinAdcPadRelative * std::max(std::abs(hi), 1e-12));
        x.adc_lo(c, g) = lo - pad;
        x.adc_hi(c, g) = hi + pad;
      }
    }
  }
  // FastQuantizer's parameters of every column and range, for the bit-serial reads.
  Crossbar::AdcTable<double>& t = x.adc_d;
  t.lo = x.adc_lo.array();
  t.hi = x.adc_hi.array();
  t.step.resize(x.pcols, ranges);
  t.on.resize(x.pcols, ranges);
  for (int c = 0; c < x.pcols; ++c)
    for (int g = 0; g < ranges; ++g) {
      const FastQuantizer q(Quantizer{cfg_.converters.adc_bits, x.adc_lo(c, g), x.adc_hi(c, g)});
      t.step(c, g) = q.step;
      t.on(c, g) = q.on ? 1.0 : 0.0;
    }
  t.inv_step = 1.0 / t.step;
  t.offset = x.adc_offset.array();
  t.all_on.clear();
  for (int g = 0; g < ranges; ++g) t.all_on.push_back((t.on.col(g) > 0).all());
  x.adc_f = {t.lo.cast<float>(), t.hi.cast<float>(), t.step.cast<float>(),  t.inv_step.cast<float>(),
             t.on.cast<float>(), t.all_on,           t.offset.cast<float>()};
}

void AnalogLayer::set_full_adc_ranges(Crossbar& x) const {
  // One level: a cell one conductance level above g_min read at one DAC step.
  const int bits = cfg_.converters.adc_bits;
  const bool bipolar = !slicing_.serial() && signed_;  // one signed read applies negative voltages
  const double read_max =
      slicing_.serial() ? static_cast<double>(slicing_.digit_max()) : std::ldexp(1.0, dac_q_.bits) - 1;
  const double g_span = cfg_.xbar.g_max_s * (1 - cfg_.mapping.g_headroom) - cfg_.xbar.g_min_s;
  const double cell_max = std::ldexp(1.0, cfg_.mapping.cell_bits) - 1;
  const double unit = cfg_.xbar.v_in_max_v / read_max * g_span / cell_max;
  const double levels = x.blk.rows * cell_max * read_max;
  for (int c = 0; c < x.pcols; ++c) {
    const bool reference = cfg_.mapping.analog_sum() && c == x.pcols - 1;
    // The sum(X) column spans rows x its conductance at full scale; weight columns their levels.
    const double span =
        reference ? x.blk.rows * cfg_.xbar.v_in_max_v * (cfg_.xbar.g_min_s + x.s(c) * x.a_sum) : levels * unit;
    const int need = static_cast<int>(std::ceil(std::log2(span / unit + 1) - 1e-12)) + (bipolar ? 1 : 0);
    const double lsb = reference ? span / (std::ldexp(1.0, bits) - 1) : std::ldexp(unit, std::max(0, need - bits));
    x.adc_lo(c, 0) = bipolar && !reference ? -std::ldexp(lsb, bits - 1) : 0.0;
    x.adc_hi(c, 0) = x.adc_lo(c, 0) + (std::ldexp(1.0, bits) - 1) * lsb;
  }
}

std::vector<double> AnalogLayer::column_samples(const AdcSamples& a, int c, int g, int ranges) {
  std::vector<double> v;
  v.reserve(static_cast<size_t>(ranges == 1 ? a.cur.rows() : a.cur.rows() / ranges + 1));
  for (Eigen::Index r = 0; r < a.cur.rows(); ++r)
    if (ranges == 1 || a.range(r) == g) v.push_back(a.cur(r, c));
  return v;
}

void AnalogLayer::read_out_all(std::vector<std::unique_ptr<Crossbar>>& xbars, const LayerInputs& in) const {
  // Every crossbar reads its own rows of the inputs while it is read out (in0 = 0), and the
  // whole layer's inputs at its rows afterwards, also when the readout throws.
  struct AtLayerRows {
    std::vector<std::unique_ptr<Crossbar>>& xbars;
    const std::vector<Block>& blocks;
    ~AtLayerRows() {
      for (size_t b = 0; b < xbars.size(); ++b) xbars[b]->in0 = blocks[b].row0;
    }
  } at_layer_rows{xbars, blocks_};
  for (auto& x : xbars) x->in0 = 0;
  std::vector<AdcSamples> samples(xbars.size());
  std::vector<ProgrammingInputs> inputs;
  inputs.reserve(xbars.size());
  for (size_t b = 0; b < xbars.size(); ++b) {
    check_cancel();
    Crossbar& x = *xbars[b];
    try {
      inputs.push_back(crossbar_inputs(in, blocks_[b]));
      set_adc_offsets(x);
      samples[b] = adc_samples(x, inputs.back().range_b);
    } catch (const std::exception&) {
      rethrow_with_context("reading out its " + crossbar_name(blocks_[b]));
    }
  }
  // One ADC range for the layer: every weight column's samples of every crossbar, per range.
  Eigen::MatrixXd pooled;
  const bool layer_scope = cfg_.ranging.adc_scope == AdcScope::Layer && measures_adc_ranges();
  if (layer_scope) {
    const int ranges = cfg_.converters.adc_range == AdcRange::PerRead ? slicing_.slices : 1;
    const double levels = std::ldexp(1.0, cfg_.converters.adc_bits) - 1;
    pooled.resize(2, ranges);
    for (int g = 0; g < ranges; ++g) {
      std::vector<double> v;
      for (size_t b = 0; b < xbars.size(); ++b) {
        const int weight_cols = xbars[b]->pcols - (cfg_.mapping.analog_sum() ? 1 : 0);
        for (int c = 0; c < weight_cols; ++c) {
          const std::vector<double> col = column_samples(samples[b], c, g, ranges);
          v.insert(v.end(), col.begin(), col.end());
        }
      }
      const auto [lo, hi] = value_range(std::move(v), cfg_.ranging.adc, cfg_.ranging.adc_percentile, levels);
      pooled(0, g) = lo;
      pooled(1, g) = hi;
    }
  }
  for (size_t b = 0; b < xbars.size(); ++b) {
    check_cancel();
    Crossbar& x = *xbars[b];
    try {
      set_adc_ranges(x, samples[b], layer_scope ? &pooled : nullptr);
      calibrate(x, inputs[b]);
    } catch (const std::exception&) {
      rethrow_with_context("reading out its " + crossbar_name(blocks_[b]));
    }
  }
  if (bias_.size()) fold_output_offsets(xbars, bias_);  // the digital bias's correction stays
}

void AnalogLayer::calibrate(Crossbar& x, const ProgrammingInputs& in) const {
  x.fit = identity_fit(x.blk.cols);
  if (!cfg_.mitigation.calibrate()) return;
  x.fit = fit_columns(partial_of(x, in.cal_b, /*adc=*/true, /*calibrated=*/false, kCalibrationReads), in.ideal_partial,
                      output_steps(x));
}

Eigen::VectorXd AnalogLayer::output_steps(const Crossbar& x) const {
  Eigen::VectorXd step = Eigen::VectorXd::Zero(x.blk.cols);
  if (cfg_.converters.adc_bits <= 0) return step;
  // A code of physical column c in read s moves weight column j's output by
  // w_s k_c step(c, g) / alpha (recover_of: k_c = sign / (beta s)); with an analog sum
  // column, a code of it moves sum(X) by w_s step / (alpha (g_min + beta s a_sum)), which
  // enters j's output times w_lo - g_min sum_c k_c.
  const int slices = slicing_.slices, per = x.per_weight;
  const bool per_read = x.adc_d.step.cols() > 1, analog_sum = cfg_.mapping.analog_sum();
  const auto code = [&](int c, int s) { return x.adc_d.on(c, per_read ? s : 0) > 0 ? x.adc_d.step(c, per_read ? s : 0) : 0.0; };
  const auto place = [&](int s) { return slicing_.weight.empty() ? 1.0 : slicing_.weight[static_cast<size_t>(s)]; };
  for (int j = 0; j < x.blk.cols; ++j) {
    double var = 0, k_sum = 0;
    for (int q = 0; q < per; ++q) {
      const int c = j * per + q;
      k_sum += x.recover_k(c);
      for (int s = 0; s < slices; ++s) var += std::pow(place(s) * x.recover_k(c) * code(c, s) / alpha_, 2);
    }
    if (analog_sum) {
      const int c = x.pcols - 1;
      const double per_sum = (x.w_lo - cfg_.xbar.g_min_s * k_sum) / (alpha_ * (cfg_.xbar.g_min_s + x.beta(c) * x.s(c) * x.a_sum));
      for (int s = 0; s < slices; ++s) var += std::pow(place(s) * per_sum * code(c, s), 2);
    }
    step(j) = std::sqrt(var);
  }
  return step;
}

}  // namespace xbarsim
