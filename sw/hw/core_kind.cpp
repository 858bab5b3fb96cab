#include "sw/hw/core_kind.h"

#include <algorithm>
#include <cmath>
#include <random>

#include "sw/circuit/crossbar_solver.h"
#include "sw/common/seed.h"
#include "sw/common/yaml_section.h"
#include "sw/hw/hardware_context.h"

namespace xbarsim {

namespace {

/// Column currents into current-mode ADCs shared through sample-and-holds (ISAAC): the layer
/// inventory counts the parts (kCrossbarCoreComponents), the IMA reads in ima.read_ns.
class CrossbarCore final : public CoreKind {
 public:
  void read_ima(Architecture& a, YamlSection& ima, const std::string&) const override {
    a.ima.read_ns = ima.number("read_ns", true);
  }

  void check_machine(const Architecture& a, const std::string& origin) const override {
    if (a.tile.edram_bytes == 0 || a.tile.bus.unit.empty() || !a.chip.has_router() || a.chip.offchip.unit.empty())
      throw InputError(origin + ": a machine of current-mode IMAs needs 'tile.edram', 'tile.bus', 'chip.router' and "
                       "'chip.offchip' (only neuron cores are described without the first three)");
  }

  void configure(HardwareContext& hw, const AnalogConfig& ac) const override {
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
    if (image.dac_bits != ac.converters.dac_bits)
      throw InputError("converters.image_bits (" + std::to_string(image.input_bits) +
                       ") with one read per activation would need DACs of " + std::to_string(image.dac_bits) +
                       " bits for the image, but converters.dac_bits (" + std::to_string(ac.converters.dac_bits) +
                       ") prices every DAC: set converters.dac_bits to at least " + std::to_string(image.input_bits) +
                       ", or stream the image in slices (converters.dac_bits below converters.input_bits)");
  }

  ComponentBreakdown layer_area_mm2(const HardwareContext& hw, const LayerInventory& v) const override {
    return hw.cost.area_mm2(v);
  }
  ComponentBreakdown layer_peak_power_mw(const HardwareContext& hw, const LayerInventory& v) const override {
    return hw.cost.peak_power_mw(v);
  }
  ComponentBreakdown layer_leakage_mw(const HardwareContext& hw, const LayerInventory& v) const override {
    return hw.cost.leakage_mw(v);
  }
  ComponentBreakdown layer_energy_pj(const HardwareContext& hw, const LayerInventory&,
                                     const ActionCounts& a) const override {
    return hw.cost.dynamic_energy_pj(a);
  }
  MachineBill machine_bill(const HardwareContext& hw) const override {
    return price_machine(hw.arch, hw.cost, hw.converters, hw.mapping);
  }
  std::optional<Bill> core_read(const HardwareContext&) const override { return std::nullopt; }
};

/// A voltage-mode integrate-and-convert neuron per column (NeuRRAM): one read's steps and time
/// follow from the precision (neuron_read_steps); the core is priced by its named instances
/// (ima.components), whose actions the read counts; a layer's units are the machine's, priced
/// once in its bill.
class NeuronCore final : public CoreKind {
 public:
  void read_ima(Architecture& a, YamlSection& ima, const std::string& origin) const override {
    if (ima.has("read_ns"))
      throw InputError(ima.where("read_ns") + ": a neuron readout's read time follows from its steps at each "
                       "precision (readout.integrate_ns, adc_step_ns, phase_ns); leave it out");
    if (a.input.kind != InputEncoding::SignMagnitude)
      throw InputError(origin + ": 'readout.kind: neuron' integrates sign-magnitude pulses: set 'input.kind: "
                       "sign_magnitude'");
  }

  void check_machine(const Architecture& a, const std::string& origin) const override {
    // The parts count actions of instances the core must have.
    for (const std::string* role : {&a.readout.adc, &a.readout.integrator, &a.readout.sample, &a.readout.shift_add,
                                    &a.input.wordline})
      if (std::none_of(a.ima.components.begin(), a.ima.components.end(),
                       [&](const Instance& i) { return i.name == *role; }))
        throw InputError(origin + ": the readout and input name instance '" + *role +
                         "', which 'ima.components' does not have");
  }

  void configure(HardwareContext& hw, const AnalogConfig& ac) const override {
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
    const int image_bits = ac.converters.for_layer(true).activation_bits();
    hw.image_read_steps = image_bits == in ? hw.read_steps : hw.arch.read_steps(image_bits, out);
    hw.arch.ima.read_ns = hw.read_steps.time_ns;
    hw.core_pulse_pj_per_bit = input_pulse_pj_per_bit(hw.arch, ac);
    // The datapath is clocked by a read at the activations' precision.
    hw.platform.image_read_cycles =
        static_cast<int>(std::ceil(hw.image_read_steps.time_ns / hw.read_steps.time_ns - 1e-9));
  }

  ComponentBreakdown layer_area_mm2(const HardwareContext&, const LayerInventory&) const override { return {}; }
  ComponentBreakdown layer_peak_power_mw(const HardwareContext&, const LayerInventory&) const override { return {}; }
  ComponentBreakdown layer_leakage_mw(const HardwareContext&, const LayerInventory&) const override { return {}; }
  ComponentBreakdown layer_energy_pj(const HardwareContext& hw, const LayerInventory& v,
                                     const ActionCounts& a) const override {
    return energy_pj(hw, hw.steps_of(v), a);
  }

  /// Each core's named components priced by the named library (area and leakage), the chip
  /// its cores; the peak power every core reading back to back: one whole core's read (every
  /// column converted, every cell read) each read time.
  MachineBill machine_bill(const HardwareContext& hw) const override {
    const Architecture& a = hw.arch;
    MachineBill bill;
    const double cores = static_cast<double>(a.chip.tiles) * a.tile.imas;
    for (const Instance& i : a.ima.components) {
      const Bill b = price(hw.lib.named, {i}, Ledger{}, 0.0);
      bill.ima.push_back({i.name, static_cast<long long>(i.count), b.total_area_mm2(), 0.0, b.total_leakage_mw()});
      bill.chip_area_mm2.parts[i.part] += bill.ima.back().area_mm2 * cores;
      bill.chip_leakage_mw.parts[i.part] += bill.ima.back().leakage_mw * cores;
    }
    bill.tile.push_back({"core", a.tile.imas, a.tile.imas * MachineBill::area(bill.ima), 0.0,
                         a.tile.imas * MachineBill::leakage(bill.ima)});
    bill.chip.push_back({"tile", a.chip.tiles, a.chip.tiles * MachineBill::area(bill.tile), 0.0,
                         a.chip.tiles * MachineBill::leakage(bill.tile)});
    ActionCounts read;
    read.adc_conversions = static_cast<double>(a.crossbar.cols) * a.ima.crossbars;
    read.cell_reads = static_cast<double>(a.crossbar.rows) * a.crossbar.cols * a.ima.crossbars;
    const ComponentBreakdown core_mw = energy_pj(hw, hw.read_steps, read) * (1.0 / a.ima.read_ns);  // pJ/ns = mW
    for (BillLine& l : bill.ima) l.peak_mw = l.leakage_mw;
    bill.ima.push_back({"reads", 1, 0.0, core_mw.total(), 0.0});
    bill.tile.front().peak_mw = a.tile.imas * MachineBill::peak_mw(bill.ima);
    bill.chip.front().peak_mw = a.chip.tiles * MachineBill::peak_mw(bill.tile);
    bill.chip_peak_mw = bill.chip_leakage_mw + core_mw * cores;
    return bill;
  }

  std::optional<Bill> core_read(const HardwareContext& hw) const override {
    const Architecture& a = hw.arch;
    const double xbars = a.ima.crossbars;
    return price(hw.lib.named, a.ima.components,
                 neuron_read_ledger(hw, hw.read_steps, xbars * a.crossbar.cols, xbars * a.crossbar.rows * a.crossbar.cols),
                 hw.read_steps.time_ns);
  }

 private:
  /// The energy (pJ) by part of actions `a` of reads of `steps` (every converted column one
  /// neuron's read).
  static ComponentBreakdown energy_pj(const HardwareContext& hw, const ReadSteps& steps, const ActionCounts& a) {
    const Bill b = price(hw.lib.named, hw.arch.ima.components,
                         neuron_read_ledger(hw, steps, a.adc_conversions, a.cell_reads), 0.0);
    ComponentBreakdown e;
    for (const auto& [part, pj] : b.energy_pj)
      if (pj > 0) e.parts[part] = pj;
    return e;
  }
};

}  // namespace

const CoreKind& core_kind(ReadoutKind k) {
  static const CrossbarCore crossbar;
  static const NeuronCore neuron;
  switch (k) {
    case ReadoutKind::CurrentAdc:
      return crossbar;
    case ReadoutKind::Neuron:
      return neuron;
  }
  throw std::logic_error("core_kind: unknown readout kind");
}

Ledger neuron_read_ledger(const HardwareContext& hw, const ReadSteps& s, double neuron_reads, double cell_reads) {
  const Architecture& arch = hw.arch;
  Ledger l;
  l.add(arch.readout.adc, "step", neuron_reads * static_cast<double>(s.adc_steps));
  l.add(arch.readout.integrator, "step", neuron_reads * static_cast<double>(s.integrate_steps));
  l.add(arch.readout.sample, "sample", neuron_reads * static_cast<double>(s.samples));
  l.add(arch.readout.shift_add, "add", neuron_reads * s.phases);
  l.add(arch.input.wordline, "switch", neuron_reads * arch.input.wordline_switches_per_bit * s.magnitude_bits);
  const double cells = static_cast<double>(arch.crossbar.rows) * arch.crossbar.cols;
  l.energy_pj["input_pulses"] = cell_reads / cells * hw.core_pulse_pj_per_bit * s.magnitude_bits;
  return l;
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
