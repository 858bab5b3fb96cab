#include "sw/analog/training_draw.h"

#include <algorithm>
#include <cmath>

#include "sw/common/seed.h"
#include "sw/common/errors.h"

namespace xbarsim {

namespace {

/// eval's calibration of one crossbar's weight columns (docs/physics.md, calibration): per
/// column the gain and offset mapping the outputs on `x` of the held weights to the ideal ones
/// (least squares); a column whose outputs do not vary keeps gain 1 and gets its offset only.
void calibration_fit(const Eigen::MatrixXd& x, const Eigen::MatrixXd& w_ideal, const Eigen::MatrixXd& w_cells,
                     Eigen::VectorXd& gain, Eigen::VectorXd& offset) {
  const Eigen::MatrixXd ideal = x * w_ideal, measured = x * w_cells;
  const Eigen::Index n = x.rows(), cols = w_ideal.cols();
  gain.resize(cols);
  offset.resize(cols);
  for (Eigen::Index j = 0; j < cols; ++j) {
    const double m_mean = measured.col(j).mean(), i_mean = ideal.col(j).mean();
    const Eigen::ArrayXd dm = measured.col(j).array() - m_mean;
    const double var = dm.square().sum(), cov = (dm * (ideal.col(j).array() - i_mean)).sum();
    const double scale = std::max(measured.col(j).cwiseAbs().maxCoeff(), 1e-300);
    gain(j) = var > 1e-24 * scale * scale * static_cast<double>(n) ? cov / var : 1.0;
    offset(j) = i_mean - gain(j) * m_mean;
  }
}

}  // namespace

TrainingDraw training_draw(const AnalogConfig& cfg, const Device& device, const Eigen::MatrixXd& w,
                           const std::vector<WeightRanges>* ranges, const Eigen::MatrixXd& calib_rows,
                           const TrainingDrawSpec& spec) {
  if (w.rows() < 1 || w.cols() < 1) throw InputError("training draw: the weight matrix is empty");
  if (!w.allFinite()) throw InputError("training draw: the weight matrix holds a non-finite value");
  if (calib_rows.size() && calib_rows.cols() != w.rows())
    throw InputError("training draw: the calibration vectors have " + std::to_string(calib_rows.cols()) +
                     " inputs, the layer " + std::to_string(w.rows()));
  const std::vector<Block> blocks = crossbar_blocks(static_cast<int>(w.rows()), static_cast<int>(w.cols()), cfg.mapping);
  TrainingDraw out;
  if (ranges) {
    if (ranges->size() != blocks.size())
      throw InputError("training draw: ranges for " + std::to_string(ranges->size()) + " blocks, the layer has " +
                       std::to_string(blocks.size()));
    out.ranges = *ranges;
  } else {
    out.ranges = AnalogLayer(cfg, w, 1.0, false).block_ranges();
  }
  const double g_min = device.spec().g_min_s;
  const size_t nb = blocks.size();
  std::vector<MappedWeights> mapped(nb);
  std::vector<Eigen::MatrixXd> held(nb);
  const bool drifts = spec.device && spec.time_s > 0;
  double want = 0, have = 0;
  for (size_t b = 0; b < nb; ++b) {
    const Block& blk = blocks[b];
    if (out.ranges[b].lo.size() != blk.cols || out.ranges[b].hi.size() != blk.cols)
      throw InputError("training draw: the ranges of block " + std::to_string(b) + " do not match its columns");
    mapped[b] = map_weights(w.block(blk.row0, blk.col0, blk.rows, blk.cols), blk, cfg.mapping, cfg.xbar, out.ranges[b]);
    const int weight_cols = blk.cols * mapped[b].per_weight;  // the sum(X) column, if any, follows them
    mapped[b].g_target = Eigen::MatrixXd(mapped[b].g_target.leftCols(weight_cols));
    Eigen::MatrixXd h = mapped[b].g_target;
    if (spec.device) {
      const uint64_t stream = derive_seed(device.spec().seed, {spec.layer, (spec.step << 20) + b});
      FaultMap faults;
      device.program(h, faults, stream);
      if (spec.time_s > 0) {
        FaultMap f;
        device.place_faults(f, h.rows(), h.cols(), stream);
        h = device.at_time(mapped[b].g_target, h, f, spec.time_s, stream);
      }
    }
    if (drifts && spec.gain == TrainingGain::Global) {
      want += (mapped[b].g_target.array() - g_min).sum();
      have += (h.array() - g_min).sum();
    }
    held[b] = std::move(h);
  }
  const double global = have > 0 ? want / have : 1.0;
  const Eigen::Index K = w.rows(), N = w.cols();
  out.delta = Eigen::MatrixXd::Zero(K, N);
  const bool noisy = spec.read_noise;
  if (noisy) out.sigma2 = Eigen::MatrixXd::Zero(K, N);
  out.readout_var = Eigen::VectorXd::Zero(N);
  out.offset = Eigen::VectorXd::Zero(N);
  const bool calibrates = calib_rows.size() > 0;
  for (size_t b = 0; b < nb; ++b) {
    const Block& blk = blocks[b];
    const MappedWeights& m = mapped[b];
    const Eigen::MatrixXd& h = held[b];
    const int per = m.per_weight, pc = blk.cols * per;
    // weight units per siemens, per physical column, times the readout's compensation gain
    Eigen::VectorXd scale = m.sign.head(pc).cwiseQuotient(m.s.head(pc));
    if (drifts && spec.gain == TrainingGain::Global) scale *= global;
    if (drifts && spec.gain == TrainingGain::Column)
      for (int c = 0; c < pc; ++c) {
        const double wc = (m.g_target.col(c).array() - g_min).sum(), hc = (h.col(c).array() - g_min).sum();
        if (hc > 0) scale(c) *= wc / hc;
      }
    Eigen::MatrixXd w_cells = Eigen::MatrixXd::Constant(blk.rows, blk.cols, m.w_lo);
    for (int j = 0; j < blk.cols; ++j)
      for (int t = 0; t < per; ++t) w_cells.col(j) += (h.col(j * per + t).array() - g_min).matrix() * scale(j * per + t);
    const Eigen::MatrixXd w_block = w.block(blk.row0, blk.col0, blk.rows, blk.cols);
    if (calibrates) {
      Eigen::VectorXd gain, offset;
      calibration_fit(calib_rows.middleCols(blk.row0, blk.rows), w_block, w_cells, gain, offset);
      w_cells *= gain.asDiagonal();
      for (int j = 0; j < blk.cols; ++j) scale.segment(j * per, per) *= gain(j);
      out.offset.segment(blk.col0, blk.cols) += offset;
    }
    out.delta.block(blk.row0, blk.col0, blk.rows, blk.cols) = w_cells - w_block;
    TrainingBlock tb{blk.row0, blk.rows, blk.col0, blk.cols, {}};
    if (noisy) {
      const bool reads = device.spec().has_read_noise();
      const Eigen::MatrixXd sig = reads ? device.read_sigma(h) : Eigen::MatrixXd::Zero(h.rows(), h.cols());
      auto dst = out.sigma2.block(blk.row0, blk.col0, blk.rows, blk.cols);
      for (int j = 0; j < blk.cols; ++j)
        for (int t = 0; t < per; ++t) {
          const double s2 = scale(j * per + t) * scale(j * per + t);
          dst.col(j) += (sig.col(j * per + t).array().square() * s2).matrix();
        }
      if (spec.readout_noise_a > 0) {
        tb.readout_var = Eigen::VectorXd::Zero(blk.cols);
        for (int j = 0; j < blk.cols; ++j)
          for (int t = 0; t < per; ++t) tb.readout_var(j) += std::pow(spec.readout_noise_a * scale(j * per + t) / spec.v_in_max, 2);
        out.readout_var.segment(blk.col0, blk.cols) += tb.readout_var;
      }
    }
    out.blocks.push_back(std::move(tb));
  }
  if (spec.noise_scale != 1) {
    out.delta *= spec.noise_scale;
    if (noisy) out.sigma2 *= spec.noise_scale * spec.noise_scale;
  }
  return out;
}

}  // namespace xbarsim
