#pragma once
/// Private to the analog layer's sources: a programmed crossbar and what programming reads.
#include <memory>
#include <type_traits>
#include <vector>

#include "sw/analog/analog_layer.h"

namespace xbarsim {

/// A crossbar after programming: the mapped weights, the conductances written (after
/// conversion and noise), the solver over them and what the forward stages use.
struct AnalogLayer::Crossbar : MappedWeights {
  /// The column of the crossbar's first row in the input matrices it reads: blk.row0 once
  /// programmed (inputs of the whole layer), 0 while programming (inputs of its own rows only,
  /// so that programming a layer costs no more than its crossbars' share of every input).
  int in0 = 0;
  Eigen::VectorXd beta;    ///< per physical column gain of matrix conversion (1 otherwise)
  Eigen::MatrixXd g_prog;  ///< S, programmed conductances
  std::unique_ptr<CrossbarSolver> solver;
  Eigen::MatrixXd geff_d;  ///< alpha * G_eff (A per input unit), linear devices
  Eigen::MatrixXf geff_f;  ///< the same in float for network inference
  /// Bit-serial reads (mostly zero digits): the same by rows, for sparse accumulation.
  AnalogLayer::RowMat<double> geff_rows_d;
  AnalogLayer::RowMat<float> geff_rows_f;
  /// A, per physical column (rows) and per read of an input vector (columns: one, or the
  /// input slices with converters.adc_range: per_read).
  Eigen::MatrixXd adc_lo, adc_hi;
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
  struct Readout {
    Eigen::MatrixXd adc_lo, adc_hi;
    Eigen::VectorXd adc_offset;
    ColumnFit fit;
    Crossbar::AdcTable<float> adc_f;
    Crossbar::AdcTable<double> adc_d;
  };
  std::vector<Readout> xbars;
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

}  // namespace xbarsim
