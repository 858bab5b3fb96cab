// The `xbarsim._core` extension: the configuration and the exact crossbar solver on NumPy
// arrays. Whole commands (eval, simulate, explore, overhead) are run by python/xbarsim/__init__.py
// through the xbarsim executable, so their results are the CLI's JSON by construction.
#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <memory>
#include <optional>

#include <cmath>
#include <cstdlib>
#include <sstream>

#include "sw/analog/analog_layer.h"
#include "sw/analog/calibration.h"
#include "sw/analog/error_metrics.h"
#include "sw/circuit/crossbar_params.h"
#include "sw/circuit/crossbar_solver.h"
#include "sw/circuit/spice_netlist.h"
#include "sw/common/cancel.h"
#include "sw/common/config.h"
#include "sw/common/errors.h"

namespace py = pybind11;
using namespace xbarsim;

namespace {

/// Runs f() with the GIL released, checking for signals (Ctrl-C) every 100 ms at most: the
/// check briefly takes the GIL and calls PyErr_CheckSignals (Python runs its handlers on the
/// main thread only; elsewhere the check finds nothing). When a handler raises (SIGINT's raises
/// KeyboardInterrupt) the computation stops at its next check (sw/common/cancel.h) and that
/// exception is raised here, once the worker threads are joined.
template <typename F>
auto interruptible(F&& f) -> decltype(f()) {
  std::optional<py::error_already_set> raised;
  CancelScope scope([&raised] {
    py::gil_scoped_acquire gil;
    if (PyErr_CheckSignals() == 0) return false;
    raised.emplace();  // takes the Python error (KeyboardInterrupt) out of the thread state
    return true;
  });
  try {
    py::gil_scoped_release release;
    return f();
  } catch (const Cancelled&) {
    if (raised) throw *raised;
    throw;
  }
}

/// A Python value as the YAML text --set takes: lists as [a, b], booleans as true/false. Any
/// int (NumPy's too) is written whole and floats with 17 digits, so the configuration's range
/// checks see the value itself (2**63 is out of range there, not an overflow here).
std::string yaml_text(const py::handle& v) {
  if (py::isinstance<py::bool_>(v)) return v.cast<bool>() ? "true" : "false";
  if (py::isinstance<py::int_>(v)) return py::str(v).cast<std::string>();
  if (py::isinstance<py::float_>(v)) {
    std::ostringstream s;
    s.precision(17);
    s << v.cast<double>();
    return s.str();
  }
  if (py::isinstance<py::str>(v)) return v.cast<std::string>();
  if (py::isinstance<py::list>(v) || py::isinstance<py::tuple>(v)) {
    std::string out = "[";
    for (const py::handle& x : v) out += (out.size() > 1 ? ", " : "") + yaml_text(x);
    return out + "]";
  }
  if (v.is_none()) return "none";
  // NumPy scalars and arrays: as the Python numbers and lists tolist() gives.
  if (py::hasattr(v, "dtype") && py::hasattr(v, "tolist")) return yaml_text(v.attr("tolist")());
  throw InputError("a configuration value must be a number, string, bool, None or a list of those (got " +
                   py::str(v.get_type().attr("__name__")).cast<std::string>() + ")");
}

/// yaml_text for the value of `key`; a value it cannot write is an InputError naming the key.
std::string value_text(const std::string& key, const py::handle& v) {
  try {
    return yaml_text(v);
  } catch (const InputError& e) {
    throw InputError("configuration key '" + key + "': " + e.what());
  }
}

/// A configuration key given from Python: a str.
std::string key_text(const py::handle& k) {
  if (!py::isinstance<py::str>(k))
    throw InputError("configuration keys are dotted names (strings), got " + py::repr(k).cast<std::string>());
  return k.cast<std::string>();
}

/// The override `key=value` as --set takes it.
std::string assignment(const py::handle& k, const py::handle& v) {
  const std::string key = key_text(k);
  return key + "=" + value_text(key, v);
}

/// The value at `key`, typed: a list, an int, a float, a bool or a string.
py::object typed_value(const ConfigTree& cfg, const std::string& key) {
  if (cfg.is_list(key)) {
    py::list out;
    for (const std::string& item : cfg.list_items(key)) out.append(item);
    return std::move(out);
  }
  const std::string text = cfg.get_string(key);
  if (text == "true" || text == "false") return py::bool_(text == "true");
  if (ConfigTree::is_integer(key)) {
    try {
      return py::int_(cfg.get_int(key));
    } catch (const InputError&) {  // a word such as `none` or `unbounded`
      return py::str(text);
    }
  }
  if (ConfigTree::is_numeric(key)) {
    try {
      return py::float_(cfg.get_double(key));
    } catch (const InputError&) {
      return py::str(text);
    }
  }
  return py::str(text);
}

/// Checks a numeric key's value `text` against its documented range, as the commands do when
/// they read it (words such as `none` are checked by the command that reads the key).
void check_range(const ConfigTree& cfg, const std::string& key, const std::string& text) {
  char* end = nullptr;
  std::strtod(text.c_str(), &end);
  if (text.empty() || end != text.c_str() + text.size()) return;
  if (ConfigTree::is_integer(key))
    cfg.get_int(key);
  else
    cfg.get_double(key);
}

/// check_range for every numeric value, each value of a sweep list too.
void check_ranges(const ConfigTree& cfg) {
  for (const std::string& key : cfg.leaf_keys()) {
    if (!ConfigTree::is_numeric(key)) continue;
    if (!cfg.is_list(key)) {
      check_range(cfg, key, cfg.get_string(key));
      continue;
    }
    ConfigTree point = cfg;
    for (const std::string& item : cfg.list_items(key)) {
      point.set_scalar(key, item);
      check_range(point, key, item);
    }
  }
}

/// The configuration at `path` (a str or os.PathLike; None or "" for the defaults) with `overrides`.
ConfigTree load_config(const py::handle& path, const py::handle& overrides) {
  std::string file;
  if (!path.is_none()) {
    if (!py::isinstance<py::str>(path) && !py::hasattr(path, "__fspath__"))
      throw InputError("Config: path must be the path of a YAML file (a str or os.PathLike), got " +
                       py::repr(path).cast<std::string>());
    const py::object fs = py::module_::import("os").attr("fspath")(path);
    if (!py::isinstance<py::str>(fs))
      throw InputError("Config: path must be the path of a YAML file (a str), got " + py::repr(fs).cast<std::string>());
    file = fs.cast<std::string>();
  }
  std::vector<std::string> sets;
  if (!overrides.is_none()) {
    if (!py::hasattr(overrides, "items"))
      throw InputError("Config: overrides must be a dict of {'dotted.key': value}, got " +
                       py::repr(overrides).cast<std::string>());
    for (const auto& [k, v] : py::dict(py::reinterpret_borrow<py::object>(overrides))) sets.push_back(assignment(k, v));
  }
  ConfigTree cfg = ConfigTree::load(file, sets);
  check_ranges(cfg);
  return cfg;
}

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
    return solver->column_currents(v);
  });
}

/// X (vectors x inputs) through every stage of the layer, in precision S (float: as eval).
/// X is read in place (no conversion with the GIL held: a copy of a large X took seconds before
/// Ctrl-C could act) and run in blocks of vectors, each crossbar's stage over a whole block, so
/// a block bounds how long Ctrl-C waits (the layer also checks between crossbars). A vector's
/// result does not depend on the other vectors of its block.
template <typename S>
AnalogLayer::Mat<S> matvec(const AnalogLayer& layer, py::array_t<S, py::array::c_style | py::array::forcecast> a) {
  if (a.ndim() != 2) throw InputError("X must be a 2-D array (vectors x inputs), got " + std::to_string(a.ndim()) +
                                      " dimensions");
  const Eigen::Index rows = a.shape(0), cols = a.shape(1);
  if (cols != layer.inputs())
    throw InputError("the vectors have " + std::to_string(cols) + " values each, the crossbar " +
                     std::to_string(layer.inputs()) + " inputs");
  const Eigen::Map<const AnalogLayer::RowMat<S>> x(a.data(), rows, cols);
  constexpr Eigen::Index kBlock = 4096;
  return interruptible([&] {
    AnalogLayer::Mat<S> y(rows, layer.outputs()), yb;
    AnalogLayer::RowMat<S> xb;
    for (Eigen::Index first = 0; first < rows; first += kBlock) {
      check_cancel();
      const Eigen::Index n = std::min(kBlock, rows - first);
      xb = x.middleRows(first, n);
      if (!xb.allFinite()) throw InputError("the vectors hold a non-finite value");
      layer.forward<S>(xb, yb);
      y.middleRows(first, n) = yb;
    }
    return y;
  });
}

}  // namespace

PYBIND11_MODULE(_core, m) {
  m.doc() = "xbarsim's C++ core: configuration and the exact crossbar circuit solver";
  m.attr("__version__") = XBARSIM_VERSION;
  m.attr("_binary") = XBARSIM_BINARY_PATH;
  m.attr("_installed_binary") = XBARSIM_INSTALLED_BINARY;
  m.def("_assignment", &assignment, py::arg("key"), py::arg("value"),
        "The override key=value as --set takes it (the package's one conversion; ValueError naming the key)");
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

  py::class_<ConfigTree>(m, "Config",
                         "Configuration: the documented defaults (configs/default.yaml), then a YAML file, then "
                         "overrides; validated as the CLI validates it.")
      .def(py::init(&load_config),
           py::arg("path") = py::none(), py::arg("overrides") = py::none(),
           "Config(path=None, overrides=None): defaults, the YAML file at `path` (str or os.PathLike), then "
           "{'dotted.key': value}; a bad value raises ValueError naming its key")
      .def(
          "set",
          [](ConfigTree& c, const py::handle& k, const py::handle& v) {
            const std::string key = key_text(k);
            ConfigTree next = c;
            next.set(key, value_text(key, v));
            check_ranges(next);
            c = next;
          },
          py::arg("key"), py::arg("value"), "Set a dotted key (a list value is a sweep)")
      .def("get", &typed_value, py::arg("key"), "The value at a dotted key, typed")
      .def(
          "to_dict",
          [](const ConfigTree& c) {
            py::dict root;
            for (const std::string& key : c.leaf_keys()) {
              py::dict node = root;
              size_t at = 0, dot;
              while ((dot = key.find('.', at)) != std::string::npos) {
                const py::str part(key.substr(at, dot - at));
                if (!node.contains(part)) node[part] = py::dict();
                node = node[part].cast<py::dict>();
                at = dot + 1;
              }
              node[py::str(key.substr(at))] = typed_value(c, key);
            }
            return root;
          },
          "Every key as nested dicts")
      .def("dump", &ConfigTree::dump, "The effective configuration as YAML text")
      .def("sweep_points", &ConfigTree::sweep_points, "Points of the sweep its list values span")
      .def("__repr__", [](const ConfigTree& c) {
        return "<xbarsim.Config: " + std::to_string(c.sweep_points()) + " point(s)>";
      });

  py::class_<AnalogLayer>(m, "Crossbar",
                          "A weight matrix programmed onto crossbars as eval programs a layer: mapping, "
                          "mitigation, programming noise, converters (config's sections).")
      .def(py::init([](const Eigen::MatrixXd& w, const ConfigTree& cfg, double x_max, bool signed_inputs,
                       const std::optional<Eigen::MatrixXd>& calib, uint64_t salt, int groups, int channels) {
             const AnalogConfig ac = parse_analog_config(cfg);
             if (w.rows() < 1 || w.cols() < 1) throw InputError("the weight matrix is empty");
             if (!w.allFinite()) throw InputError("the weight matrix holds a non-finite value");
             if (!(x_max > 0) || !std::isfinite(x_max)) throw InputError("x_max must be a finite number > 0");
             if (calib && calib->size() && calib->cols() != w.rows())
               throw InputError("the calibration vectors have " + std::to_string(calib->cols()) +
                                " values each, but the weight matrix has " + std::to_string(w.rows()) + " rows");
             if (calib && !calib->allFinite()) throw InputError("the calibration vectors hold a non-finite value");
             if (groups < 1) throw InputError("groups must be >= 1");
             if (groups > 1 && channels < 1)
               throw InputError("a grouped layer (groups > 1) needs channels: its input channels");
             auto layer = std::make_unique<AnalogLayer>(ac, w, x_max, signed_inputs, salt, RowGroups{groups, channels});
             interruptible([&] { layer->program(calib ? *calib : Eigen::MatrixXd()); });
             return layer;
           }),
           py::arg("W"), py::arg("config") = ConfigTree(), py::arg("x_max") = 1.0, py::arg("signed_inputs") = false,
           py::arg("calibration") = std::nullopt, py::arg("salt") = 0, py::arg("groups") = 1, py::arg("channels") = 0,
           "Crossbar(W, config, x_max=1, signed_inputs=False, calibration=None, salt=0, groups=1, channels=0): W is "
           "inputs x outputs; inputs span [0, x_max] ([-x_max, x_max] signed); calibration (vectors x inputs) as "
           "eval's calibration images (random vectors when None). A grouped convolution (groups > 1) gives its "
           "block-diagonal W in im2col order (input channel innermost, `channels` of them) and is programmed "
           "group by group, as eval programs it. Releases the GIL while programming.")
      .def("matvec", &matvec<double>, py::arg("X"),
           "X (vectors x inputs) times W through every stage: DACs, the circuit, ADCs, recovery. float64 "
           "arrays compute in double precision; float32 arrays in single, as eval computes a network.")
      .def("matvec", &matvec<float>, py::arg("X"))
      .def_property_readonly("inputs", &AnalogLayer::inputs, "Rows of W: the values of one input vector")
      .def_property_readonly("outputs", &AnalogLayer::outputs, "Columns of W: the values of one output vector")
      .def_property_readonly("crossbars", &AnalogLayer::crossbars,
                             "How many physical crossbars hold W (mapping.max_rows x max_cols blocks, with the "
                             "mapping's extra columns)")
      .def_property_readonly("x_max", &AnalogLayer::x_max,
                             "The inputs' full scale: the DACs span [0, x_max] ([-x_max, x_max] when signed)")
      .def_property_readonly("signed_inputs", &AnalogLayer::signed_inputs,
                             "True when inputs span [-x_max, x_max] (else [0, x_max])")
      .def("reports", [](const AnalogLayer& layer) {
        py::list out;
        for (const CrossbarReport& r : layer.reports()) {
          py::dict d;
          d["row0"] = r.block.row0;
          d["rows"] = r.block.rows;
          d["col0"] = r.block.col0;
          d["cols"] = r.block.cols;
          d["physical_cols"] = r.physical_cols;
          d["out_of_range_cells"] = r.out_of_range_cells;
          d["min_column_gain"] = r.min_column_gain;
          out.append(d);
        }
        return out;
      }, "Per crossbar, a dict: its block of W (row0, rows, col0, cols), physical_cols, out_of_range_cells "
         "(cells the conversion wanted outside [g_min, g_max], clipped) and min_column_gain");

  m.def(
      "output_errors",
      [](py::array_t<double, py::array::c_style | py::array::forcecast> actual,
         py::array_t<double, py::array::c_style | py::array::forcecast> ideal, double output_range) {
        if (actual.size() != ideal.size() || actual.ndim() != ideal.ndim())
          throw InputError("output_errors: actual and ideal differ in shape");
        for (py::ssize_t d = 0; d < actual.ndim(); ++d)
          if (actual.shape(d) != ideal.shape(d)) throw InputError("output_errors: actual and ideal differ in shape");
        if (!(output_range > 0) || !std::isfinite(output_range))
          throw InputError("output_errors: output_range must be a finite number > 0");
        const Eigen::Map<const Eigen::VectorXd> a(actual.data(), actual.size()), i(ideal.data(), ideal.size());
        const ErrorTally t = layer_error(a, i, output_range);
        return py::make_tuple(t.mean(), t.worst, t.count);
      },
      py::arg("actual"), py::arg("ideal"), py::arg("output_range"),
      "(mean, worst, count) of |actual - ideal| / output_range over every element: eval's per-layer error "
      "(docs/physics.md), with output_range from layer_output_range");
  m.def("layer_output_range", &layer_output_range, py::arg("lo"), py::arg("hi"),
        "A layer's output range for its errors: max(hi) - min(lo), where lo and hi are per output channel the "
        "smallest and largest software outputs over the calibration data (1 when they never varied)");
  m.attr("layer_error_warning") = kLayerErrorWarning;
  m.def("layer_error_warning_text", &layer_error_warning, py::arg("name"), py::arg("mean"),
        "The warning eval gives for a layer whose mean error passes layer_error_warning");

  m.def("calibration_rows_per_image", &calibration_rows_per_image, py::arg("samples"), py::arg("images"),
        "How many calibration vectors eval draws from each calibration image when it keeps `samples` "
        "(eval.calibration_samples) over `images` images");
  m.def(
      "calibration_row_picks",
      [](uint64_t seed, int image, int layer, Eigen::Index rows, int count) {
        return calibration_row_picks(seed, image, layer, rows, count);
      },
      py::arg("seed"), py::arg("image"), py::arg("layer"), py::arg("rows"), py::arg("count"),
      "Which of a calibration image's `rows` input vectors eval samples for linear layer `layer` (its "
      "place among the network's Conv/Gemm layers): `count` indices from calibration.seed's stream");
  m.def("solve", &solve, py::arg("G"), py::arg("V"), py::arg("config") = ConfigTree(),
        "Column currents (A), one row per input vector, of the crossbar with conductances G (rows x cols, "
        "S) for the input voltages V (vectors x rows, V): the exact circuit of crossbar.* with solver.*. "
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
      "The equivalent SPICE netlist (text); `ngspice -b` on it prints the column currents");
}
