#include "sw/analog/weight_mapping.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace xbarsim {

namespace {

/// A cell variance tabulated on the conductance span (linear interpolation): the searches
/// evaluate it for every weight and candidate clip.
struct VarianceTable {
  double g0 = 0, dg = 1;
  std::vector<double> v;
  VarianceTable(const CellVariance& var, double g_min, double g_top) {
    if (!var) return;
    constexpr int kPoints = 256;
    g0 = g_min;
    dg = (g_top - g_min) / kPoints;
    v.resize(kPoints + 1);
    for (int k = 0; k <= kPoints; ++k) v[static_cast<size_t>(k)] = var(g0 + k * dg);
  }
  bool on() const { return !v.empty(); }
  double at(double g) const {
    const double u = std::clamp((g - g0) / dg, 0.0, static_cast<double>(v.size() - 1));
    const size_t k = std::min(static_cast<size_t>(u), v.size() - 2);
    const double f = u - static_cast<double>(k);
    return v[k] + f * (v[k + 1] - v[k]);
  }
};

/// The summed squared error of n weights of one scale group held with the range [lo, hi] of its
/// columns (map_weights' rules): each polarity's code (rounded, clipped), its slices as cell
/// levels, and every cell's variance in weight units.
double held_error(const double* w, Eigen::Index n, double lo, double hi, const MappingSpec& mapping, double g_span,
                  double g_min, const VarianceTable& var) {
  const bool diff = mapping.differential();
  const int P = mapping.polarities(), T = mapping.weight_slices(), q_bits = mapping.code_bits(),
            cb = mapping.cell_bits;
  const double range = diff ? std::max({-lo, std::abs(hi), 1e-300}) : (hi - lo > 0 ? hi - lo : 1.0);
  const double top = diff ? range : lo + range;
  const double code_max = q_bits ? std::ldexp(1.0, q_bits) - 1 : 0;
  const double dw = q_bits ? range / code_max : 0;
  // Weight units per siemens of slice t's cell (its place), and of an unsliced cell.
  double u[32];
  const double level_span = cb ? std::ldexp(1.0, cb) - 1 : 1.0;
  for (int t = 0; t < T && t < 32; ++t)
    u[t] = T > 1 ? std::ldexp(dw, t * cb) * level_span / g_span : range / g_span;
  double idle = 0;  // the variance of a polarity's cells at g_min (nothing of the weight on them)
  if (var.on())
    for (int t = 0; t < T; ++t) idle += var.at(g_min) * u[t] * u[t];
  double e = 0;
  for (Eigen::Index i = 0; i < n; ++i) {
    const double v = std::clamp(w[i], diff ? -range : lo, top);
    double held = diff ? 0.0 : lo, noise = 0;
    for (int p = 0; p < P; ++p) {
      const double a = diff ? (p == 0 ? std::max(v, 0.0) : std::max(-v, 0.0)) : v - lo;
      if (diff && a == 0) {
        noise += idle;
        continue;
      }
      double rep = a;
      long code = 0;
      if (q_bits) {
        code = static_cast<long>(std::min(std::floor(a / dw + 0.5), code_max));
        rep = code * dw;
      }
      held += p == 1 ? -rep : rep;
      if (!var.on()) continue;
      if (T == 1) {
        noise += var.at(g_min + rep / range * g_span) * u[0] * u[0];
      } else {
        for (int t = 0; t < T; ++t) {
          const long digit = (code >> (t * cb)) & ((1L << cb) - 1);
          noise += var.at(g_min + digit * g_span / level_span) * u[t] * u[t];
        }
      }
    }
    e += (w[i] - held) * (w[i] - held) + noise;
  }
  return e;
}

}  // namespace

WeightRanges weight_ranges(const Eigen::MatrixXd& w, const MappingSpec& mapping, const RangingSpec& ranging,
                           const CrossbarParams& xbar, const CellVariance& var) {
  const double g_span = xbar.g_max_s * (1 - mapping.g_headroom) - xbar.g_min_s;
  WeightRanges r;
  const Eigen::Index cols = w.cols(), rows = w.rows();
  r.lo.resize(cols);
  r.hi.resize(cols);
  const bool per_column = ranging.weight_scale == WeightScale::Column;
  const VarianceTable table(ranging.weights == RangeMethod::Mse ? var : CellVariance(), xbar.g_min_s,
                            xbar.g_min_s + g_span);
  const bool quantized = mapping.code_bits() > 0;
  for (Eigen::Index j0 = 0; j0 < cols; j0 += per_column ? 1 : cols) {
    const Eigen::Index n = per_column ? 1 : cols;
    const auto group = w.middleCols(j0, n);
    // The shift's rules: the offset min(w, 0), the top max w; a pair's magnitude max |w|.
    const double lo_nat = std::min(group.minCoeff(), 0.0), hi_nat = group.maxCoeff();
    const double mag_max = group.cwiseAbs().maxCoeff();
    double c = mag_max;
    switch (ranging.weights) {
      case RangeMethod::Max:
        break;
      case RangeMethod::Percentile: {
        std::vector<double> mags(static_cast<size_t>(group.size()));
        Eigen::Map<Eigen::MatrixXd>(mags.data(), rows, n) = group.cwiseAbs();
        const double p = percentile_of(mags, ranging.weight_percentile);
        if (p > 0) c = p;
        break;
      }
      case RangeMethod::Mse: {
        if (!quantized && !table.on()) break;  // exact cells, no code: nothing to gain by clipping
        // The group's weights in one contiguous block (a column, or all of them).
        const Eigen::MatrixXd g = group;
        c = search_clip(mag_max, [&](double clip) {
          return held_error(g.data(), g.size(), std::max(lo_nat, -clip), std::min(hi_nat, clip), mapping, g_span,
                            xbar.g_min_s, table);
        });
        break;
      }
    }
    const double lo = std::max(lo_nat, -c), hi = c < mag_max ? std::min(hi_nat, c) : hi_nat;
    r.lo.segment(j0, n).setConstant(lo);
    r.hi.segment(j0, n).setConstant(hi);
    r.clipped += ((group.array() < lo) || (group.array() > hi)).count();
  }
  return r;
}

MappedWeights map_weights(const Eigen::MatrixXd& wb, const Block& blk, const MappingSpec& mapping,
                          const CrossbarParams& xbar, const WeightRanges& ranges) {
  MappedWeights m;
  m.blk = blk;
  // Conductance span for weights; the headroom above it is left for conversion.
  const double g_span = xbar.g_max_s * (1 - mapping.g_headroom) - xbar.g_min_s;
  const int P = mapping.polarities(), T = mapping.weight_slices(), q_bits = mapping.code_bits();
  m.per_weight = P * T;
  m.pcols = mapping.physical_columns(blk.cols);
  m.offset_has_w_lo = !mapping.differential() && mapping.cell_bits == 0;
  // Each polarity as a non-negative matrix in weight units (clipped to its column's range), and
  // the range each column spans.
  const WeightRanges own = ranges.lo.size() ? WeightRanges{} : weight_ranges(wb, mapping, RangingSpec{}, xbar);
  const WeightRanges& rg = ranges.lo.size() ? ranges : own;
  if (rg.lo.size() != wb.cols() || rg.hi.size() != wb.cols())
    throw std::invalid_argument("map_weights: ranges of another number of columns");
  Eigen::MatrixXd pol[2];
  Eigen::VectorXd range(blk.cols);
  if (mapping.differential()) {
    for (int j = 0; j < blk.cols; ++j) range(j) = std::max({-rg.lo(j), std::abs(rg.hi(j)), 1e-300});
    pol[0] = wb.cwiseMax(0.0);
    pol[1] = (-wb).cwiseMax(0.0);
    for (int j = 0; j < blk.cols; ++j)
      for (int p = 0; p < 2; ++p) pol[p].col(j) = pol[p].col(j).cwiseMin(range(j));
  } else {
    m.w_lo = rg.lo.minCoeff();  // one offset for the crossbar: sum(X) removes it from every column
    pol[0].resize(wb.rows(), wb.cols());
    for (int j = 0; j < blk.cols; ++j) {
      range(j) = rg.hi(j) - m.w_lo;
      const double top = range(j) > 0 ? rg.hi(j) : m.w_lo + 1.0;
      if (!(range(j) > 0)) range(j) = 1.0;
      pol[0].col(j) = (wb.col(j).array().max(m.w_lo).min(top) - m.w_lo).matrix();
    }
  }
  const double code_max = q_bits ? std::ldexp(1.0, q_bits) - 1 : 0;
  m.a.setZero(blk.rows, m.pcols);
  m.s.resize(m.pcols);
  m.sign.setOnes(m.pcols);
  for (int j = 0; j < blk.cols; ++j)
    for (int p = 0; p < P; ++p) {
      const int c0 = (j * P + p) * T;
      const double dw = q_bits ? range(j) / code_max : 0;  // weight units per code
      m.s.segment(c0, T).setConstant(g_span / range(j));
      if (p == 1) m.sign.segment(c0, T).setConstant(-1.0);
      if (!q_bits) {
        m.a.col(c0) = pol[p].col(j);
        continue;
      }
      for (int r = 0; r < blk.rows; ++r) {
        const long code = static_cast<long>(std::min(std::floor(pol[p](r, j) / dw + 0.5), code_max));
        if (T == 1) {
          m.a(r, c0) = code * dw;
          continue;
        }
        for (int t = 0; t < T; ++t) {
          const long digit = (code >> (t * mapping.cell_bits)) & ((1L << mapping.cell_bits) - 1);
          m.a(r, c0 + t) = std::ldexp(dw, t * mapping.cell_bits) * digit;
        }
      }
      // Slice t's cell holds its digit as a level: g - g_min = digit x g_span / (2^cell_bits - 1).
      if (T > 1)
        for (int t = 0; t < T; ++t)
          m.s(c0 + t) = g_span / (std::ldexp(1.0, mapping.cell_bits) - 1) / std::ldexp(dw, t * mapping.cell_bits);
    }
  if (mapping.analog_sum()) {
    const int c = m.pcols - 1;
    m.s(c) = g_span / range.maxCoeff();
    // Mid-range conductance; with multi-level cells the level 2^(cell_bits - 1).
    const double fraction =
        mapping.cell_bits ? std::ldexp(1.0, mapping.cell_bits - 1) / (std::ldexp(1.0, mapping.cell_bits) - 1) : 0.5;
    m.a_sum = fraction * g_span / m.s(c);
    m.a.col(c).setConstant(m.a_sum);
  }
  m.g_target = ((m.a * m.s.asDiagonal()).array() + xbar.g_min_s).matrix();
  return m;
}

std::vector<Block> crossbar_blocks(int rows, int cols, const MappingSpec& mapping) {
  return partition(rows, cols, mapping.max_rows, mapping.logical_columns_per_crossbar());
}

}  // namespace xbarsim
