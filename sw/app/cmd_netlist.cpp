#include <fstream>
#include <iostream>

#include "sw/app/app_common.h"
#include "sw/circuit/spice_netlist.h"
#include "sw/common/csv.h"
#include "sw/common/errors.h"

namespace xbarsim {

namespace {
int cmd_netlist(int argc, char** argv) {
  const CliArgs args(argc, argv, 0, {"--conductances", "--inputs", "--out"});
  if (args.has("--json") || args.has("--csv"))
    throw InputError("netlist writes a SPICE netlist (--out); --json and --csv do not apply");
  const ConfigTree cfg = load_config(args);
  const CrossbarParams params = parse_crossbar_params(cfg);
  const Eigen::MatrixXd g = read_csv_matrix(args.require("--conductances"), "the conductances (--conductances)");
  const Eigen::MatrixXd v = read_csv_matrix(args.require("--inputs"), "the input vectors (--inputs)");
  check_outputs(args, {"--out"});
  if (v.cols() != g.rows())
    throw InputError("input vectors have " + std::to_string(v.cols()) + " voltages but the crossbar has " +
                     std::to_string(g.rows()) + " rows");
  if (g.minCoeff() <= 0) throw InputError("conductances must be > 0");
  if (!args.has("--out")) {
    write_spice_netlist(std::cout, params, g, v);
    return 0;
  }
  OutputFile out(args.get("--out"));
  write_spice_netlist(out.stream(), params, g, v);
  out.commit();
  return 0;
}
}  // namespace

namespace {
const CommandRegistrar kRegister{
    "netlist", cmd_netlist,
    "netlist --conductances G.csv --inputs V.csv [--out NET.cir] [--config F] [--set k=v]...\n      the equivalent "
    "SPICE netlist; `ngspice -b NET.cir` prints the column currents (voltages with crossbar.sensing: voltage)"};
}  // namespace

}  // namespace xbarsim
