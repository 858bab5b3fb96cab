#include "sw/analog/analog_layer.h"
#include "sw/common/cancel.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>
#include <sstream>
#include <stdexcept>
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
  if (c.xbar.voltage_sensing())
    throw InputError(
        "configuration key 'crossbar.sensing' (voltage): the analog layers, their mapping and mitigations read "
        "column currents; voltage sensing is available to `xbarsim solve`, `xbarsim netlist` and the Python solve "
        "and netlist only");
  c.solver = parse_solver_options(cfg);
  c.mapping = parse_mapping_spec(cfg, c.xbar);
  c.mitigation = mitigation_from_name(cfg.get_string(method_key), method_key);
  c.conversion = parse_conversion_spec(cfg);
  c.calibration = parse_calibration_spec(cfg);
  if (c.calibration.samples < 2) throw InputError("configuration key 'calibration.samples' must be >= 2");
  c.converters = parse_converters_spec(cfg);
  c.ranging = parse_ranging_spec(cfg);
  c.device = parse_device_spec(cfg);
  c = with_device_range(c);  // one key per physical quantity: a model's own range sets the crossbar's
  // Per-column scales are digital gains after the ADC; the shift's analog removal of w_lo sum(X)
  // (the sum(X) column, or the ADC's offset subtraction of analog cells) is one reference current
  // for every column of a crossbar, which columns of other scales cannot share.
  if (c.ranging.weight_scale == WeightScale::Column && !c.mapping.differential() &&
      (c.mapping.analog_sum() || (c.converters.adc_offset_subtraction && c.mapping.cell_bits == 0)))
    throw InputError(std::string("configuration key 'ranging.weight_scale' (column) with mapping.negative: shift and ") +
                     (c.mapping.analog_sum() ? "mapping.sum_x: analog" : "converters.adc_offset_subtraction: true") +
                     ": the shift's offset is removed in the analog domain with one reference current for every "
                     "column of a crossbar, which columns of their own scales cannot share; use mapping.negative: "
                     "differential, or ranging.weight_scale: crossbar or layer" +
                     (c.mapping.analog_sum() ? ", or mapping.sum_x: digital" : ""));
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

AnalogConfig with_device_range(AnalogConfig c) {
  DeviceSpec& d = c.device;
  if (d.fixes_range()) {
    c.xbar.g_min_s = d.g_min_s = d.stat.g_min_s;
    c.xbar.g_max_s = d.g_max_s = d.stat.g_max_s;
  } else {
    d.g_min_s = c.xbar.g_min_s;
    d.g_max_s = c.xbar.g_max_s;
  }
  return c;
}

bool programs_alike(const AnalogConfig& a_given, const AnalogConfig& b_given) {
  const AnalogConfig a = with_device_range(a_given), b = with_device_range(b_given);
  const CrossbarParams &xa = a.xbar, &xb = b.xbar;
  const bool crossbar = xa.r_wire_ohm == xb.r_wire_ohm && xa.r_in_ohm == xb.r_in_ohm && xa.r_out_ohm == xb.r_out_ohm &&
                        xa.g_min_s == xb.g_min_s && xa.g_max_s == xb.g_max_s && xa.v_in_max_v == xb.v_in_max_v &&
                        xa.memristor.model == xb.memristor.model && xa.memristor.k_per_v == xb.memristor.k_per_v &&
                        xa.memristor.v_read_v == xb.memristor.v_read_v && xa.transistor.model == xb.transistor.model &&
                        xa.transistor.r_on_ohm == xb.transistor.r_on_ohm && xa.transistor.vg_v == xb.transistor.vg_v &&
                        xa.transistor.vth_v == xb.transistor.vth_v &&
                        xa.transistor.kp_a_per_v2 == xb.transistor.kp_a_per_v2;
  const SolverOptions &sa = a.solver, &sb = b.solver;
  const bool solver = sa.method == sb.method && sa.tolerance == sb.tolerance &&
                      sa.max_iterations == sb.max_iterations && sa.newton_max_iterations == sb.newton_max_iterations &&
                      sa.newton_tolerance == sb.newton_tolerance && sa.newton_abstol_a == sb.newton_abstol_a &&
                      sa.max_step_v == sb.max_step_v && sa.batched_nonlinear == sb.batched_nonlinear &&
                      sa.nonlinear_tolerance == sb.nonlinear_tolerance;
  const MappingSpec &ma = a.mapping, &mb = b.mapping;
  const bool mapping = ma.max_rows == mb.max_rows && ma.max_cols == mb.max_cols && ma.negative == mb.negative &&
                       ma.sum_x == mb.sum_x && ma.g_headroom == mb.g_headroom && ma.scheme == mb.scheme &&
                       ma.cell_bits == mb.cell_bits && ma.weight_bits == mb.weight_bits;
  const ConversionSpec &ca = a.conversion, &cb = b.conversion;
  const bool conversion = a.mitigation.conversion() == b.mitigation.conversion() && ca.signal == cb.signal &&
                          ca.amplitude_mode == cb.amplitude_mode && ca.amplitude == cb.amplitude &&
                          ca.column_scaling == cb.column_scaling && ca.max_iterations == cb.max_iterations &&
                          ca.tolerance == cb.tolerance;
  const bool calibration = a.calibration.samples == b.calibration.samples &&
                           a.calibration.signal == b.calibration.signal && a.calibration.seed == b.calibration.seed;
  const ConvertersSpec &da = a.converters, &db = b.converters;
  const bool dacs =
      da.input_bits == db.input_bits && da.dac_bits == db.dac_bits && da.image_bits == db.image_bits &&
      da.dac_predistortion == db.dac_predistortion;
  // The device's programming and read statistics program (conversion may read); the time the
  // layer is read at and the compensation are readout (set_readout moves the layer in time).
  const DeviceSpec &va = a.device, &vb = b.device;
  const bool device = va.model == vb.model && va.program_sigma_s == vb.program_sigma_s &&
                      va.read_sigma_s == vb.read_sigma_s && va.stuck_gmin == vb.stuck_gmin &&
                      va.stuck_gmax == vb.stuck_gmax && va.spare_columns == vb.spare_columns && va.seed == vb.seed &&
                      da.readout_noise_a == db.readout_noise_a;
  // Weights and inputs are ranged before programming; the ADC ranges and the bias are readout.
  const RangingSpec &ra = a.ranging, &rb = b.ranging;
  const bool ranging = ra.weights == rb.weights && ra.weight_percentile == rb.weight_percentile &&
                       ra.weight_scale == rb.weight_scale && ra.inputs == rb.inputs &&
                       ra.input_percentile == rb.input_percentile;
  return crossbar && solver && mapping && conversion && calibration && dacs && device && ranging;
}

AnalogLayer::AnalogLayer(const AnalogConfig& cfg, const Eigen::MatrixXd& w, double x_max, bool signed_inputs,
                         uint64_t salt, const RowGroups& groups)
    : cfg_(with_device_range(cfg)), w_(w), x_max_(x_max), signed_(signed_inputs), salt_(salt), device_(cfg_.device) {
  if (w.rows() < 1 || w.cols() < 1) throw InputError("analog layer: empty weight matrix");
  if (!(x_max > 0) || !std::isfinite(x_max)) throw InputError("analog layer: input full scale must be > 0");
  alpha_ = cfg_.xbar.v_in_max_v / x_max;
  // With pre-distortion I/G = h(V(x)) = alpha x, full scale at v_in_max.
  if (cfg.dac_predistorts())
    alpha_ = MemristorDevice(cfg.xbar.memristor).current_per_siemens(cfg.xbar.v_in_max_v) / x_max;
  // Signed inputs: sign-magnitude, so that 0 is exactly a DAC level.
  const int bits = cfg.converters.activation_bits();
  dac_q_ = Quantizer{signed_inputs ? std::max(bits - 1, bits > 0 ? 1 : 0) : bits, 0.0, x_max};
  slicing_ = make_input_slicing(bits, cfg.converters.dac_bits, signed_inputs, x_max);
  const int rows = static_cast<int>(w.rows()), cols = static_cast<int>(w.cols());
  if (groups.count == 1) {
    blocks_ = crossbar_blocks(rows, cols, cfg.mapping);
    return;
  }
  const int g = groups.count, c = groups.channels;
  if (g < 1 || c < 1 || c % g != 0 || rows % c != 0 || cols % g != 0)
    throw InputError("analog layer: " + std::to_string(g) + " groups do not divide its " + std::to_string(c) +
                     " input channels, " + std::to_string(rows) + " rows and " + std::to_string(cols) + " outputs");
  // Group-major rows: every window position of group 0's channels, then group 1's, ...
  const int per_group = c / g, positions = rows / c, group_rows = rows / g, group_cols = cols / g;
  order_.resize(rows);
  for (int k = 0, q = 0; k < g; ++k)
    for (int p = 0; p < positions; ++p)
      for (int ch = 0; ch < per_group; ++ch) order_(q++) = p * c + k * per_group + ch;
  w_ = w(order_, Eigen::all);
  for (int k = 0; k < g; ++k)
    for (Block b : crossbar_blocks(group_rows, group_cols, cfg.mapping)) {
      b.row0 += k * group_rows;
      b.col0 += k * group_cols;
      blocks_.push_back(b);
    }
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
    // Distinct vectors first, in shuffled order: a repeated vector (eval samples an image's
    // rows with repetition; a 1 x 1 map has one) adds no information to the fit. Repeats only
    // when the real inputs hold fewer than `count` distinct vectors.
    std::vector<int> kept;
    Eigen::MatrixXd kept_q(count, k);  // the kept vectors as the DAC applies them
    for (size_t a = 0; a < idx.size() && static_cast<int>(kept.size()) < count; ++a) {
      const Eigen::MatrixXd q = dac(calib.row(idx[a]));
      const auto n = static_cast<Eigen::Index>(kept.size());
      if (n > 0 && (kept_q.topRows(n).rowwise() - q.row(0)).rowwise().squaredNorm().minCoeff() == 0) continue;
      kept_q.row(n) = q.row(0);
      kept.push_back(idx[a]);
    }
    Eigen::MatrixXd out(count, k);
    for (int a = 0; a < count; ++a) out.row(a) = calib.row(kept[static_cast<size_t>(a) % kept.size()]);
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
  // Whole columns at a time (the matrices are column-major): the first rows, or random picks.
  if (calib_in.rows() <= cap) {
    range_x.topRows(take) = calib_in.topRows(take);
  } else {
    Eigen::VectorXi picks(take);
    for (Eigen::Index a = 0; a < take; ++a) picks(a) = static_cast<int>(rng() % calib_in.rows());
    range_x.topRows(take) = calib_in(picks, Eigen::all);
  }
  range_x.bottomRows(cal.rows()) = cal;
  return dac(range_x);
}

void AnalogLayer::program(const Eigen::MatrixXd& calib, const SolverOptions& solver) {
  cfg_.solver = solver;
  program(calib);
}

AnalogLayer::LayerInputs AnalogLayer::layer_inputs(const Eigen::MatrixXd& calib_given, bool real_inputs) const {
  if (calib_given.size() > 0 && calib_given.cols() != w_.rows())
    throw InputError("analog layer: calibration vectors have the wrong length");
  const Eigen::MatrixXd calib_in =
      order_.size() && calib_given.size() ? Eigen::MatrixXd(calib_given(Eigen::all, order_)) : calib_given;
  LayerInputs in;
  in.cal = dac(calibration_vectors(calib_in));
  in.range_x = range_vectors(calib_in, in.cal);
  if (real_inputs && calib_in.size()) in.calib_q = dac(calib_in);
  return in;
}

AnalogLayer::ProgrammingInputs AnalogLayer::crossbar_inputs(const LayerInputs& in, const Block& blk) const {
  return {in.cal.middleCols(blk.row0, blk.rows),
          in.calib_q.size() ? Eigen::MatrixXd(in.calib_q.middleCols(blk.row0, blk.rows)) : Eigen::MatrixXd(),
          in.range_x.middleCols(blk.row0, blk.rows),
          in.cal.middleCols(blk.row0, blk.rows) * w_.block(blk.row0, blk.col0, blk.rows, blk.cols)};
}

std::vector<WeightRanges> AnalogLayer::block_ranges() const {
  const CellVariance var = [this](double g) { return std::pow(device_.read_spread_s(g), 2); };
  const CellVariance* v = cfg_.device.kind == DeviceKind::Ideal ? nullptr : &var;
  std::vector<WeightRanges> out(blocks_.size());
  const auto block_of = [&](const Block& b) { return w_.block(b.row0, b.col0, b.rows, b.cols); };
  if (cfg_.ranging.weight_scale == WeightScale::Crossbar) {
    for (size_t b = 0; b < blocks_.size(); ++b)
      out[b] = weight_ranges(block_of(blocks_[b]), cfg_.mapping, cfg_.ranging, cfg_.xbar, v ? *v : nullptr);
    return out;
  }
  // Layer or column: the range of every weight the layer's crossbars hold (a grouped layer's
  // zeros between groups are on no crossbar), as one column or per output column.
  const bool per_column = cfg_.ranging.weight_scale == WeightScale::Column;
  const int n = per_column ? outputs() : 1;
  std::vector<std::vector<double>> values(static_cast<size_t>(n));
  for (const Block& b : blocks_) {
    const Eigen::MatrixXd wb = block_of(b);
    for (int j = 0; j < b.cols; ++j) {
      std::vector<double>& dst = values[static_cast<size_t>(per_column ? b.col0 + j : 0)];
      dst.insert(dst.end(), wb.col(j).data(), wb.col(j).data() + b.rows);
    }
  }
  RangingSpec one = cfg_.ranging;
  one.weight_scale = WeightScale::Layer;  // each gathered column is a group of its own
  Eigen::VectorXd lo(n), hi(n);
  for (int k = 0; k < n; ++k) {
    const std::vector<double>& d = values[static_cast<size_t>(k)];
    const Eigen::Map<const Eigen::MatrixXd> col(d.data(), static_cast<Eigen::Index>(d.size()), 1);
    const WeightRanges r = weight_ranges(col, cfg_.mapping, one, cfg_.xbar, v ? *v : nullptr);
    lo(k) = r.lo(0);
    hi(k) = r.hi(0);
  }
  for (size_t b = 0; b < blocks_.size(); ++b) {
    const Block& blk = blocks_[b];
    WeightRanges& r = out[b];
    r.lo = per_column ? Eigen::VectorXd(lo.segment(blk.col0, blk.cols)) : Eigen::VectorXd::Constant(blk.cols, lo(0));
    r.hi = per_column ? Eigen::VectorXd(hi.segment(blk.col0, blk.cols)) : Eigen::VectorXd::Constant(blk.cols, hi(0));
    const Eigen::MatrixXd wb = block_of(blk);
    for (int j = 0; j < blk.cols; ++j)
      r.clipped += ((wb.col(j).array() < r.lo(j)) || (wb.col(j).array() > r.hi(j))).count();
  }
  return out;
}

void AnalogLayer::program(const Eigen::MatrixXd& calib_given) {
  const LayerInputs layer_in = layer_inputs(calib_given);
  const std::vector<WeightRanges> ranges = block_ranges();
  // All or nothing: the crossbars replace the layer's only once every one is programmed (an
  // error or a cancellation leaves the layer as it was).
  std::vector<std::unique_ptr<Crossbar>> xbars;
  std::vector<CrossbarReport> reports;
  for (size_t b = 0; b < blocks_.size(); ++b) {
    check_cancel();
    try {
      const Block& blk = blocks_[b];
      auto xb = std::make_unique<Crossbar>();
      const Eigen::MatrixXd wb = w_.block(blk.row0, blk.col0, blk.rows, blk.cols);
      static_cast<MappedWeights&>(*xb) = map_weights(wb, blk, cfg_.mapping, cfg_.xbar, ranges[b]);
      xb->index = static_cast<int>(b);
      xb->stream = derive_seed(cfg_.device.seed, {salt_, static_cast<uint64_t>(b)});
      xb->beta = Eigen::VectorXd::Ones(xb->pcols);
      xb->solver = make_crossbar_solver(cfg_.xbar, cfg_.solver);
      // Programming reads the crossbar's own rows of every input (in0 = 0), then the crossbar
      // reads the whole layer's inputs at its rows.
      const ProgrammingInputs in = crossbar_inputs(layer_in, blk);
      CrossbarReport rep;
      rep.block = blk;
      rep.physical_cols = xb->pcols;
      rep.clipped_weights = ranges[b].clipped;
      rep.weight_clip.resize(blk.cols);
      for (int j = 0; j < blk.cols; ++j) {
        const double top = std::max(-ranges[b].lo(j), std::abs(ranges[b].hi(j)));
        const double biggest = wb.col(j).cwiseAbs().maxCoeff();
        rep.weight_clip(j) = biggest > 0 ? std::min(top / biggest, 1.0) : 1.0;
      }
      convert(*xb, in, rep);
      if (cfg_.device.has_read_noise() && cfg_.xbar.is_linear()) xb->noise_points = read_noise_points(in);
      write_cells(*xb, rep);
      xbars.push_back(std::move(xb));
      reports.push_back(rep);
    } catch (const std::exception&) {
      rethrow_with_context("programming its " + crossbar_name(blocks_[b]));
    }
  }
  const Eigen::VectorXd bias_before = bias_;
  bias_.resize(0);  // new crossbars: no output offsets until they are measured on them
  try {
    read_out_all(xbars, layer_in);
  } catch (...) {
    bias_ = bias_before;
    throw;
  }
  xbars.swap(xbars_);
  const std::vector<CrossbarReport> reports_before = reports_;
  reports_ = std::move(reports);
  time_s_ = 0;
  try {
    move_to_time(layer_in);
  } catch (...) {
    xbars.swap(xbars_);  // all or nothing: the layer as it was
    reports_ = reports_before;
    bias_ = bias_before;
    throw;
  }
}

void AnalogLayer::set_output_offsets(const Eigen::VectorXd& offset) {
  if (offset.size() != outputs()) throw std::invalid_argument("analog layer: output offsets of another width");
  if (xbars_.empty()) throw std::invalid_argument("analog layer: output offsets before program()");
  const Eigen::VectorXd before = bias_.size() ? bias_ : Eigen::VectorXd::Zero(outputs());
  fold_output_offsets(xbars_, offset - before);
  bias_ = offset;
}

AnalogLayer::RangeSummary AnalogLayer::range_summary() const {
  RangeSummary r;
  double clip_sum = 0, adc_sum = 0;
  long long clip_n = 0, adc_n = 0;
  for (size_t b = 0; b < reports_.size(); ++b) {
    const CrossbarReport& rep = reports_[b];
    r.weights += static_cast<long long>(rep.block.rows) * rep.block.cols;
    r.clipped_weights += rep.clipped_weights;
    clip_sum += rep.weight_clip.sum();
    clip_n += rep.weight_clip.size();
  }
  for (const auto& x : xbars_)
    for (Eigen::Index k = 0; k < x->adc_span.size(); ++k) {
      r.adc_full_scale_a = std::max(r.adc_full_scale_a, x->adc_hi.data()[k] - x->adc_lo.data()[k]);
      if (!(x->adc_span.data()[k] > 0)) continue;
      adc_sum += std::min(x->adc_chosen.data()[k] / x->adc_span.data()[k], 1.0);
      ++adc_n;
    }
  r.weight_clip = clip_n ? clip_sum / static_cast<double>(clip_n) : 1.0;
  r.adc_clip = adc_n ? adc_sum / static_cast<double>(adc_n) : 0.0;
  r.output_offset_rms = bias_.size() ? std::sqrt(bias_.squaredNorm() / static_cast<double>(bias_.size())) : 0.0;
  return r;
}

void AnalogLayer::fold_output_offsets(std::vector<std::unique_ptr<Crossbar>>& xbars, const Eigen::VectorXd& add) const {
  // Each output column's offset in the first crossbar holding it.
  std::vector<char> done(static_cast<size_t>(outputs()), 0);
  for (size_t b = 0; b < blocks_.size() && b < xbars.size(); ++b)
    for (int j = 0; j < blocks_[b].cols; ++j) {
      const int col = blocks_[b].col0 + j;
      if (done[static_cast<size_t>(col)]) continue;
      done[static_cast<size_t>(col)] = 1;
      xbars[b]->fit.offset(j) += add(col);
    }
}

void AnalogLayer::set_readout(const AnalogConfig& cfg, const Eigen::MatrixXd& calib) {
  if (xbars_.empty()) throw std::invalid_argument("analog layer: set_readout before program()");
  if (!programs_alike(cfg_, cfg))
    throw std::invalid_argument("analog layer: set_readout with a configuration that programs other conductances");
  const std::shared_ptr<const SavedReadout> before = save_readout();
  try {
    // Only the time or the compensation changes, and the readout at t = 0 is still the one
    // programming made (no recalibration at another time since): move in time only.
    const ConvertersSpec &ca = cfg_.converters, &cb = cfg.converters;
    const RangingSpec &ra = cfg_.ranging, &rb = cfg.ranging;
    const bool same_readout = ca.adc_bits == cb.adc_bits && ca.adc_range == cb.adc_range &&
                              ca.adc_margin == cb.adc_margin && ca.adc_offset_subtraction == cb.adc_offset_subtraction &&
                              cfg_.mitigation.calibrate() == cfg.mitigation.calibrate() && ra.adc == rb.adc &&
                              ra.adc_percentile == rb.adc_percentile && ra.adc_scope == rb.adc_scope &&
                              cfg_.device.compensation != Compensation::Recalibrate;
    cfg_ = with_device_range(cfg);
    cfg_.solver = before->cfg.solver;  // the options the crossbars' solvers were made with
    const LayerInputs layer_in = layer_inputs(calib, /*real_inputs=*/false);  // only conversion reads them
    if (same_readout) {
      move_to_time(layer_in);
      return;
    }
    // As program(): the crossbars read out at t = 0.
    for (auto& x : xbars_) {
      check_cancel();
      if (time_s_ != 0) settle(*x, 0);
    }
    time_s_ = 0;
    read_out_all(xbars_, layer_in);
    move_to_time(layer_in);
  } catch (...) {
    restore_readout(*before);
    throw;
  }
}

std::shared_ptr<const AnalogLayer::SavedReadout> AnalogLayer::save_readout() const {
  auto s = std::make_shared<SavedReadout>();
  s->cfg = cfg_;
  s->time_s = time_s_;
  s->bias = bias_;
  s->xbars.reserve(xbars_.size());
  for (const auto& x : xbars_)
    s->xbars.push_back(
        {x->adc_lo, x->adc_hi, x->adc_span, x->adc_chosen, x->adc_offset, x->fit, x->adc_f, x->adc_d, x->ref0, x->comp});
  return s;
}

void AnalogLayer::restore_readout(const SavedReadout& saved) {
  if (saved.xbars.size() != xbars_.size())
    throw std::invalid_argument("analog layer: restore_readout of another layer's crossbars");
  cfg_ = saved.cfg;
  bias_ = saved.bias;
  for (size_t b = 0; b < xbars_.size(); ++b) {
    Crossbar& x = *xbars_[b];
    const SavedReadout::Readout& r = saved.xbars[b];
    x.adc_lo = r.adc_lo;
    x.adc_hi = r.adc_hi;
    x.adc_span = r.adc_span;
    x.adc_chosen = r.adc_chosen;
    x.adc_offset = r.adc_offset;
    x.fit = r.fit;
    x.adc_f = r.adc_f;
    x.adc_d = r.adc_d;
    x.ref0 = r.ref0;
    x.comp = r.comp;
    if (time_s_ != saved.time_s) settle(x, saved.time_s);
  }
  time_s_ = saved.time_s;
}

const Eigen::MatrixXd& AnalogLayer::conductances(int b) const { return xbars_.at(b)->g_prog; }

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

Eigen::MatrixXd AnalogLayer::currents_of(const Crossbar& x, const Eigen::MatrixXd& xq, uint64_t image) const {
  Mat<double> cur;
  analog_of<double>(x, xq, cur, image);
  return cur;
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
void AnalogLayer::arrange_inputs(RowMat<S>& x) const {
  if (!order_.size()) return;
  thread_local RowMat<S> arranged;
  arranged = x(Eigen::all, order_);
  x.swap(arranged);
}

template <typename S>
void AnalogLayer::analog(int b, const RowMat<S>& xq, Mat<S>& currents, uint64_t image) const {
  analog_of<S>(*xbars_.at(b), xq, currents, image);
}

template <typename S>
void AnalogLayer::analog_of(const Crossbar& x, const RowMat<S>& xq, Mat<S>& currents, uint64_t image) const {
  const auto values = xq.middleCols(x.in0, x.blk.rows);
  if (cfg_.xbar.is_linear()) {
    // I = V * G_eff with V = alpha * X: alpha is folded into the stored matrix.
    if constexpr (std::is_same_v<S, float>)
      currents.noalias() = values * x.geff_f;
    else
      currents.noalias() = values * x.geff_d;
    add_read_noise<S>(x, values, currents.data(), currents.rows(), /*row_major=*/false, 0, image);
    return;
  }
  const Eigen::MatrixXd v = volts(values.template cast<double>());
  if (cfg_.device.has_read_noise()) {  // every read solved with its own conductances
    currents = noisy_solves(x, v, 0, image).template cast<S>();
    return;
  }
  currents = x.solver->column_currents(v).template cast<S>();
  add_read_noise<S>(x, values, currents.data(), currents.rows(), /*row_major=*/false, 0, image);
}

template <typename S>
void AnalogLayer::adc_inplace(int b, Mat<S>& currents, const RowMat<S>& xq) const {
  adc_of<S>(*xbars_.at(b), currents, xq);
}

template <typename S, typename XQ>
void AnalogLayer::adc_of(const Crossbar& x, Mat<S>& currents, const XQ& xq) const {
  // Drift compensation is the readout's gain: the ADC converts the compensated current, so the
  // range it was given at programming still fits.
  compensate<S>(x, currents.data(), currents.rows(), currents.rows(), /*row_major=*/false);
  if (cfg_.converters.adc_bits <= 0) return;
  using Col = Eigen::Array<S, Eigen::Dynamic, 1>;
  const Col sum_x = input_sums<S>(xq, x.in0, x.blk.rows).array();
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

template <typename S>
void AnalogLayer::recover_add(int b, const Mat<S>& iq, const RowMat<S>& xq, Mat<S>& y, bool calibrated) const {
  const Crossbar& x = *xbars_.at(b);
  recover_of<S>(x, iq, xq, y, x.blk.col0, calibrated);
}

template <typename S>
void AnalogLayer::recover_of(const Crossbar& x, const Mat<S>& iq, const RowMat<S>& xq, Mat<S>& y, int y_col0,
                             bool calibrated) const {
  const Eigen::Index n = y.rows();  // iq and xq: n rows
  const S gmin = static_cast<S>(cfg_.xbar.g_min_s);
  const S inv_alpha = static_cast<S>(1.0 / alpha_);
  Eigen::Matrix<S, Eigen::Dynamic, 1> sum_x;
  if (cfg_.mapping.analog_sum()) {  // I_sum / alpha = (g_min + beta s a_sum) * sum(X)
    const int c = x.pcols - 1;
    sum_x = iq.col(c) * static_cast<S>(1.0 / (alpha_ * (cfg_.xbar.g_min_s + x.beta(c) * x.s(c) * x.a_sum)));
  } else {
    sum_x = input_sums<S>(xq, x.in0, x.blk.rows);
  }
  // Per physical column: sign / (beta s), so (I / alpha - g_min sum(X)) times it is the
  // column's signed share of its weight column's product (its slice's place included).
  Eigen::Matrix<S, Eigen::Dynamic, 1> k(x.pcols);
  for (int c = 0; c < x.pcols; ++c) k(c) = static_cast<S>(x.sign(c) / (x.beta(c) * x.s(c)));
  const S w_lo = static_cast<S>(x.w_lo);
  const int per = x.per_weight;
  Eigen::Matrix<S, Eigen::Dynamic, 1> acc(n);
  for (int j = 0; j < x.blk.cols; ++j) {
    const S gain = calibrated ? static_cast<S>(x.fit.gain(j)) : S(1);
    const S off = calibrated ? static_cast<S>(x.fit.offset(j)) : S(0);
    S* out = y.col(y_col0 + j).data();
    if (per <= 2) {  // one column or a pair: in one pass
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
    // Shift-and-add of the weight's columns (weight slices).
    S* ac = acc.data();
    for (int q = 0; q < per; ++q) {
      const int c = j * per + q;
      const S kc = k(c);
      const S* ic = iq.col(c).data();
      const S* sx = sum_x.data();
      if (q == 0)
        for (Eigen::Index r = 0; r < n; ++r) ac[r] = (ic[r] * inv_alpha - gmin * sx[r]) * kc;
      else
        for (Eigen::Index r = 0; r < n; ++r) ac[r] += (ic[r] * inv_alpha - gmin * sx[r]) * kc;
    }
    for (Eigen::Index r = 0; r < n; ++r) ac[r] += w_lo * sum_x(r);
    for (Eigen::Index r = 0; r < n; ++r) out[r] += gain * ac[r] + off;
  }
}

template <typename S>
void AnalogLayer::forward(const RowMat<S>& x, Mat<S>& y, bool quantized, uint64_t image) const {
  if (x.cols() != w_.rows()) {
    std::ostringstream os;
    os << "analog layer: input vectors have " << x.cols() << " values, the layer expects " << w_.rows();
    throw InputError(os.str());
  }
  if (xbars_.empty()) throw InputError("analog layer used before program()");
  RowMat<S> xq_buf;
  const RowMat<S>* xq = &x;
  if ((dac_q_.enabled() && !quantized) || order_.size()) {
    // One copy: a grouped layer's inputs taken in the crossbars' row order (arrange_inputs).
    if (order_.size())
      xq_buf = x(Eigen::all, order_);
    else
      xq_buf = x;
    if (!quantized) dac_inplace<S>(xq_buf);
    xq = &xq_buf;
  }
  y.setZero(x.rows(), w_.cols());
  if (slicing_.serial()) {
    forward_serial<S>(*xq, y, image);
    return;
  }
  Mat<S> cur;
  for (int b = 0; b < crossbars(); ++b) {
    check_cancel();
    try {
      analog<S>(b, *xq, cur, image);
      adc_inplace<S>(b, cur, *xq);
      recover_add<S>(b, cur, *xq, y);
    } catch (const std::exception&) {
      rethrow_with_context(crossbar_name(blocks_[b]));
    }
  }
}

Eigen::MatrixXd AnalogLayer::forward(const Eigen::MatrixXd& x, uint64_t image) const {
  const RowMat<double> xr = x;
  Mat<double> y;
  forward<double>(xr, y, false, image);
  return y;
}

Eigen::MatrixXd AnalogLayer::partial(int b, const Eigen::MatrixXd& x) const {
  const Eigen::MatrixXd xq = dac(x);
  if (order_.size()) return partial_of(*xbars_.at(b), xq(Eigen::all, order_), /*adc=*/true, /*calibrated=*/true, 0);
  return partial_of(*xbars_.at(b), xq, /*adc=*/true, /*calibrated=*/true, 0);
}

Eigen::MatrixXd AnalogLayer::partial_of(const Crossbar& x, const Eigen::MatrixXd& xq, bool adc, bool calibrated,
                                        uint64_t image) const {
  Mat<double> y = Mat<double>::Zero(xq.rows(), x.blk.cols);
  if (slicing_.serial()) {
    Codes codes;
    slice_inputs<double>(xq, codes);
    ReadCurrents<double> cur;
    analog_of<double>(x, codes, 0, xq.rows(), cur, image);
    if (adc) adc_of<double>(x, cur);
    recover_of<double>(x, cur, y, 0, calibrated);
    return y;
  }
  Mat<double> cur = currents_of(x, xq, image);
  if (adc) adc_of<double, Eigen::MatrixXd>(x, cur, xq);
  recover_of<double>(x, cur, xq, y, 0, calibrated);
  return y;
}

#define XBARSIM_INSTANTIATE(S)                                                     \
  template void AnalogLayer::forward<S>(const RowMat<S>&, Mat<S>&, bool, uint64_t) const;    \
  template void AnalogLayer::dac_values<S>(S*, Eigen::Index) const;                \
  template void AnalogLayer::dac_inplace<S>(RowMat<S>&) const;                     \
  template void AnalogLayer::arrange_inputs<S>(RowMat<S>&) const;                  \
  template void AnalogLayer::analog<S>(int, const RowMat<S>&, Mat<S>&, uint64_t) const;      \
  template void AnalogLayer::adc_inplace<S>(int, Mat<S>&, const RowMat<S>&) const; \
  template void AnalogLayer::recover_add<S>(int, const Mat<S>&, const RowMat<S>&, Mat<S>&, bool) const;
XBARSIM_INSTANTIATE(float)
XBARSIM_INSTANTIATE(double)
#undef XBARSIM_INSTANTIATE

}  // namespace xbarsim
