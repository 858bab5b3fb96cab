// The `xbarsim._core` extension: the configuration and the exact crossbar solver on NumPy
// arrays. Whole commands (eval, simulate, explore, overhead) are run by python/xbarsim/__init__.py
// through the xbarsim executable, so their results are the CLI's JSON by construction.
#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <memory>
#include <optional>
#include <mutex>
#include <shared_mutex>

#include <cmath>
#include <cstdlib>
#include <sstream>

#include "sw/analog/analog_layer.h"
#include "sw/analog/calibration.h"
#include "sw/analog/error_metrics.h"
#include "sw/analog/training_draw.h"
#include "sw/circuit/crossbar_params.h"
#include "sw/circuit/crossbar_solver.h"
#include "sw/circuit/spice_netlist.h"
#include "sw/common/cancel.h"
#include "sw/common/config.h"
#include "sw/common/errors.h"
#include "sw/common/seed.h"
#include "sw/device/device.h"

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
    return solver->column_outputs(v);
  });
}

/// The configuration a call was given: a Config, a dict of {'dotted.key': value} overrides of
/// the defaults, or None (the defaults).
ConfigTree config_of(const py::handle& config) {
  if (config.is_none()) return ConfigTree();
  if (py::isinstance<ConfigTree>(config)) return config.cast<ConfigTree>();
  if (py::isinstance<py::dict>(config)) return load_config(py::none(), config);
  throw InputError("config must be an xbarsim.Config, a dict of {'dotted.key': value} or None, got " +
                   py::repr(config).cast<std::string>());
}

/// A weight matrix programmed onto crossbars (AnalogLayer), with what Python needs beside it:
/// the configuration and calibration vectors it was programmed with (set_time reads out again
/// from them) and the index of the next image its reads belong to (the read noise's key).
struct PyCrossbar {
  std::unique_ptr<AnalogLayer> layer;
  ConfigTree config;
  Eigen::MatrixXd calib;  ///< what program() was given (empty: random vectors)
  bool reads_image = false;  ///< the layer reads the network's image (converters.image_bits)
  uint64_t next_image = 0;
  /// matvec reads the layer (shared), set_time changes its readout (exclusive); both without the GIL.
  mutable std::shared_mutex mutex;
};

/// f() under a shared lock of x, taken without the GIL (set_time holds the lock exclusively
/// while its cancellation checks take the GIL).
template <typename F>
auto reading(const PyCrossbar& x, F&& f) -> decltype(f()) {
  py::gil_scoped_release release;
  std::shared_lock lock(x.mutex);
  return f();
}

/// The images of the read-noise streams a call may use: those below the reads programming makes.
constexpr uint64_t kMaxImage = uint64_t{1} << 62;

/// Whether a read's result depends on the image it belongs to (the read noise's key).
bool reads_are_noisy(const AnalogLayer& layer) {
  return layer.config().device.has_read_noise() || layer.config().converters.readout_noise_a > 0;
}

/// X (vectors x inputs) through every stage of the layer, in precision S (float: as eval).
/// Vector r is read r % R of image first + r / R (R = rows_per_image; the image keys the read
/// noise, as eval's dataset index does). X is read in place (no conversion with the GIL held: a
/// copy of a large X took seconds before Ctrl-C could act) and run in blocks, each crossbar's
/// stage over a whole block, so a block bounds how long Ctrl-C waits (the layer also checks
/// between crossbars): blocks of whole images when the reads are noisy (an image's reads are
/// numbered within one forward call), else blocks of 4096 vectors. A vector's result does not
/// depend on the other vectors of its block.
template <typename S>
AnalogLayer::Mat<S> matvec(PyCrossbar& xb, py::array_t<S, py::array::c_style | py::array::forcecast> a,
                           std::optional<uint64_t> image, std::optional<Eigen::Index> rows_per_image) {
  const AnalogLayer& layer = *xb.layer;
  if (a.ndim() != 2) throw InputError("X must be a 2-D array (vectors x inputs), got " + std::to_string(a.ndim()) +
                                      " dimensions");
  const Eigen::Index rows = a.shape(0), cols = a.shape(1);
  if (cols != layer.inputs())
    throw InputError("the vectors have " + std::to_string(cols) + " values each, the crossbar " +
                     std::to_string(layer.inputs()) + " inputs");
  if (rows_per_image && (*rows_per_image < 1 || rows % *rows_per_image != 0))
    throw InputError("rows_per_image must be >= 1 and divide the " + std::to_string(rows) + " vectors of X, got " +
                     std::to_string(*rows_per_image));
  const Eigen::Index per_image = rows_per_image ? *rows_per_image : std::max<Eigen::Index>(rows, 1);
  const auto images = static_cast<uint64_t>(rows / per_image);
  const uint64_t first = image ? *image : xb.next_image;
  if (first >= kMaxImage || images >= kMaxImage - first)
    throw InputError("image must be below 2**62 (its reads' index), got " + std::to_string(first) +
                     (images > 1 ? " for " + std::to_string(images) + " images" : std::string()));
  if (!image) xb.next_image += images;  // the GIL is held: calls from several threads count in turn
  const Eigen::Map<const AnalogLayer::RowMat<S>> x(a.data(), rows, cols);
  const bool by_image = reads_are_noisy(layer);
  constexpr Eigen::Index kBlock = 4096;
  return interruptible([&] {
    std::shared_lock lock(xb.mutex);
    AnalogLayer::Mat<S> y(rows, layer.outputs()), yb;
    AnalogLayer::RowMat<S> xr;
    const Eigen::Index step = by_image ? per_image : kBlock;
    for (Eigen::Index at = 0; at < rows; at += step) {
      check_cancel();
      const Eigen::Index n = std::min(step, rows - at);
      xr = x.middleRows(at, n);
      if (!xr.allFinite()) throw InputError("the vectors hold a non-finite value");
      layer.forward<S>(xr, yb, /*quantized=*/false, first + static_cast<uint64_t>(at / per_image));
      y.middleRows(at, n) = yb;
    }
    return y;
  });
}

/// A NumPy array of conductances as a matrix (S): 2-D as it is (a crossbar's rows x columns),
/// 1-D as one column. `what` names it in messages; `shape` receives its shape.
Eigen::MatrixXd conductance_matrix(const py::array_t<double, py::array::c_style | py::array::forcecast>& a,
                                   const std::string& what, std::vector<py::ssize_t>& shape) {
  if (a.ndim() != 1 && a.ndim() != 2)
    throw InputError(what + " must be a 1-D or 2-D array of conductances (S), got " + std::to_string(a.ndim()) +
                     " dimensions");
  shape.assign(a.shape(), a.shape() + a.ndim());
  const Eigen::Index rows = a.shape(0), cols = a.ndim() == 2 ? a.shape(1) : 1;
  const Eigen::MatrixXd g = Eigen::Map<const AnalogLayer::RowMat<double>>(a.data(), rows, cols);
  if (!g.allFinite()) throw InputError(what + " holds a non-finite value");
  if (g.size() && g.minCoeff() < 0) throw InputError(what + " holds a negative conductance");
  return g;
}

/// A matrix back as an array of `shape` (what conductance_matrix was given).
template <typename T>
py::array_t<T> as_array(const Eigen::Matrix<T, Eigen::Dynamic, Eigen::Dynamic>& m,
                        const std::vector<py::ssize_t>& shape) {
  py::array_t<T> out(shape);
  Eigen::Map<AnalogLayer::RowMat<T>>(out.mutable_data(), m.rows(), m.cols()) = m;
  return out;
}

/// The device model of a configuration on NumPy arrays, with the crossbar's streams: cell k
/// (column-major: k = column * rows + row) of crossbar `crossbar` of the layer with salt
/// `layer` draws as AnalogLayer's crossbar does, and the reads count per object.
struct PyDevice {
  explicit PyDevice(const DeviceSpec& spec) : device(spec) {}
  Device device;
  uint64_t next_read = 0;
  /// The crossbar's device stream (AnalogLayer: derive_seed(device.seed, {salt, crossbar})).
  uint64_t stream(uint64_t layer, uint64_t crossbar) const {
    return derive_seed(device.spec().seed, {layer, crossbar});
  }
};

FaultMap fault_map(const std::optional<py::array_t<int8_t, py::array::c_style | py::array::forcecast>>& a,
                   const std::vector<py::ssize_t>& shape, Eigen::Index rows, Eigen::Index cols) {
  if (!a) return FaultMap();
  if (std::vector<py::ssize_t>(a->shape(), a->shape() + a->ndim()) != shape)
    throw InputError("faults must have the shape of G_target");
  FaultMap f = Eigen::Map<const Eigen::Array<int8_t, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(a->data(),
                                                                                                       rows, cols);
  if (f.size() && (f.minCoeff() < -1 || f.maxCoeff() > 1))
    throw InputError("faults holds a value other than -1 (stuck at g_min), 0 (free) or +1 (stuck at g_max)");
  return f;
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

  py::class_<PyCrossbar>(m, "Crossbar",
                         "A weight matrix programmed onto crossbars as eval programs a layer: mapping, "
                         "mitigation, the device model (device.*), converters (config's sections).")
      .def(py::init([](const Eigen::MatrixXd& w, const py::object& config, double x_max, bool signed_inputs,
                       const std::optional<Eigen::MatrixXd>& calib, uint64_t salt, int groups, int channels,
                       bool reads_image) {
             const ConfigTree cfg = config_of(config);
             AnalogConfig ac = parse_analog_config(cfg);
             ac.converters = ac.converters.for_layer(reads_image);
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
             auto xb = std::make_unique<PyCrossbar>();
             xb->layer = std::make_unique<AnalogLayer>(ac, w, x_max, signed_inputs, salt, RowGroups{groups, channels});
             xb->config = cfg;
             xb->reads_image = reads_image;
             if (calib) xb->calib = *calib;
             interruptible([&] { xb->layer->program(xb->calib); });
             return xb;
           }),
           py::arg("W"), py::arg("config") = py::none(), py::arg("x_max") = 1.0, py::arg("signed_inputs") = false,
           py::arg("calibration") = std::nullopt, py::arg("salt") = 0, py::arg("groups") = 1, py::arg("channels") = 0,
           py::arg("reads_image") = false,
           "Crossbar(W, config=None, x_max=1, signed_inputs=False, calibration=None, salt=0, groups=1, channels=0, "
           "reads_image=False): reads_image: the layer reads the network's image, its inputs at "
           "converters.image_bits (eval's layers that read the network's input). W "
           "is inputs x outputs; config a Config, a dict of overrides or None (the defaults); inputs span [0, x_max] "
           "([-x_max, x_max] signed); calibration (vectors x inputs) as eval's calibration images (random vectors "
           "when None). A grouped convolution (groups > 1) gives its block-diagonal W in im2col order (input "
           "channel innermost, `channels` of them) and is programmed group by group, as eval programs it. The "
           "device (device.*) is programmed with streams of (device.seed, salt, crossbar) and read at "
           "device.time_s (set_time moves it). Releases the GIL while programming.")
      .def("matvec", &matvec<double>, py::arg("X"), py::arg("image") = std::nullopt,
           py::arg("rows_per_image") = std::nullopt,
           "X (vectors x inputs) times W through every stage: DACs, the circuit (with one read's device and "
           "readout noise), ADCs, recovery. Vector r is read r % R of image `image` + r // R, R = rows_per_image "
           "(default: all of X is one image): the image keys the read noise, as eval's dataset index does. "
           "Without `image` the crossbar's counter next_image gives it and advances by the call's images, so "
           "every call reads afresh and a new Crossbar of the same config reads the same. float64 arrays "
           "compute in double precision; float32 arrays in single, as eval computes a network.")
      .def("matvec", &matvec<float>, py::arg("X"), py::arg("image") = std::nullopt,
           py::arg("rows_per_image") = std::nullopt)
      .def_property(
          "next_image", [](const PyCrossbar& x) { return x.next_image; },
          [](PyCrossbar& x, uint64_t image) {
            if (image >= kMaxImage) throw InputError("next_image must be below 2**62");
            x.next_image = image;
          },
          "The image the next matvec without image= reads as (0 after programming); set it to read again")
      .def(
          "set_time",
          [](PyCrossbar& x, double t, const std::optional<std::string>& compensation) {
            ConfigTree next = x.config;
            next.set("device.time_s", value_text("device.time_s", py::float_(t)));
            if (compensation) next.set("device.compensation", *compensation);
            check_ranges(next);
            AnalogConfig ac = parse_analog_config(next);
            ac.converters = ac.converters.for_layer(x.reads_image);
            interruptible([&] {
              std::unique_lock lock(x.mutex);
              x.layer->set_readout(ac, x.calib);
            });
            x.config = next;
          },
          py::arg("t"), py::arg("compensation") = std::nullopt,
          "Reads the crossbars t seconds after programming (device.time_s; and device.compensation when given): "
          "the state at t and its compensation, without programming again (the same cells, draws and "
          "calibration at t = 0), as a Crossbar programmed with that device.time_s. Releases the GIL.")
      .def_property_readonly("time_s", [](const PyCrossbar& x) { return x.layer->time_s(); },
                             "The time after programming the crossbars are read at (s): device.time_s")
      .def_property_readonly("config", [](const PyCrossbar& x) { return x.config; },
                             "The configuration (a copy) the crossbars were programmed with, at time_s")
      .def_property_readonly("compensation_reads", [](const PyCrossbar& x) { return x.layer->compensation_reads(); },
                             "Reads made for drift compensation at time_s (reference reads, summed over crossbars)")
      .def(
          "conductances",
          [](const PyCrossbar& x, int b) {
            if (b < 0 || b >= x.layer->crossbars())
              throw InputError("crossbar " + std::to_string(b) + " does not exist (the layer has " +
                               std::to_string(x.layer->crossbars()) + ")");
            return reading(x, [&] { return Eigen::MatrixXd(x.layer->conductances(b)); });
          },
          py::arg("b"),
          "The conductances (S) crossbar b holds at time_s (rows x physical columns): programmed by the device, "
          "stuck cells at g_min or g_max, drifted")
      .def_property_readonly("inputs", [](const PyCrossbar& x) { return x.layer->inputs(); },
                             "Rows of W: the values of one input vector")
      .def_property_readonly("outputs", [](const PyCrossbar& x) { return x.layer->outputs(); },
                             "Columns of W: the values of one output vector")
      .def_property_readonly("crossbars", [](const PyCrossbar& x) { return x.layer->crossbars(); },
                             "How many physical crossbars hold W (mapping.max_rows x max_cols blocks, with the "
                             "mapping's extra columns)")
      .def_property_readonly("x_max", [](const PyCrossbar& x) { return x.layer->x_max(); },
                             "The inputs' full scale: the DACs span [0, x_max] ([-x_max, x_max] when signed)")
      .def_property_readonly("signed_inputs", [](const PyCrossbar& x) { return x.layer->signed_inputs(); },
                             "True when inputs span [-x_max, x_max] (else [0, x_max])")
      .def("reports", [](const PyCrossbar& x) {
        py::list out;
        for (const CrossbarReport& r : reading(x, [&] { return x.layer->reports(); })) {
          py::dict d;
          d["row0"] = r.block.row0;
          d["rows"] = r.block.rows;
          d["col0"] = r.block.col0;
          d["cols"] = r.block.cols;
          d["physical_cols"] = r.physical_cols;
          d["out_of_range_cells"] = r.out_of_range_cells;
          d["min_column_gain"] = r.min_column_gain;
          d["stuck_cells"] = r.stuck_cells;
          d["spare_columns_used"] = r.spare_columns_used;
          out.append(d);
        }
        return out;
      }, "Per crossbar, a dict: its block of W (row0, rows, col0, cols), physical_cols, out_of_range_cells "
         "(cells the conversion wanted outside [g_min, g_max], clipped), min_column_gain, stuck_cells (cells "
         "stuck at g_min or g_max, after spare columns) and spare_columns_used");

  using Cells = py::array_t<double, py::array::c_style | py::array::forcecast>;
  using Faults = std::optional<py::array_t<int8_t, py::array::c_style | py::array::forcecast>>;
  py::class_<PyDevice>(m, "Device",
                       "The device model of a configuration's section device. (docs/physics.md, device models) on "
                       "NumPy arrays of conductances in siemens: programming error and stuck cells, the state t "
                       "seconds after programming, one read's fluctuation. Every draw is the crossbar's: cell k "
                       "(column-major) of crossbar `crossbar` of the layer with salt `layer` draws from "
                       "(device.seed, layer, crossbar, k), as Crossbar and eval program it.")
      .def(py::init([](const py::object& config) {
             return std::make_unique<PyDevice>(parse_device_spec(config_of(config)));
           }),
           py::arg("config") = py::none(),
           "Device(config=None): config a Config, a dict of {'dotted.key': value} overrides or None (the "
           "defaults: device.model ideal). An unknown device.model or a bad device.* value raises ValueError "
           "naming the key.")
      .def(
          "program",
          [](const PyDevice& d, const Cells& g, bool return_faults, uint64_t layer, uint64_t crossbar) -> py::object {
            std::vector<py::ssize_t> shape;
            Eigen::MatrixXd m = conductance_matrix(g, "G", shape);
            FaultMap faults;
            d.device.program(m, faults, d.stream(layer, crossbar));
            if (!return_faults) return as_array<double>(m, shape);
            return py::make_tuple(as_array<double>(m, shape),
                                  as_array<int8_t>(Eigen::Matrix<int8_t, Eigen::Dynamic, Eigen::Dynamic>(faults), shape));
          },
          py::arg("G"), py::kw_only(), py::arg("return_faults") = false, py::arg("layer") = 0, py::arg("crossbar") = 0,
          "The conductances (S) cells with targets G (S; a crossbar's rows x columns, or 1-D: one column) hold "
          "after programming: the programming error, states clipped as the model clips them, stuck cells at "
          "g_min or g_max. With return_faults=True, (G_programmed, faults): faults int8, -1 stuck at g_min, +1 "
          "at g_max, 0 free. The same (layer, crossbar) always draws the same.")
      .def(
          "faults",
          [](const PyDevice& d, py::ssize_t rows, py::ssize_t cols, uint64_t layer, uint64_t crossbar) {
            if (rows < 0 || cols < 0) throw InputError("faults: rows and cols must be >= 0");
            FaultMap f;
            d.device.place_faults(f, rows, cols, d.stream(layer, crossbar));
            return as_array<int8_t>(Eigen::Matrix<int8_t, Eigen::Dynamic, Eigen::Dynamic>(f), {rows, cols});
          },
          py::arg("rows"), py::arg("cols"), py::kw_only(), py::arg("layer") = 0, py::arg("crossbar") = 0,
          "The stuck cells program() places on a rows x cols crossbar (int8: -1 at g_min, +1 at g_max, 0 free): "
          "each cell stuck at g_min with probability device.stuck_at_gmin, at g_max with stuck_at_gmax")
      .def(
          "at_time",
          [](const PyDevice& d, const Cells& target, const Cells& prog, std::optional<double> t, const Faults& faults,
             uint64_t layer, uint64_t crossbar) {
            std::vector<py::ssize_t> shape, shape_prog;
            const Eigen::MatrixXd gt = conductance_matrix(target, "G_target", shape);
            const Eigen::MatrixXd gp = conductance_matrix(prog, "G_prog", shape_prog);
            if (shape != shape_prog) throw InputError("G_target and G_prog differ in shape");
            const double time = t ? *t : d.device.spec().time_s;
            if (!std::isfinite(time) || time < 0) throw InputError("t must be a time >= 0 (s), got " + py::repr(py::float_(time)).cast<std::string>());
            const uint64_t stream = d.stream(layer, crossbar);
            FaultMap f = fault_map(faults, shape, gt.rows(), gt.cols());
            if (!faults) d.device.place_faults(f, gt.rows(), gt.cols(), stream);
            return as_array<double>(d.device.at_time(gt, gp, f, time, stream), shape);
          },
          py::arg("G_target"), py::arg("G_prog"), py::arg("t") = std::nullopt, py::kw_only(),
          py::arg("faults") = std::nullopt, py::arg("layer") = 0, py::arg("crossbar") = 0,
          "The conductances (S) t seconds after programming (default device.time_s) of cells with targets "
          "G_target programmed to G_prog (program()'s result): drift with each cell's exponent, relaxation, "
          "accumulated 1/f noise; stuck cells (faults; default: those program() placed for this layer and "
          "crossbar) never move. A cell's draws are the same at every t (a coherent trajectory); at t = 0 the "
          "programmed state, plus the noise the first read has accumulated for models with 1/f noise.")
      .def(
          "read",
          [](PyDevice& d, const Cells& g, std::optional<uint64_t> read, uint64_t image, uint64_t layer,
             uint64_t crossbar) {
            std::vector<py::ssize_t> shape;
            Eigen::MatrixXd m = conductance_matrix(g, "G", shape);
            const uint64_t r = read ? *read : d.next_read++;
            // The draws a nonlinear crossbar's read r of that image solves with (AnalogLayer::noisy_solves).
            return as_array<double>(d.device.read(m, d.device.read_noise_key(image, layer, crossbar), r), shape);
          },
          py::arg("G"), py::kw_only(), py::arg("read") = std::nullopt, py::arg("image") = 0, py::arg("layer") = 0,
          py::arg("crossbar") = 0,
          "One read's conductances (S) of cells in state G (S): G + read_sigma(G) z, z standard normal per "
          "cell, at least 1 nS (an open cell). Read `read` of `image` (default: the device's counter next_read, "
          "which advances, so every call draws afresh and a new Device of the same config draws the same): the "
          "cell draws of that read of a nonlinear Crossbar with salt `layer` (its linear reads add the "
          "column current's fluctuation instead, to first order)")
      .def_property(
          "next_read", [](const PyDevice& d) { return d.next_read; },
          [](PyDevice& d, uint64_t r) { d.next_read = r; }, "The read the next read() without read= is (0 at first)")
      .def(
          "read_sigma",
          [](const PyDevice& d, const Cells& g) {
            std::vector<py::ssize_t> shape;
            return as_array<double>(d.device.read_sigma(conductance_matrix(g, "G", shape)), shape);
          },
          py::arg("G"), "One read's standard deviation (S) of every cell's conductance at state G (S)")
      .def(
          "program_sigma",
          [](const PyDevice& d, const Cells& g) {
            std::vector<py::ssize_t> shape;
            const Eigen::MatrixXd m = conductance_matrix(g, "G_target", shape);
            return as_array<double>(m.unaryExpr([&](double v) { return d.device.program_sigma_s(v); }).eval(), shape);
          },
          py::arg("G_target"), "The model's programming error sigma (S) for targets G_target (S), before clipping")
      .def(
          "nu",
          [](const PyDevice& d, const Cells& g) {
            std::vector<py::ssize_t> shape;
            const Eigen::MatrixXd m = conductance_matrix(g, "G_target", shape);
            const bool drifts = d.device.spec().kind == DeviceKind::Statistical && d.device.spec().stat.drifts;
            const Eigen::MatrixXd mean = m.unaryExpr([&](double v) { return drifts ? d.device.nu_mean(v) : 0.0; });
            const Eigen::MatrixXd sd = m.unaryExpr([&](double v) { return drifts ? d.device.nu_std(v) : 0.0; });
            return py::make_tuple(as_array<double>(mean, shape), as_array<double>(sd, shape));
          },
          py::arg("G_target"),
          "(mean, std) of the drift exponent for targets G_target (S): each cell's nu = |N(mean, std)| (zeros for "
          "a model without drift)")
      .def_property_readonly("model", [](const PyDevice& d) { return d.device.spec().model; },
                             "device.model as written: ideal, constant, a built-in model's name or a model file")
      .def_property_readonly(
          "kind",
          [](const PyDevice& d) -> std::string {
            switch (d.device.spec().kind) {
              case DeviceKind::Ideal:
                return "ideal";
              case DeviceKind::Constant:
                return "constant";
              case DeviceKind::Statistical:
                return "statistical";
            }
            return "?";
          },
          "ideal, constant or statistical (a published model as data)")
      .def_property_readonly("source", [](const PyDevice& d) { return d.device.spec().stat.source; },
                             "A statistical model's source (its papers), else ''")
      .def_property_readonly("g_min", [](const PyDevice& d) { return d.device.spec().g_min_s; },
                             "The cells' lowest conductance (S): the model's, or crossbar.g_min")
      .def_property_readonly("g_max", [](const PyDevice& d) { return d.device.spec().g_max_s; },
                             "The cells' highest conductance (S): the model's, or crossbar.g_max")
      .def_property_readonly("seed", [](const PyDevice& d) { return d.device.spec().seed; }, "device.seed")
      .def_property_readonly("time_s", [](const PyDevice& d) { return d.device.spec().time_s; },
                             "device.time_s: at_time's default t (s)")
      .def_property_readonly("moves", [](const PyDevice& d) { return d.device.spec().moves(); },
                             "The state changes after programming (at_time is not the identity for t > 0)")
      .def_property_readonly("has_read_noise", [](const PyDevice& d) { return d.device.spec().has_read_noise(); },
                             "A cell's read fluctuates (read_sigma > 0 somewhere)")
      .def("__repr__", [](const PyDevice& d) {
        std::ostringstream s;
        s << "<xbarsim.Device " << d.device.spec().model << ": " << d.device.spec().g_min_s * 1e6 << ".."
          << d.device.spec().g_max_s * 1e6 << " uS>";
        return s.str();
      });

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
  m.def(
      "input_full_scale",
      [](const Eigen::MatrixXd& samples, bool signed_inputs, const py::object& config, double input_max,
         bool reads_image) {
        const AnalogConfig ac = parse_analog_config(config_of(config));
        if (!samples.allFinite()) throw InputError("the input samples hold a non-finite value");
        if (!(input_max > 0)) {  // not given: the samples' largest magnitude
          const double top = samples.size() ? samples.cwiseAbs().maxCoeff() : 0.0;
          input_max = top > 0 ? top : 1.0;
        }
        return input_full_scale(samples, input_max, signed_inputs, ac.ranging,
                                ac.converters.for_layer(reads_image).activation_bits());
      },
      py::arg("samples"), py::arg("signed_inputs"), py::arg("config") = py::none(), py::arg("input_max") = 0.0,
      py::arg("reads_image") = false,
      "The DAC's full scale eval gives a layer whose sampled input vectors are `samples` (rows) and whose "
      "largest input magnitude is `input_max` (0: the samples'; 1 for all zeros): ranging.inputs (max, "
      "percentile or mse for the activation bits; signed: a sign and bits - 1 magnitude bits), never above "
      "input_max; reads_image: the layer reads the network's image (converters.image_bits)");
  m.def(
      "weight_cells",
      [](const Eigen::MatrixXd& w, const py::object& config, const py::object& given) {
        const AnalogConfig ac = parse_analog_config(config_of(config));
        if (w.rows() < 1 || w.cols() < 1) throw InputError("the weight matrix is empty");
        if (!w.allFinite()) throw InputError("the weight matrix holds a non-finite value");
        py::list out;
        const std::vector<Block> blocks = crossbar_blocks(static_cast<int>(w.rows()), static_cast<int>(w.cols()), ac.mapping);
        std::vector<WeightRanges> ranges;
        if (given.is_none()) {
          // The ranges eval maps with (ranging.weights, weight_scale), from an unprogrammed layer.
          const AnalogLayer layer(ac, w, 1.0, false);
          ranges = layer.block_ranges();
        } else {  // a previous call's (lo, hi) per block: the search skipped
          const auto list = given.cast<py::list>();
          if (list.size() != blocks.size())
            throw InputError("weight_cells: ranges has " + std::to_string(list.size()) + " blocks, the matrix " +
                             std::to_string(blocks.size()));
          for (size_t b = 0; b < blocks.size(); ++b) {
            const auto pair = list[b].cast<py::tuple>();
            WeightRanges r;
            r.lo = pair[0].cast<Eigen::VectorXd>();
            r.hi = pair[1].cast<Eigen::VectorXd>();
            if (r.lo.size() != blocks[b].cols || r.hi.size() != blocks[b].cols)
              throw InputError("weight_cells: ranges of block " + std::to_string(b) + " do not match its columns");
            ranges.push_back(std::move(r));
          }
        }
        for (size_t b = 0; b < blocks.size(); ++b) {
          const Block& blk = blocks[b];
          const MappedWeights m =
              map_weights(w.block(blk.row0, blk.col0, blk.rows, blk.cols), blk, ac.mapping, ac.xbar, ranges[b]);
          const int weight_cols = blk.cols * m.per_weight;  // the sum(X) column, if any, follows them
          py::dict d;
          d["r0"] = blk.row0;
          d["rows"] = blk.rows;
          d["c0"] = blk.col0;
          d["cols"] = blk.cols;
          d["per_weight"] = m.per_weight;
          d["g"] = Eigen::MatrixXd(m.g_target.leftCols(weight_cols));
          d["s"] = Eigen::VectorXd(m.s.head(weight_cols));
          d["sign"] = Eigen::VectorXd(m.sign.head(weight_cols));
          d["w_lo"] = m.w_lo;
          d["ranges"] = py::make_tuple(ranges[b].lo, ranges[b].hi);
          out.append(d);
        }
        return out;
      },
      py::arg("W"), py::arg("config") = py::none(), py::arg("ranges") = py::none(),
      "The cells a weight matrix (inputs x outputs) is written to, as eval maps a layer before conversion: per "
      "crossbar (mapping.max_rows/max_cols) a dict of its block (r0, rows, c0, cols), its target conductances g "
      "(rows x cols * per_weight, S; weight column j, polarity p, slice t in column (j * polarities + p) * slices "
      "+ t; the sum(X) column left out), per column the scale s (S per weight unit) and sign, and the shift "
      "w_lo: weight (r, j) = w_lo + sum over its columns c of sign[c] (g[r, c] - g_min) / s[c]. With "
      "mapping.weight_bits or crossbar.cell_bits these are the quantized weights; weights beyond their "
      "column's range (ranging.weights) are held at its end. Each dict's `ranges` is its block's (lo, hi) per weight column; passing a previous "
      "call's list of them as `ranges` maps with those instead of searching them again (ranging.weights: mse "
      "searches every column).");
  py::class_<AnalogConfig>(m, "TrainingMapper",
                           "A configuration's mapping, parsed once, for xbarsim.nn's per-step draws (draw)")
      .def(py::init([](const py::object& config) { return parse_analog_config(config_of(config)); }),
           py::arg("config") = py::none())
      .def_property_readonly(
          "negative", [](const AnalogConfig& ac) { return ac.mapping.differential() ? "differential" : "shift"; },
          "mapping.negative as resolved (auto: differential under a device model)")
      .def(
          "draw",
          [](const AnalogConfig& ac, const PyDevice& d, const Eigen::MatrixXd& w, const py::object& given,
             const Eigen::MatrixXd& calib_rows, uint64_t layer, uint64_t step, bool device, double time_s,
             const std::string& compensation, bool read_noise, double readout_noise_a, double v_in_max,
             double noise_scale) {
            TrainingDrawSpec spec;
            spec.device = device;
            spec.time_s = time_s;
            spec.layer = layer;
            spec.step = step;
            spec.gain = compensation == "none"     ? TrainingGain::None
                        : compensation == "global" ? TrainingGain::Global
                                                   : TrainingGain::Column;
            spec.read_noise = read_noise;
            spec.readout_noise_a = readout_noise_a;
            spec.v_in_max = v_in_max;
            spec.noise_scale = noise_scale;
            std::vector<WeightRanges> ranges;
            if (!given.is_none())
              for (const auto& item : given.cast<py::list>()) {
                const auto pair = item.cast<py::tuple>();
                ranges.push_back({pair[0].cast<Eigen::VectorXd>(), pair[1].cast<Eigen::VectorXd>(), 0});
              }
            TrainingDraw r;
            {
              py::gil_scoped_release free;  // the layers of a step draw on every core
              r = training_draw(ac, d.device, w, given.is_none() ? nullptr : &ranges, calib_rows, spec);
            }
            py::list blocks, out_ranges;
            for (size_t b = 0; b < r.blocks.size(); ++b) {
              const TrainingBlock& tb = r.blocks[b];
              blocks.append(py::make_tuple(tb.r0, tb.rows, tb.c0, tb.cols,
                                           tb.readout_var.size() ? py::cast(tb.readout_var) : py::none()));
              out_ranges.append(py::make_tuple(r.ranges[b].lo, r.ranges[b].hi));
            }
            py::dict out;
            out["delta"] = r.delta;
            out["sigma2"] = r.sigma2.size() ? py::cast(r.sigma2) : py::none();
            out["readout_var"] = r.readout_var;
            out["offset"] = r.offset;
            out["blocks"] = blocks;
            out["ranges"] = out_ranges;
            return out;
          },
          py::arg("device"), py::arg("W"), py::arg("ranges"), py::arg("calibration"), py::arg("layer"),
          py::arg("step"), py::arg("program"), py::arg("time_s"), py::arg("compensation"), py::arg("read_noise"),
          py::arg("readout_noise_a"), py::arg("v_in_max"), py::arg("noise_scale"),
          "One training step's draw of the weight matrix W (inputs x outputs, eval's row order): mapped as "
          "weight_cells (with `ranges`, a previous draw's, or searched: None), programmed by `device` with keys "
          "(layer, (step << 20) + crossbar) when `program`, read time_s after programming with the compensation's "
          "gains (none, global, column), each crossbar column calibrated on `calibration` (vectors x inputs as "
          "the DAC applies them; 0 rows: none). A dict: delta (held - W), sigma2 (one read's variance per weight "
          "with read_noise, else None), readout_var and offset per output column, blocks (r0, rows, c0, cols, "
          "readout variance per column or None), ranges. Releases the GIL.");
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
