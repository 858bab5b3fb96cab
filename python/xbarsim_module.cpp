// The `xbarsim._core` extension: the configuration, the exact crossbar circuit, the device
// model and analog layers on NumPy arrays, eval's per-layer rules and its datasets, each area bound in a file
// of its own (python/bind_*.cpp). Whole commands (eval, simulate, explore, overhead) are run by
// python/xbarsim/commands.py through the xbarsim executable, so their results are the CLI's JSON
// by construction: the platform (SystemC) is not bound.
#include "python/bind.h"
#include "sw/common/errors.h"

namespace py = pybind11;
using namespace xbarsim;

PYBIND11_MODULE(_core, m) {
  m.doc() = "xbarsim's C++ core: configuration and the exact crossbar circuit solver";
  m.attr("__version__") = XBARSIM_VERSION;
  m.attr("_binary") = XBARSIM_BINARY_PATH;
  m.attr("_installed_binary") = XBARSIM_INSTALLED_BINARY;
  static py::exception<SolverError> solver_error(m, "SolverError", PyExc_RuntimeError);
  solver_error.attr("__doc__") =
      "A crossbar circuit solve that did not converge (the CLI's exit code 3): the message names the "
      "solver, its iterations and residual. A RuntimeError; bad input raises ValueError instead.";
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const InputError& e) {
      PyErr_SetString(PyExc_ValueError, e.what());
    } catch (const SolverError& e) {
      solver_error(e.what());
    }
  });

  // The order matters: a default argument or signature names a class bound before it.
  bindings::bind_config(m);
  bindings::bind_devices(m);
  bindings::bind_circuit(m);
  bindings::bind_analog(m);
  bindings::bind_networks(m);
  bindings::bind_data(m);
}
