// xbarsim._core: the device model (Device) on NumPy arrays of conductances, with the crossbar's streams.
#include <cmath>
#include <sstream>
#include <vector>

#include "python/bind.h"
#include "sw/analog/analog_layer.h"
#include "sw/common/errors.h"

namespace xbarsim::bindings {

namespace {

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

using Cells = py::array_t<double, py::array::c_style | py::array::forcecast>;

/// f(G) for every cell of the conductances `g` (S; `what` names them in messages), as an array of their shape.
template <typename F>
py::array_t<double> per_cell(const Cells& g, const std::string& what, F f) {
  std::vector<py::ssize_t> shape;
  const Eigen::MatrixXd m = conductance_matrix(g, what, shape);
  return as_array<double>(m.unaryExpr(f).eval(), shape);
}

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

void bind_devices(py::module_& m) {
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
            return per_cell(g, "G_target", [&](double v) { return d.device.program_sigma_s(v); });
          },
          py::arg("G_target"), "The model's programming error sigma (S) for targets G_target (S), before clipping")
      .def(
          "nu",
          [](const PyDevice& d, const Cells& g) {
            const bool drifts = d.device.spec().kind == DeviceKind::Statistical && d.device.spec().stat.drifts;
            return py::make_tuple(per_cell(g, "G_target", [&](double v) { return drifts ? d.device.nu_mean(v) : 0.0; }),
                                  per_cell(g, "G_target", [&](double v) { return drifts ? d.device.nu_std(v) : 0.0; }));
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
}

}  // namespace xbarsim::bindings
