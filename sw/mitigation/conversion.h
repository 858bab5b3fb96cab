#pragma once
/// Conversion (paper section "Mitigation algorithm"): program G' instead of the target G
/// so that the crossbar with parasitics computes (approximately) the ideal I = V * G.
#include <Eigen/Dense>

#include "sw/circuit/crossbar_params.h"
#include "sw/circuit/crossbar_solver.h"

namespace xbarsim {

/// Outcome of a conversion: the conductances to program and how many of them the
/// programmable range [g_min, g_max] could not hold (those are clipped).
struct ConversionResult {
  Eigen::MatrixXd g_prime;  ///< S, m x n, clipped to [g_min, g_max]
  int above_max = 0;        ///< cells that needed G' > g_max (or an infinite/negative G')
  int below_min = 0;        ///< cells that needed G' < g_min
  int undetermined = 0;     ///< cells with zero conversion current (kept at G)
  int iterations = 0;       ///< matrix conversion: fixed-point iterations
  double residual = 0;      ///< matrix conversion: max |G_eff(G') - T| / max T
  /// Matrix conversion with column scaling: per-column gain beta_j of the realised target
  /// T(:,j) = g_min + beta_j (G(:,j) - g_min). All ones otherwise. The digital recovery
  /// divides the weight part of column j by beta_j (see WeightMapping).
  Eigen::VectorXd column_gain;
  int out_of_range() const { return above_max + below_min; }
};

/// Signal conversion, exact and O(mn): with V_conv applied, every memristor must pass its
/// ideal current I_ij = V_conv,i * G_ij. With all cell currents fixed, the row-wire
/// currents (suffix sums along each row) and column-wire currents (prefix sums down each
/// column) are known, hence every node voltage, and each cell's G' follows from its device
/// model (linear, sinh; the transistor's V_M is solved from its own I-V). Cells whose G'
/// leaves [g_min, g_max] are clipped and counted.
ConversionResult convert_signal(const CrossbarParams& p, const Eigen::MatrixXd& g_target,
                                const Eigen::VectorXd& v_conv);
/// The same with the ideal currents I_ij = V_target,i * G_ij while V_conv is applied: with an
/// input pre-distortion (a DAC lookup table), V_conv = f^-1(x) and the target stays linear in x.
ConversionResult convert_signal(const CrossbarParams& p, const Eigen::MatrixXd& g_target, const Eigen::VectorXd& v_conv,
                                const Eigen::VectorXd& v_target);

/// Options of the matrix conversion.
struct MatrixConversionOptions {
  int max_iterations = 60;
  double tolerance = 1e-9;  ///< stop when max |G_eff - T| / max T falls below this
  double relaxation = 1.5;  ///< exponent of the multiplicative update (0 < omega < 2)
  /// Allow a per-column gain beta_j <= 1 on the weight part of the target so that every
  /// G' fits in [g_min, g_max] (IR drop needs G' > T; lowering the column's currents also
  /// lowers its IR drop). The gain is exact and removed digitally; it costs signal range.
  bool column_scaling = true;
};

/// Matrix conversion (beyond the paper): a single conversion signal is exact only for
/// inputs proportional to it. For linear devices the crossbar is exactly I = V * G_eff(G'),
/// so solve the inverse problem G_eff(G') = G for all inputs at once, with G' bounded to
/// [g_min, g_max]: a projected multiplicative fixed-point iteration
///   G' <- clip(G' .* T ./ G_eff(G')),   T = G (or its column-scaled version, see options),
/// started from the signal conversion with a constant signal. Each step costs one G_eff
/// (min(m, n) structured solves). Where the bounds are active the result is the bounded
/// fixed point and `residual` reports how far G_eff stays from G.
/// For nonlinear devices, `v_operating` (e.g. the mean calibration input) is used: the
/// circuit is linearised there (chord conductances) and the same iteration is run on the
/// linearised crossbar.
ConversionResult convert_matrix(const CrossbarParams& p, const SolverOptions& o, const Eigen::MatrixXd& g_target,
                                const Eigen::VectorXd& v_operating,
                                const MatrixConversionOptions& mo = MatrixConversionOptions{});

}  // namespace xbarsim
