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
  Eigen::MatrixXd apply(const Eigen::MatrixXd& actual) const;
};

/// Least-squares fit ideal ~ gain * actual + offset per column (closed form). A column
/// whose actual outputs do not vary gets gain 1 and the mean difference as offset.
ColumnFit fit_columns(const Eigen::MatrixXd& actual, const Eigen::MatrixXd& ideal);

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
