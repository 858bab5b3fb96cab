// xbarsim._core: analog layers: a weight matrix programmed onto crossbars (Crossbar), the DAC's
// full scale, the cells a weight matrix is mapped to, and the training mapper's per-step draws.
#include <cmath>
#include <memory>
#include <mutex>
#include <shared_mutex>

#include "python/bind.h"
#include "sw/analog/analog_layer.h"
#include "sw/analog/calibration.h"
#include "sw/analog/training_draw.h"
#include "sw/common/errors.h"

namespace xbarsim::bindings {

namespace {

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

}  // namespace

void bind_analog(py::module_& m) {
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
}

}  // namespace xbarsim::bindings
