// xbarsim._core: the exact crossbar circuit (solve) and its SPICE netlist.
#include <sstream>

#include "python/bind.h"
#include "sw/circuit/crossbar_params.h"
#include "sw/circuit/crossbar_solver.h"
#include "sw/circuit/spice_netlist.h"
#include "sw/common/errors.h"

namespace xbarsim::bindings {

namespace {

Eigen::MatrixXd solve(const Eigen::MatrixXd& g, const Eigen::MatrixXd& v, const ConfigTree& cfg) {
  const CrossbarParams params = parse_crossbar_params(cfg);
  const SolverOptions opts = parse_solver_options(cfg);
  if (g.size() == 0) throw InputError("the conductance matrix is empty");
  if (v.cols() != g.rows())
    throw InputError("the input vectors have " + std::to_string(v.cols()) + " voltages each, but the conductance matrix has " +
                     std::to_string(g.rows()) + " rows (one voltage per row is needed)");
  if (!g.allFinite() || !v.allFinite()) throw InputError("conductances and voltages must be finite");
  if (g.minCoeff() <= 0) throw InputError("conductances must be > 0");
  return interruptible([&] {  // the solve runs on this thread (and the solver's) without the GIL
    auto solver = make_crossbar_solver(params, opts);
    solver->program(g);
    return solver->column_outputs(v);
  });
}

}  // namespace

void bind_circuit(py::module_& m) {
  m.def("solve", &solve, py::arg("G"), py::arg("V"), py::arg("config") = ConfigTree(),
        "Column currents (A), one row per input vector, of the crossbar with conductances G (rows x cols, "
        "S) for the input voltages V (vectors x rows, V): the exact circuit of crossbar.* with solver.*. "
        "With crossbar.sensing = voltage, the settled column voltages (V) of the open columns. "
        "Releases the GIL.");
  m.def(
      "netlist",
      [](const Eigen::MatrixXd& g, const Eigen::MatrixXd& v, const ConfigTree& cfg) {
        const CrossbarParams params = parse_crossbar_params(cfg);
        if (v.cols() != g.rows())
          throw InputError("input vectors have " + std::to_string(v.cols()) + " voltages but the crossbar has " +
                           std::to_string(g.rows()) + " rows");
        if (g.size() == 0 || g.minCoeff() <= 0) throw InputError("conductances must be > 0");
        std::ostringstream out;
        write_spice_netlist(out, params, g, v);
        return out.str();
      },
      py::arg("G"), py::arg("V"), py::arg("config") = ConfigTree(),
      "The equivalent SPICE netlist (text); `ngspice -b` on it prints the column currents (voltages with "
      "crossbar.sensing = voltage)");
}

}  // namespace xbarsim::bindings
