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

/// Column currents (vectors x columns) of conductances g under row voltages v, from ngspice.
inline Eigen::MatrixXd ngspice_currents(const CrossbarParams& p, const Eigen::MatrixXd& g, const Eigen::MatrixXd& v) {
  const std::string path = "/tmp/xbarsim_ngspice_" + std::to_string(g.rows()) + "x" + std::to_string(g.cols()) + "_" +
                           to_string(p.memristor.model) + "_" + to_string(p.transistor.model) + "_" +
                           std::to_string(::getpid()) + ".cir";
  {
    std::ofstream f(path);
    write_spice_netlist(f, p, g, v);
  }
  // stderr apart: ngspice's notes there would interleave with the printed currents.
  const std::string out = run("ngspice -b " + path + " 2>/dev/null");
  std::remove(path.c_str());
  return parse_ngspice_currents(out, static_cast<int>(v.rows()), static_cast<int>(g.cols()));
}

}  // namespace xbarsim::testing_ngspice
