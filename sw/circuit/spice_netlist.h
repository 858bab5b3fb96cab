#pragma once
/// SPICE netlist of the crossbar circuit, for ngspice as the independent reference.
/// Node names: in_i (ideal source), l_i, t_i_j, m_i_j, b_i_j, r_i, u_j, d_j, s_j; column
/// current I_j is measured by the 0 V source vsense_j in series with r_out (from s_j to
/// ground). With voltage sensing s_j is left open (no vsense_j) and its voltage is the output.
#include <Eigen/Dense>
#include <ostream>
#include <string>

#include "sw/circuit/crossbar_params.h"

namespace xbarsim {

/// Writes the netlist with a .control block that runs one operating point per input
/// vector (rows of `inputs`, k x m) and prints its n column currents (voltage sensing: the
/// column voltages v(s_j)) with one `print` command per vector, between "xbarsim_vector K"
/// echo markers.
/// Memristor sinh -> behavioural current source; level1 -> level-1 NMOS (W = L, is = 0).
void write_spice_netlist(std::ostream& out, const CrossbarParams& p, const Eigen::MatrixXd& g_s,
                         const Eigen::MatrixXd& inputs);

/// Parses ngspice's batch output of such a netlist into k x n column currents (A).
/// Throws SolverError if a vector or current is missing.
Eigen::MatrixXd parse_ngspice_currents(const std::string& output, int vectors, int cols);
/// The same for a voltage-sensing netlist: k x n column voltages (V).
Eigen::MatrixXd parse_ngspice_voltages(const std::string& output, int vectors, int cols);

}  // namespace xbarsim
