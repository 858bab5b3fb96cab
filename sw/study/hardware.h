#pragma once
/// The hardware a configuration describes (sw/hw/hardware_context.h) priced for the commands:
/// overhead, eval, xbar-study and simulate count and price the same design the same way.
#include "sw/hw/hardware_context.h"
#include "sw/hw/mapper.h"

namespace xbarsim {

/// Cost of a set of layers per image: areas, leakage and peak power from the inventory;
/// energy = the actions' dynamic energy (closed form per layer, or counted by a simulation)
/// + every unit's leakage over the image time `time_ns`; average power = energy / time.
struct CostReport {
  ComponentBreakdown area_mm2, peak_power_mw, leakage_mw, dynamic_energy_uj;
  double time_ns = 0;  ///< per image
  long long crossbars = 0, adcs = 0, dacs = 0;
  ComponentBreakdown energy_uj() const { return dynamic_energy_uj + leakage_mw * (time_ns * 1e-6); }
  double avg_power_mw() const { return time_ns > 0 ? energy_uj().total() * 1e6 / time_ns : 0.0; }
  nlohmann::json to_json() const;
  /// The inverse of to_json: the breakdowns it holds (energy and average power are derived).
  static CostReport from_json(const nlohmann::json& j);
};

/// Adds one layer (its inventory and the actions of one image) to `r`.
void add_layer_cost(CostReport& r, const HardwareContext& hw, const LayerInventory& v, const ActionCounts& a);

/// On a machine (hw.arch.machine) the area, peak power and leakage of `r` are the whole
/// chip's (its bill, used by the network or not); nothing changes for layer-sized.
void price_whole_machine(CostReport& r, const HardwareContext& hw);
/// Adds the layer-sized platform around the layers: the energy of its actions (bus, memory
/// port, digital operations; counted by simulate, or platform_actions in closed form for eval)
/// and the area and leakage of the bus and its digital units. A machine's platform is part of
/// its whole price (price_whole_machine): nothing is added.
void add_platform_cost(CostReport& r, const HardwareContext& hw, const PlatformActions& p);

/// What a machine's platform does per image besides its IMAs: counted by simulate, in closed
/// form by eval (machine_actions), priced by add_machine_cost.
struct MachineActions {
  double edram_read_bytes = 0;  ///< the layers' input registers loading from eDRAM over the tile bus
  double router_bytes = 0;      ///< bytes x routers crossed on the mesh
  double memory_bytes = 0;      ///< over the off-chip links (the input and the logits)
  /// Per operation of a tile's digital units: the unit's operation name and its operations.
  std::vector<std::pair<std::string, double>> digital_ops;
};
/// The machine actions of one image of `m` on the mapping `mp` of hw's machine, in closed form
/// (machine_traffic for the mesh; none when the network does not fit); `edram_read_bytes` is
/// the layers' (their input shifts).
MachineActions machine_actions(const Model& m, const HardwareContext& hw, const Mapping& mp, double edram_read_bytes);
/// A machine run priced: the whole chip's area, peak power and leakage (price_whole_machine)
/// and the energy of `a` (the tile bus per byte read, the routers per byte and router crossed,
/// the off-chip links per byte, each digital unit per operation). Nothing for layer-sized.
void add_machine_cost(CostReport& r, const HardwareContext& hw, const MachineActions& a);

/// A machine (architecture.machine) with a network mapped onto it: the chip priced from counts
/// x components, where the network's layers sit, and the machine's peak throughput for the
/// configured datapath (weights on cell slices, inputs in reads).
struct MachineReport {
  std::string name;
  int tiles = 0, imas_per_tile = 0, crossbars_per_ima = 0;
  MachineBill bill;
  Mapping mapping;
  /// Operations (2 per MAC) per ns with every crossbar reading: each holds rows x cols /
  /// columns_per_weight weights and finishes a vector every input_slices reads.
  double peak_gops = 0;
  double area_mm2() const { return MachineBill::area(bill.chip); }
  double peak_power_mw() const { return MachineBill::peak_mw(bill.chip); }
  nlohmann::json to_json() const;
};

/// The machine of `hw` (hw.arch.machine) priced, and `m` mapped onto it (dense, with
/// platform.replication); `signed_inputs` per linear layer as linear_inputs_signed.
MachineReport machine_report(const Model& m, const HardwareContext& hw, const std::vector<bool>& signed_inputs);

/// The rule every command applies on a machine (eval, simulate, explore's points, overhead):
/// the network with its replication fits, or InputError "the network does not fit
/// architecture.machine NAME: REASON" (the mapper's reason: the IMAs it needs against the
/// machine's).
void require_fit(const Mapping& mapping, const Architecture& arch);
/// The same before any work: `m` mapped onto hw's machine with its layers' inputs as the graph
/// says (linear_inputs_signed; whether a layer fits does not depend on its input slices).
/// Nothing to check for layer-sized.
void require_fit(const Model& m, const HardwareContext& hw);

}  // namespace xbarsim
