// xbarsim._core: the rules eval applies to a network's layers: per-layer errors against the
// output range, and which calibration vectors a layer keeps (its picks).
#include <cmath>

#include "python/bind.h"
#include "sw/analog/calibration.h"
#include "sw/analog/error_metrics.h"
#include "sw/common/errors.h"

namespace xbarsim::bindings {

void bind_networks(py::module_& m) {
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
}

}  // namespace xbarsim::bindings
