#pragma once
/// Calibration (paper section "Calibration"): a per-column first-order fit from crossbar
/// output to ideal output over a few calibration vectors, applied digitally.
#include <Eigen/Dense>

#include <cstdint>
#include <vector>

namespace xbarsim {

struct ColumnFit {
  Eigen::VectorXd gain;    ///< per column
  Eigen::VectorXd offset;  ///< per column: corrected = gain * actual + offset
  Eigen::Array<bool, Eigen::Dynamic, 1> gain_fitted;  ///< per column: the gain was fitted (else 1)
  Eigen::MatrixXd apply(const Eigen::MatrixXd& actual) const;
};

/// A gain is fitted only when the actual outputs take at least this many resolved values.
constexpr int kMinDistinctOutputs = 3;
/// ... and only when the fitted gain's standard error is at most this.
constexpr double kMaxGainStandardError = 1.0;
/// ... and only when it differs from 1 by more than this many standard errors.
constexpr double kGainSignificance = 2.0;

/// Least-squares fit actual ~ a * ideal + b per column (closed form; the errors are in the
/// actual outputs, so regressing the other way would attenuate the gain), inverted to
/// corrected = gain * actual + offset (gain = 1 / a), where the calibration data determine a
/// gain that differs from 1 by more than kGainSignificance standard errors; elsewhere gain 1
/// and the mean difference as offset
/// (docs/physics.md, "Calibration"). `step` (per column, output units; empty = no ADC) is the
/// actual outputs' resolution: one ADC code, combined over the column's reads and physical
/// columns. The gain is fitted when the actual outputs take at least kMinDistinctOutputs
/// values more than half a step apart (a line through two points always fits, and a column
/// whose outputs sit in one or two codes says nothing about its gain) and its standard error,
/// with the ADC's quantization variance step^2 / 12 added to the residuals', is at most
/// kMaxGainStandardError (a gain known no better than +-1 is not known at all).
ColumnFit fit_columns(const Eigen::MatrixXd& actual, const Eigen::MatrixXd& ideal,
                      const Eigen::VectorXd& step = Eigen::VectorXd());

/// Identity fit (no calibration) for n columns.
ColumnFit identity_fit(int n);

/// How many calibration vectors eval samples from each calibration image when it may keep
/// `max_samples` in all over `images` images (it keeps the first `max_samples` in image order).
int calibration_rows_per_image(int max_samples, int images);

/// Which of an image's `rows` im2col rows eval samples to calibrate linear layer `layer` (its
/// place among the network's Conv/Gemm layers): `count` picks (with repetition), the layer's
/// block of `count` draws from the stream derived from `seed` (calibration.seed) and the
/// image's index in the calibration set. One definition for every caller, so a layer
/// programmed from Python sees the same vectors as eval's.
std::vector<Eigen::Index> calibration_row_picks(uint64_t seed, int image, int layer, Eigen::Index rows, int count);

}  // namespace xbarsim
