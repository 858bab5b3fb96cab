#pragma once
// One training step's draw of a layer for xbarsim.nn's fast training path
// (python/xbarsim/nn.py, docs/python.md "Hardware-aware training"): the weights as eval maps
// them, programmed (and drifted) by the device model, read back per crossbar column with the
// compensation's and calibration's gains, as weight deviations and read variances.

#include <Eigen/Dense>
#include <cstdint>
#include <vector>

#include "sw/analog/analog_layer.h"
#include "sw/analog/weight_mapping.h"
#include "sw/device/device.h"

namespace xbarsim {

/// The drift compensation the training forward applies: none, one gain per layer (global) or
/// one per physical column (column, recalibrate).
enum class TrainingGain { None, Global, Column };

struct TrainingDrawSpec {
  bool device = false;         ///< program (and drift) the cells through the device model
  double time_s = 0;           ///< seconds after programming the step reads at
  uint64_t layer = 0;          ///< the device stream's layer key
  uint64_t step = 0;           ///< crossbar b's key: (step << 20) + b
  TrainingGain gain = TrainingGain::None;
  bool read_noise = false;     ///< form the read variances (device's read sigma, readout noise)
  double readout_noise_a = 0;  ///< converters.readout_noise_na in A
  double v_in_max = 1;         ///< crossbar.v_in_max (V)
  double noise_scale = 1;      ///< deviations x this, variances x its square
};

struct TrainingBlock {
  int r0 = 0, rows = 0, c0 = 0, cols = 0;
  Eigen::VectorXd readout_var;  ///< per weight column (output units at x_max = 1); empty: none
};

struct TrainingDraw {
  Eigen::MatrixXd delta;        ///< held weight - weight (inputs x outputs, eval's row order)
  Eigen::MatrixXd sigma2;       ///< one read's variance per weight (empty without read noise)
  Eigen::VectorXd readout_var;  ///< the readout's variance per output column, summed over blocks
  Eigen::VectorXd offset;       ///< calibration's offsets per output column, summed over blocks
  std::vector<TrainingBlock> blocks;
  std::vector<WeightRanges> ranges;  ///< the weight ranges mapped with, per block
};

/// Draws one step of layer `w` (inputs x outputs): mapped with `ranges` (per block; null: the
/// ranging search of eval), programmed, read at spec.time_s with the compensation's gains, then
/// (calib_rows non-empty: calibration vectors x inputs, as the DAC applies them) each
/// crossbar column's least-squares gain and offset of eval's calibration.
TrainingDraw training_draw(const AnalogConfig& cfg, const Device& device, const Eigen::MatrixXd& w,
                           const std::vector<WeightRanges>* ranges, const Eigen::MatrixXd& calib_rows,
                           const TrainingDrawSpec& spec);

}  // namespace xbarsim
