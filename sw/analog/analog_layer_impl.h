#pragma once
/// Private to the analog layer's sources: a programmed crossbar and what programming reads.
#include <memory>
#include <type_traits>
#include <algorithm>
#include <vector>

#include "sw/analog/analog_layer.h"
#include "sw/common/seed.h"

namespace xbarsim {

/// A crossbar after programming: the mapped weights, the conductances written (after
/// conversion and noise), the solver over them and what the forward stages use.
struct AnalogLayer::Crossbar : MappedWeights {
  /// The column of the crossbar's first row in the input matrices it reads: blk.row0 once
  /// programmed (inputs of the whole layer), 0 while programming (inputs of its own rows only,
  /// so that programming a layer costs no more than its crossbars' share of every input).
  int in0 = 0;
  int index = 0;         ///< the crossbar's index in the layer
  uint64_t stream = 0;   ///< its device stream: derive_seed(device.seed, {layer salt, index})
  Eigen::VectorXd beta;    ///< per physical column gain of matrix conversion (1 otherwise)
  Eigen::MatrixXd g_prog;  ///< S, the conductances the circuit holds now (installed)
  /// A device that moves after programming: the conductances asked for (after conversion) and
  /// those written (programming error, faults) at t = 0, from which every later state follows.
  Eigen::MatrixXd g_asked, g_written;
  FaultMap faults;         ///< stuck cells (empty without faults)
  /// Read noise of linear devices, first order in dG: a cell's fluctuation moves its column's
  /// current by s_ij dG_ij, s_ij = dI_j/dG_ij = V_i A_ij - I_j B_ij (the cell's voltage: its
  /// row's drive less its column's rise, times the network's transfer to the output; fitted
  /// per cell to the exact sensitivities at a few reads, see fit_read_noise). One read's column
  /// variance is then (x^2) p1 - 2 I (x p2) + I^2 p3, in input units x.
  AnalogLayer::RowMat<float> noise_p1, noise_p2;  ///< by rows: bit-serial reads add the rows of their digits
  Eigen::RowVectorXf noise_p3;
  Eigen::MatrixXd noise_points;  ///< the reads the model is fitted at (input units, reads x rows)
  /// Drift compensation: per physical column, the reference reads' summed current at t = 0
  /// (ref0) and the gain applied after the ADC (comp; empty = 1).
  Eigen::VectorXd ref0, comp;
  std::unique_ptr<CrossbarSolver> solver;
  Eigen::MatrixXd geff_d;  ///< alpha * G_eff (A per input unit), linear devices
  Eigen::MatrixXf geff_f;  ///< the same in float for network inference
  /// Bit-serial reads (mostly zero digits): the same by rows, for sparse accumulation.
  AnalogLayer::RowMat<double> geff_rows_d;
  AnalogLayer::RowMat<float> geff_rows_f;
  /// A, per physical column (rows) and per read of an input vector (columns: one, or the
  /// input slices with converters.adc_range: per_read).
  Eigen::MatrixXd adc_lo, adc_hi;
  /// The same shape: the extent (max - min) of the calibration currents each range was measured
  /// on (0 where the range is not measured) and the range before its margin.
  Eigen::MatrixXd adc_span, adc_chosen;
  Eigen::VectorXd adc_offset;  ///< per physical column: offset current per unit sum(X) removed before the ADC
  ColumnFit fit;
  /// For bit-serial reads, the ADC of every column and range (adc_lo, adc_hi) in the
  /// precision of the datapath: one column per range, contiguous over the physical columns.
  template <typename S>
  struct AdcTable {
    Eigen::Array<S, Eigen::Dynamic, Eigen::Dynamic> lo, hi, step, inv_step;
    Eigen::Array<S, Eigen::Dynamic, Eigen::Dynamic> on;  ///< 1 where the ADC quantizes, else 0
    std::vector<bool> all_on;                            ///< per range: every column quantizes
    Eigen::Array<S, Eigen::Dynamic, 1> offset;           ///< adc_offset
  };
  AdcTable<float> adc_f;
  AdcTable<double> adc_d;
  template <typename S>
  const AdcTable<S>& adc_table() const {
    if constexpr (std::is_same_v<S, float>)
      return adc_f;
    else
      return adc_d;
  }
  /// For bit-serial reads, per physical column: sign / (beta s), the recovery's factor.
  Eigen::ArrayXd recover_k;
};

/// What AnalogLayer::set_readout changes.
struct AnalogLayer::SavedReadout {
  AnalogConfig cfg;
  double time_s = 0;
  struct Readout {
    Eigen::MatrixXd adc_lo, adc_hi, adc_span, adc_chosen;
    Eigen::VectorXd adc_offset;
    ColumnFit fit;
    Crossbar::AdcTable<float> adc_f;
    Crossbar::AdcTable<double> adc_d;
    Eigen::VectorXd ref0, comp;
  };
  std::vector<Readout> xbars;
  Eigen::VectorXd bias;
};

/// What programming reads for the whole layer (DAC values, the crossbars' row order).
struct AnalogLayer::LayerInputs {
  Eigen::MatrixXd cal;      ///< calibration vectors
  Eigen::MatrixXd range_x;  ///< the ADC range-estimation reads
  Eigen::MatrixXd calib_q;  ///< the real inputs; may be empty
};

/// What the programming steps of one crossbar read.
struct AnalogLayer::ProgrammingInputs {
  Eigen::MatrixXd cal_b;          ///< calibration vectors (DAC values), this crossbar's rows
  Eigen::MatrixXd calib_b;        ///< real inputs (DAC values), this crossbar's rows; may be empty
  Eigen::MatrixXd range_b;        ///< the ADC range-estimation reads (DAC values), this crossbar's rows
  Eigen::MatrixXd ideal_partial;  ///< cal_b * W_block: the partial output calibration aims at
};

template <typename S>
void AnalogLayer::compensate(const Crossbar& x, S* cur, Eigen::Index reads, Eigen::Index ld, bool row_major) const {
  if (!x.comp.size()) return;
  for (Eigen::Index c = 0; c < x.pcols; ++c) {
    const S g = static_cast<S>(x.comp(c));
    for (Eigen::Index r = 0; r < reads; ++r) (row_major ? cur[r * ld + c] : cur[c * ld + r]) *= g;
  }
}

template <typename S, typename V>
void AnalogLayer::add_read_noise(const Crossbar& x, const V& values, S* cur, Eigen::Index ld, bool row_major,
                                 Eigen::Index first_read, uint64_t image, const float* pre_var,
                                 const float* pre_cross) const {
  const float ro2 = static_cast<float>(cfg_.converters.readout_noise_a * cfg_.converters.readout_noise_a);
  const bool device = x.noise_p1.size() > 0;
  if (!device && !(ro2 > 0)) return;
  const Eigen::Index reads = values.rows(), cols = x.pcols;
  const uint64_t key = device_.read_noise_key(image, salt_, static_cast<uint64_t>(x.index));
  // Everything in the currents' own layout (reads x columns, by row for bit-serial reads, by
  // column otherwise), so that every pass is contiguous.
  auto run = [&](auto order) {
    constexpr int Order = decltype(order)::value;
    using MF = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Order>;
    using MS = Eigen::Matrix<S, Eigen::Dynamic, Eigen::Dynamic, Order>;
    Eigen::Map<MS, 0, Eigen::OuterStride<>> i(cur, reads, cols, Eigen::OuterStride<>(ld));
    thread_local MF var, cross, z;
    thread_local std::vector<uint32_t> rk;
    // Per read and column: sigma, from the cells (var + I (I p3 - 2 cross), at least 0) and the readout.
    if (device) {
      if (pre_var) {  // the caller's sums (bit-serial reads: the rows of their digits)
        using RowF = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
        var = Eigen::Map<const RowF>(pre_var, reads, cols);
        cross = Eigen::Map<const RowF>(pre_cross, reads, cols);
      } else {
        var.noalias() = values.template cast<float>().array().square().matrix() * x.noise_p1;
        cross.noalias() = values.template cast<float>() * x.noise_p2;
      }
      const auto fi = i.template cast<float>().array();
      var = ((var.array() + fi * (fi.rowwise() * x.noise_p3.array() - 2.0f * cross.array())).max(0.0f) + ro2).sqrt();
    } else {
      var.setConstant(reads, cols, std::sqrt(ro2));
    }
    // Read r's draw for column c: read_normals(key, first_read + r, ...)[c], in either layout.
    z.resize(reads, cols);
    rk.resize(static_cast<size_t>(reads));
    for (Eigen::Index r = 0; r < reads; ++r) rk[static_cast<size_t>(r)] = read_stream(key, static_cast<uint64_t>(first_read + r));
    if constexpr (Order == Eigen::RowMajor) {
      // A read that moves no charge (no digit on this crossbar's rows, no readout noise) has no
      // fluctuation either: its draws are not needed (bit-serial reads: high bit planes are often empty).
      for (Eigen::Index r = 0; r < reads; ++r) {
        if (ro2 == 0 && device && !(var.row(r).maxCoeff() > 0)) continue;
        normals_of_read(rk[static_cast<size_t>(r)], cols, z.row(r).data());
        i.row(r) += (var.row(r).array() * z.row(r).array()).matrix().template cast<S>();
      }
    } else {
      for (Eigen::Index c = 0; c < cols; ++c) normals_of_column(rk.data(), reads, static_cast<uint32_t>(c), z.col(c).data());
      i += (var.array() * z.array()).matrix().template cast<S>();
    }
  };
  if (row_major)
    run(std::integral_constant<int, Eigen::RowMajor>{});
  else
    run(std::integral_constant<int, Eigen::ColMajor>{});
}

}  // namespace xbarsim
