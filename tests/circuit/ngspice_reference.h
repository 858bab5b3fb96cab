#pragma once
// ngspice (Debian package) as the independent circuit reference: run a netlist, read the currents.
#include <array>
#include <cstdio>
#include <fstream>
#include <string>
#include <unistd.h>

#include "sw/circuit/crossbar_params.h"
#include "sw/circuit/spice_netlist.h"

namespace xbarsim::testing_ngspice {

inline std::string run(const std::string& cmd) {
  std::string out;
  FILE* p = popen(cmd.c_str(), "r");
  if (!p) return out;
  std::array<char, 4096> buf;
  while (fgets(buf.data(), buf.size(), p)) out += buf.data();
  pclose(p);
  return out;
}

inline bool have_ngspice() { return run("command -v ngspice").find("ngspice") != std::string::npos; }

/// ngspice's column outputs (vectors x columns) of conductances g under row voltages v: the
/// currents (A), or with p.sensing = voltage the column voltages (V).
inline Eigen::MatrixXd ngspice_outputs(const CrossbarParams& p, const Eigen::MatrixXd& g, const Eigen::MatrixXd& v) {
  const std::string path = "/tmp/xbarsim_ngspice_" + std::to_string(g.rows()) + "x" + std::to_string(g.cols()) + "_" +
                           to_string(p.memristor.model) + "_" + to_string(p.transistor.model) + "_" +
                           to_string(p.sensing) + "_" + std::to_string(::getpid()) + ".cir";
  {
    std::ofstream f(path);
    write_spice_netlist(f, p, g, v);
  }
  // stderr apart: ngspice's notes there would interleave with the printed values.
  const std::string out = run("ngspice -b " + path + " 2>/dev/null");
  std::remove(path.c_str());
  const int k = static_cast<int>(v.rows()), n = static_cast<int>(g.cols());
  return p.voltage_sensing() ? parse_ngspice_voltages(out, k, n) : parse_ngspice_currents(out, k, n);
}

/// Column currents (vectors x columns) of conductances g under row voltages v, from ngspice.
inline Eigen::MatrixXd ngspice_currents(const CrossbarParams& p, const Eigen::MatrixXd& g, const Eigen::MatrixXd& v) {
  return ngspice_outputs(p, g, v);
}

}  // namespace xbarsim::testing_ngspice
