#include "sw/circuit/spice_netlist.h"

#include <cmath>
#include <cstdio>
#include <sstream>

#include "sw/circuit/device_models.h"
#include "sw/common/errors.h"

namespace xbarsim {

namespace {
std::string num(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}
}  // namespace

void write_spice_netlist(std::ostream& out, const CrossbarParams& p, const Eigen::MatrixXd& g_s,
                         const Eigen::MatrixXd& inputs) {
  const int m = static_cast<int>(g_s.rows()), n = static_cast<int>(g_s.cols());
  if (inputs.cols() != m) throw InputError("netlist: input vectors must have one voltage per crossbar row");
  if (inputs.rows() < 1) throw InputError("netlist: at least one input vector is needed");
  const bool short_tr = p.transistor.model == TransistorModel::None;
  out << "* xbarsim crossbar " << m << "x" << n << " memristor=" << to_string(p.memristor.model)
      << " transistor=" << to_string(p.transistor.model) << " sensing=" << to_string(p.sensing) << "\n";
  out << ".options reltol=1e-10 abstol=1e-18 vntol=1e-15 gmin=1e-30 itl1=500\n";
  if (p.transistor.model == TransistorModel::Level1) {
    out << ".model xnmos nmos level=1 vto=" << num(p.transistor.vth_v) << " kp=" << num(p.transistor.kp_a_per_v2)
        << " lambda=0 gamma=0 is=0\n";
    out << "vgate gate 0 dc " << num(p.transistor.vg_v) << "\n";
  }
  for (int i = 0; i < m; ++i) {
    out << "vin_" << i << " in_" << i << " 0 dc " << num(inputs(0, i)) << "\n";
    out << "rin_" << i << " in_" << i << " l_" << i << " " << num(p.r_in_ohm) << "\n";
    out << "rw_l_" << i << " l_" << i << " t_" << i << "_0 " << num(p.r_wire_ohm) << "\n";
    for (int j = 0; j + 1 < n; ++j)
      out << "rw_t_" << i << "_" << j << " t_" << i << "_" << j << " t_" << i << "_" << j + 1 << " "
          << num(p.r_wire_ohm) << "\n";
    out << "rw_r_" << i << " t_" << i << "_" << n - 1 << " r_" << i << " " << num(p.r_wire_ohm) << "\n";
  }
  for (int j = 0; j < n; ++j) {
    out << "rw_u_" << j << " u_" << j << " b_0_" << j << " " << num(p.r_wire_ohm) << "\n";
    for (int i = 0; i + 1 < m; ++i)
      out << "rw_b_" << i << "_" << j << " b_" << i << "_" << j << " b_" << i + 1 << "_" << j << " "
          << num(p.r_wire_ohm) << "\n";
    out << "rw_d_" << j << " b_" << m - 1 << "_" << j << " d_" << j << " " << num(p.r_wire_ohm) << "\n";
    out << "rout_" << j << " d_" << j << " s_" << j << " " << num(p.r_out_ohm) << "\n";
    // Voltage sensing: s_j has nothing else on it (the sampling capacitor, open at DC); the
    // column still has a DC path to ground through its cells and the row drivers.
    if (!p.voltage_sensing()) out << "vsense_" << j << " s_" << j << " 0 dc 0\n";
  }
  const double sinh_scale = MemristorDevice(p.memristor).scale();
  for (int i = 0; i < m; ++i)
    for (int j = 0; j < n; ++j) {
      const std::string t = "t_" + std::to_string(i) + "_" + std::to_string(j);
      const std::string b = "b_" + std::to_string(i) + "_" + std::to_string(j);
      const std::string mid = short_tr ? b : "m_" + std::to_string(i) + "_" + std::to_string(j);
      const std::string id = std::to_string(i) + "_" + std::to_string(j);
      if (p.memristor.model == MemristorModel::Linear)
        out << "rm_" << id << " " << t << " " << mid << " " << num(1.0 / g_s(i, j)) << "\n";
      else
        out << "bm_" << id << " " << t << " " << mid << " i = " << num(g_s(i, j) * sinh_scale) << "*sinh("
            << num(p.memristor.k_per_v) << "*(v(" << t << ")-v(" << mid << ")))\n";
      if (p.transistor.model == TransistorModel::Linear)
        out << "rt_" << id << " " << mid << " " << b << " " << num(p.transistor.r_on_ohm) << "\n";
      else if (p.transistor.model == TransistorModel::Level1)
        out << "mt_" << id << " " << mid << " gate " << b << " 0 xnmos w=1u l=1u\n";
    }
  out << ".control\nset numdgt=17\n";
  for (Eigen::Index k = 0; k < inputs.rows(); ++k) {
    if (k > 0)
      for (int i = 0; i < m; ++i) out << "alter vin_" << i << " dc = " << num(inputs(k, i)) << "\n";
    out << "op\necho xbarsim_vector " << k << "\nprint";
    for (int j = 0; j < n; ++j) out << (p.voltage_sensing() ? " v(s_" : " i(vsense_") << j << ")";
    out << "\n";
  }
  out << ".endc\n.end\n";
}

namespace {
/// The values printed as `<name>K) = value` (e.g. "i(vsense_3) = ...") of each vector.
Eigen::MatrixXd parse_ngspice_prints(const std::string& output, int vectors, int cols, const char* format,
                                     const char* what) {
  Eigen::MatrixXd out = Eigen::MatrixXd::Constant(vectors, cols, std::nan(""));
  std::istringstream in(output);
  std::string line;
  int k = -1;
  while (std::getline(in, line)) {
    if (line.rfind("xbarsim_vector ", 0) == 0) {
      k = std::stoi(line.substr(15));
      continue;
    }
    if (k < 0 || k >= vectors) continue;
    int j;
    char rest[64];
    double v;
    if (std::sscanf(line.c_str(), format, &j, &v, rest) >= 2 && j >= 0 && j < cols) out(k, j) = v;
  }
  for (int r = 0; r < vectors; ++r)
    for (int c = 0; c < cols; ++c)
      if (std::isnan(out(r, c)))
        throw SolverError(std::string("ngspice output lacks the ") + what + " of column " + std::to_string(c) +
                          " for vector " + std::to_string(r));
  return out;
}
}  // namespace

Eigen::MatrixXd parse_ngspice_currents(const std::string& output, int vectors, int cols) {
  return parse_ngspice_prints(output, vectors, cols, " i(vsense_%d) = %lf%63s", "current");
}

Eigen::MatrixXd parse_ngspice_voltages(const std::string& output, int vectors, int cols) {
  return parse_ngspice_prints(output, vectors, cols, " v(s_%d) = %lf%63s", "voltage");
}

}  // namespace xbarsim
