#pragma once
// What the areas of the xbarsim._core extension share (python/bind_*.cpp, each binding one area
// of the core; python/xbarsim_module.cpp calls them): Ctrl-C-aware GIL release, the
// configuration a call is given, and the device model on arrays (the training mapper draws with it).
#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <optional>
#include <string>

#include "sw/common/cancel.h"
#include "sw/common/config.h"
#include "sw/common/seed.h"
#include "sw/device/device.h"

namespace xbarsim::bindings {

namespace py = pybind11;

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

/// The override `key=value` as --set takes it (a value it cannot write: InputError naming the key).
std::string assignment(const py::handle& k, const py::handle& v);
/// A Python value as the YAML text --set takes, for `key` (InputError naming the key).
std::string value_text(const std::string& key, const py::handle& v);
/// Checks every numeric value (each value of a sweep list too) against its documented range.
void check_ranges(const ConfigTree& cfg);
/// The configuration at `path` (a str or os.PathLike; None or "" for the defaults) with `overrides`.
ConfigTree load_config(const py::handle& path, const py::handle& overrides);
/// The configuration a call was given: a Config, a dict of {'dotted.key': value} overrides of
/// the defaults, or None (the defaults).
ConfigTree config_of(const py::handle& config);

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

/// The areas, each in its file: Config; the crossbar circuit (solve, netlist); the device model
/// (Device); analog layers (Crossbar, the DAC's full scale, the mapping, the training mapper);
/// the network rules eval applies per layer (errors, calibration picks); the datasets (CIFAR-10).
void bind_config(py::module_& m);
void bind_circuit(py::module_& m);
void bind_devices(py::module_& m);
void bind_analog(py::module_& m);
void bind_networks(py::module_& m);
void bind_data(py::module_& m);

}  // namespace xbarsim::bindings
