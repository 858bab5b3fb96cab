#include "sw/hw/hardware_context.h"

#include <algorithm>
#include <cmath>
#include <random>

#include "sw/circuit/crossbar_solver.h"
#include "sw/common/seed.h"

namespace xbarsim {

HardwareContext make_hardware_context(const ConfigTree& cfg, const AnalogConfig& ac) {
  HardwareContext hw;
  hw.mapping = ac.mapping;
  hw.converters = ac.converters;
  hw.column_scales = ac.ranging.weight_scale == WeightScale::Column;
  hw.lib = load_component_library(cfg);
  hw.arch = load_architecture(cfg);
  check_crossbar_geometry(hw.arch, ac.mapping);
  hw.columns_per_adc = resolve_columns_per_adc(ac.converters.adc_columns_per_adc, hw.lib.adc_columns_per_unit());
  if (hw.arch.machine) {
    const int shared = hw.arch.columns_per_adc();
    if (ac.converters.adc_columns_per_adc != 0 && ac.converters.adc_columns_per_adc != shared)
      throw InputError("converters.adc_columns_per_adc = " + std::to_string(ac.converters.adc_columns_per_adc) +
                       ", but architecture.machine " + hw.arch.name + " shares each ADC among " +
                       std::to_string(shared) + " columns (its IMA's); set 0 or " + std::to_string(shared));
    hw.columns_per_adc = shared;
  }
  // Crossbar cores: the inventory's parts are priced, each by its component; neuron cores are
  // priced by their own parts (price_machine).
  hw.cost.crossbar_cores = !hw.arch.neuron_cores();
  if (hw.cost.crossbar_cores)
    for (const char* part : kCrossbarCoreComponents)
      if (!hw.lib.named.has(part)) {
        std::string parts;
        for (const char* p : kCrossbarCoreComponents) parts += (parts.empty() ? "" : ", ") + std::string(p);
        throw InputError("components.library " + hw.lib.source + " has no component '" + part +
                         "', which a machine of crossbar cores (architecture.machine " + hw.arch.name +
                         ") prices: the crossbar cores' parts are " + parts +
                         " (configs/components/isaac.yaml); a library of neuron-core parts (neurram) prices "
                         "architecture.machine: neurram");
      }
  const ConvertersSpec image = ac.converters.for_layer(true);  // the converters of a layer reading the image
  if (hw.arch.neuron_cores()) {  // one read's time follows from the precision
    const int in = ac.converters.activation_bits(), out = ac.converters.adc_bits;
    if (in < 1 || out < 1)
      throw InputError("architecture.machine " + hw.arch.name +
                       " reads with neurons whose steps follow the precision: set converters.input_bits (or "
                       "dac_bits) and converters.adc_bits (the output bits), not none");
    if (ac.converters.dac_bits != in)
      throw InputError("architecture.machine " + hw.arch.name + " integrates all of an input's bits in one read: set "
                       "converters.dac_bits to converters.input_bits (" + std::to_string(in) + "), not " +
                       std::to_string(ac.converters.dac_bits));
    hw.read_steps = hw.arch.read_steps(in, out);
    const int image_bits = image.activation_bits();
    hw.image_read_steps = image_bits == in ? hw.read_steps : hw.arch.read_steps(image_bits, out);
    hw.arch.ima.read_ns = hw.read_steps.time_ns;
    hw.core_pulse_pj_per_bit = input_pulse_pj_per_bit(hw.arch, ac);
  } else if (image.dac_bits != ac.converters.dac_bits) {
    throw InputError("converters.image_bits (" + std::to_string(image.input_bits) +
                     ") with one read per activation would need DACs of " + std::to_string(image.dac_bits) +
                     " bits for the image, but converters.dac_bits (" + std::to_string(ac.converters.dac_bits) +
                     ") prices every DAC: set converters.dac_bits to at least " + std::to_string(image.input_bits) +
                     ", or stream the image in slices (converters.dac_bits below converters.input_bits)");
  }
  hw.platform = parse_platform_config(cfg, hw.columns_per_adc, hw.lib.adc_sample_rate_gsps());
  if (hw.arch.neuron_cores())  // the datapath is clocked by a read at the activations' precision
    hw.platform.image_read_cycles =
        static_cast<int>(std::ceil(hw.image_read_steps.time_ns / hw.read_steps.time_ns - 1e-9));
  hw.cost.lib = hw.lib;
  hw.cost.dac_bits = ac.converters.dac_bits;
  hw.cost.dac_lut = ac.dac_predistorts();
  hw.cost.adc_bits = ac.converters.adc_bits;
  hw.cost.clock_mhz = hw.platform.clock_mhz;
  return hw;
}

LayerInventory HardwareContext::inventory(const LinearLayer& L, MappingScheme scheme, bool signed_inputs,
                                          bool reads_image) const {
  LayerInventory v = layer_inventory(L, scheme, mapping, columns_per_adc);
  v.column_scales = column_scales;
  stream_inputs(v, converters.for_layer(reads_image), signed_inputs);
  v.reads_image = reads_image && converters.image_bits != 0;
  return v;
}

double input_pulse_pj_per_bit(const Architecture& arch, const AnalogConfig& given) {
  const AnalogConfig ac = with_device_range(given);
  const InputSpec& in = arch.input;
  const int rows = arch.crossbar.rows, cols = arch.crossbar.cols;
  const int per_weight = ac.mapping.columns_per_weight();
  const double g_lo = ac.xbar.g_min_s, g_hi = ac.xbar.g_max_s * (1 - ac.mapping.g_headroom);
  const int code_bits = ac.mapping.code_bits();
  const double levels = code_bits > 0 ? std::exp2(code_bits) - 1 : 0;  // 0: analog cells
  std::mt19937_64 rng(derive_seed(static_cast<uint64_t>(in.seed), {42}));
  std::normal_distribution<double> normal(0, 1);
  std::uniform_real_distribution<double> uniform(0, 1);
  // Weights: Gaussian, clipped, quantized to the mapping's magnitude codes; a differential
  // weight's cells on adjacent rows driven with opposite pulses (pairs: rows) or in adjacent
  // columns (pairs: columns; the other cell of a pair at g_min); a shift mapping's one cell
  // holding w - w_lo.
  auto level = [&](double x) { return levels > 0 ? std::round(x * levels) / levels : x; };  // x in [0, 1]
  auto cell = [&](double x) { return g_lo + (g_hi - g_lo) * level(x); };
  const bool rows_paired = ac.mapping.differential() && in.pairs_on_rows;
  Eigen::MatrixXd g = Eigen::MatrixXd::Constant(rows, cols, g_lo);
  if (rows_paired) {
    for (int j = 0; j < cols; ++j)
      for (int i = 0; i + 1 < rows; i += 2) {
        const double w = std::clamp(normal(rng) / in.weight_clip_sigma, -1.0, 1.0);
        g(i, j) = cell(std::max(w, 0.0));
        g(i + 1, j) = cell(std::max(-w, 0.0));
      }
  } else {
    for (int j0 = 0; j0 + per_weight <= cols; j0 += per_weight)
      for (int i = 0; i < rows; ++i) {
        const double w = std::clamp(normal(rng) / in.weight_clip_sigma, -1.0, 1.0);
        if (ac.mapping.differential()) {
          g(i, j0) = cell(std::max(w, 0.0));
          g(i, j0 + 1) = cell(std::max(-w, 0.0));
        } else {
          g(i, j0) = cell((w + 1) / 2);
        }
      }
  }
  CrossbarParams p = ac.xbar;
  p.sensing = Sensing::Voltage;  // each column settles onto its neuron's sampling capacitor
  const auto solver = make_crossbar_solver(p, ac.solver);
  solver->program(g);
  double joules = 0;
  for (int k = 0; k < in.vectors; ++k) {
    Eigen::VectorXd v(rows);
    v.setZero();
    if (rows_paired) {  // an input's pulse: +v_read on the G+ row, -v_read on the G- row
      for (int i = 0; i + 1 < rows; i += 2)
        if (uniform(rng) < in.bit_density) v(i) = in.v_read_v, v(i + 1) = -in.v_read_v;
    } else {
      for (int i = 0; i < rows; ++i) v(i) = uniform(rng) < in.bit_density ? in.v_read_v : 0.0;
    }
    // What the drivers deliver: the cells', wires' and access transistors' dissipation.
    joules += source_power_w(solver->solve(v), v) * in.pulse_ns * 1e-9;
  }
  return joules / in.vectors * 1e12;
}

}  // namespace xbarsim
