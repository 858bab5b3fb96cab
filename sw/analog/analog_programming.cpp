// Programming of an analog layer's crossbars, in named steps: conversion (the paper's signal
// conversion or matrix conversion), programming noise, ADC ranging and calibration.
#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

#include "sw/analog/analog_layer_impl.h"
#include "sw/analog/error_metrics.h"
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
  }
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
      const double e =
          relative_error(raw_partial_of(x, currents_of(x, in.cal_s), in.cal_s), in.ideal_partial).mean_relative_error;
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
          in.cal_b.rows()
              ? Eigen::VectorXd(alpha_ *
                                in.cal_s.middleCols(x.blk.row0, x.blk.rows).cwiseAbs().colwise().mean().transpose())
              : Eigen::VectorXd::Constant(x.blk.rows,
                                          ConversionController::kDefaultOperatingPoint * cfg_.xbar.v_in_max_v);
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

void AnalogLayer::add_programming_noise(Crossbar& x, int b) const {
  if (!(cfg_.noise.sigma_s > 0)) return;
  const CrossbarParams& p = cfg_.xbar;
  std::mt19937_64 rng(derive_seed(cfg_.noise.seed, {salt_, static_cast<uint64_t>(b)}));
  std::normal_distribution<double> nd(0.0, cfg_.noise.sigma_s);
  Eigen::MatrixXd gp = x.g_prog;
  for (Eigen::Index k = 0; k < gp.size(); ++k)
    gp.data()[k] = std::min(std::max(gp.data()[k] + nd(rng), p.g_min_s), p.g_max_s);
  install(x, gp);
}

void AnalogLayer::set_adc_ranges(Crossbar& x, const Eigen::MatrixXd& range_x) const {
  // Offset subtraction before the ADC: the shift current (g_min - beta s w_lo) sum(X) of each
  // column (g_min sum(X) with differential pairs or multi-level cells), mirrored from the
  // sum(X) reference, so the ADC range spans the weight part only.
  x.adc_offset = Eigen::VectorXd::Zero(x.pcols);
  if (cfg_.converters.adc_offset_subtraction)
    for (int c = 0; c < x.pcols; ++c) {
      if (cfg_.mapping.analog_sum() && c == x.pcols - 1) continue;  // the reference column itself
      x.adc_offset(c) = alpha_ * (cfg_.xbar.g_min_s - (x.offset_has_w_lo ? x.beta(c) * x.s(c) * x.w_lo : 0.0));
    }
  const int ranges = cfg_.converters.adc_range == AdcRange::PerRead ? slicing_.slices : 1;
  x.adc_lo = Eigen::MatrixXd::Zero(x.pcols, ranges);
  x.adc_hi = Eigen::MatrixXd::Zero(x.pcols, ranges);
  if (cfg_.converters.adc_bits <= 0) return;
  if (cfg_.converters.adc_range == AdcRange::Full) {
    set_full_adc_ranges(x);
    return;
  }
  // ADC ranges from the (offset-subtracted) currents of the range-estimation reads (per read
  // of a vector: its rows of the slice-major reads).
  Eigen::MatrixXd cur = currents_of(x, range_x);
  const Eigen::VectorXd sx = range_x.middleCols(x.blk.row0, x.blk.rows).rowwise().sum();
  const Eigen::Index per_range = cur.rows() / ranges;
  for (int c = 0; c < x.pcols; ++c) {
    cur.col(c) -= x.adc_offset(c) * sx;
    for (int g = 0; g < ranges; ++g) {
      const auto seg = cur.col(c).segment(g * per_range, ranges == 1 ? cur.rows() : per_range);
      const double lo = seg.minCoeff(), hi = seg.maxCoeff();
      const double pad = std::max(cfg_.converters.adc_margin * (hi - lo),
                                  ConversionController::kMinAdcPadRelative * std::max(std::abs(hi), 1e-12));
      x.adc_lo(c, g) = lo - pad;
      x.adc_hi(c, g) = hi + pad;
    }
  }
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

void AnalogLayer::calibrate(Crossbar& x, const ProgrammingInputs& in) const {
  x.fit = identity_fit(x.blk.cols);
  if (!cfg_.mitigation.calibrate()) return;
  Mat<double> cur = currents_of(x, in.cal_s);
  adc_of<double, Eigen::MatrixXd>(x, cur, in.cal_s);
  x.fit = fit_columns(raw_partial_of(x, cur, in.cal_s), in.ideal_partial);
}

}  // namespace xbarsim
