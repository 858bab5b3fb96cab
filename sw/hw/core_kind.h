#pragma once
/// A core's kind decides its behaviour here, once. The kinds are the readouts of
/// sw/hw/core_parts.h: crossbar cores (column currents into current-mode ADCs shared through
/// sample-and-holds, their parts counted by the layer inventory; ISAAC) and neuron cores (a
/// voltage-mode neuron per column, priced by the core's named instances at the configured
/// precision; NeuRRAM, Wan et al., Nature 2022). A kind says
/// - what its architecture file must give (the IMA's read time or not, the input encoding,
///   the instances its reads count, the buffer, bus, mesh and links its transfers use);
/// - what its component library must price, how one read depends on the precision, and how
///   many datapath cycles a read of the image takes;
/// - how a layer's inventory and actions are priced, the whole machine's bill, and one core's
///   read for the chip's peak figures.
/// Commands ask the architecture's kind (Architecture::core()) and never branch on which one
/// it is; a new kind is a ReadoutKind, its parse in core_parts.cpp and one class in
/// core_kind.cpp.
#include <optional>
#include <string>

#include "sw/hw/core_parts.h"
#include "sw/hw/cost.h"

namespace xbarsim {

struct Architecture;
struct AnalogConfig;
struct HardwareContext;
struct MachineBill;
class YamlSection;

class CoreKind {
 public:
  virtual ~CoreKind() = default;

  // The architecture file (parse_architecture).
  /// Reads the `ima:` section's read time, or refuses it where the kind derives it, and checks
  /// the input encoding its readout needs.
  virtual void read_ima(Architecture& a, YamlSection& ima, const std::string& origin) const = 0;
  /// The whole file read: the instances its reads count and the units its transfers use exist.
  virtual void check_machine(const Architecture& a, const std::string& origin) const = 0;

  // A configuration on the machine (make_hardware_context, after the platform is read).
  /// The library prices what the kind counts, the precision fits the core; resolves what
  /// follows from the precision (a neuron core's read steps, read time, input pulses' energy
  /// and the datapath cycles of a read of the image).
  virtual void configure(HardwareContext& hw, const AnalogConfig& ac) const = 0;

  // Pricing.
  /// A layer's units (its inventory `v`): area, peak power, leakage.
  virtual ComponentBreakdown layer_area_mm2(const HardwareContext& hw, const LayerInventory& v) const = 0;
  virtual ComponentBreakdown layer_peak_power_mw(const HardwareContext& hw, const LayerInventory& v) const = 0;
  virtual ComponentBreakdown layer_leakage_mw(const HardwareContext& hw, const LayerInventory& v) const = 0;
  /// The dynamic energy (pJ) of a layer's actions `a` (one image's, counted or in closed form).
  virtual ComponentBreakdown layer_energy_pj(const HardwareContext& hw, const LayerInventory& v,
                                             const ActionCounts& a) const = 0;
  /// The whole machine (hw.arch.machine) priced, with its units' peak power.
  virtual MachineBill machine_bill(const HardwareContext& hw) const = 0;
  /// One core's read at the configured precision priced (every column read, every cell read;
  /// leakage over the read), for the chip's peak figures; none where the kind has no such read.
  virtual std::optional<Bill> core_read(const HardwareContext& hw) const = 0;
};

/// The behaviour of the cores of readout kind `k`.
const CoreKind& core_kind(ReadoutKind k);

/// Neuron cores: the named actions of `neuron_reads` neuron reads (each converted column one:
/// its parts' steps, its word line's switches at the configured precision) and of `cell_reads`
/// cell reads (each its share of a core's solved input pulses, an energy of part
/// input_pulses), for price() with hw.arch.ima.components.
Ledger neuron_read_ledger(const HardwareContext& hw, const ReadSteps& steps, double neuron_reads, double cell_reads);

/// Energy (pJ) of the input pulses of one magnitude bit on one neuron core: the architecture's
/// workload (weights Gaussian clipped at weight_clip_sigma, quantized to the mapping's bits on
/// its polarities over the device's conductance range; each row pulsed at v_read_v with
/// probability bit_density, else at 0 V), solved in voltage mode with the configured wires
/// and devices, the cells' dissipated power x pulse_ns, averaged over `vectors` draws.
double input_pulse_pj_per_bit(const Architecture& arch, const AnalogConfig& ac);


}  // namespace xbarsim
