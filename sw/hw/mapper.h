#pragma once
/// The mapper: a network's linear layers onto a machine's fixed crossbars, IMAs and tiles.
/// A copy of a layer takes the crossbars the counting rule gives it (sw/hw/inventory.h, with
/// its slices) in whole IMAs (an IMA's input register and ADCs serve one layer); IMAs are
/// taken in network order, copies after one another, tile by tile, so a layer may span
/// tiles and a tile may hold several layers. Replication (platform.replication, per layer,
/// or auto) makes copies that share a layer's iterations; auto balances the pipeline by
/// stage times that include the interconnect. A network that does not fit is a status with
/// its reason, not an error.
#include <nlohmann/json.hpp>

#include <string>
#include <vector>

#include "sw/hw/architecture.h"
#include "sw/hw/inventory.h"
#include "sw/hw/mesh.h"
#include "sw/hw/platform_spec.h"

namespace xbarsim {

struct LayerPlacement {
  std::string name;
  long long crossbars = 0;  ///< one copy
  long long imas = 0;       ///< one copy: ceil(crossbars / crossbars per IMA)
  int replication = 1;
  long long first_ima = -1;  ///< chip-wide index of its first IMA (its copies follow one another); -1: not placed
  /// Per image, the estimate of the time its copies compute: the closed form of its tile's
  /// busiest unit (platform/Tile.h, modules/TileUnit.h, with machine_platform's timing): each
  /// unit holds an iteration for whole cycles (input register shifts, DACs, the crossbars'
  /// read, the ADCs' conversions (adc_read_ns, k crossbars sharing an ADC: k times a
  /// crossbar's columns), accumulation; slices x a read for the per-read units); per row
  /// group (platform.grain_rows output rows) the copies take contiguous shares of its
  /// iterations; the busiest unit of the busiest copy counts. The simulation's busy time (what
  /// that unit worked) is the same by construction; the pipeline's fill, stalls and waits for
  /// inputs, which the estimate leaves out, show in the simulated period.
  double compute_ns = 0;
  double iteration_ns = 0;  ///< an iteration that does not reload its input register at its busiest unit
  /// Per image: its input activations over one router link (replication does not shorten it).
  double input_ns = 0;
  double stage_ns() const { return compute_ns > input_ns ? compute_ns : input_ns; }
  double cell_utilization = 0;  ///< cells its weights use / cells of its IMAs
  long long last_ima() const { return first_ima + imas * replication - 1; }
};

/// A digital operation of the network (ReLU, Add, pooling, ...) as the simulation runs it: on
/// the tile its first input comes from, by the tile's units that list it (tile.units.*.ops), all
/// of them at their summed rate (Architecture::ops_per_ns).
struct DigitalPlacement {
  std::string name;
  std::string operation;  ///< its unit operation (digital_op_name), "" when it only moves data
  long long ops = 0;      ///< per image
  double busy_ns = 0;     ///< per image: ops / the tile's rate for it (0: moves data, or no unit performs it)
  int tile = -1;
};

struct Mapping {
  std::string machine;
  bool fits = true;
  std::string reason;  ///< why it does not fit
  std::vector<LayerPlacement> layers;
  long long imas_used = 0, imas_available = 0, tiles_used = 0, tiles_available = 0;  ///< 64-bit: tiles x IMAs
  double cell_utilization = 0;  ///< cells the weights use / cells of the chip
  int bottleneck = -1;          ///< the linear layer with the longest stage (-1: none)
  std::vector<DigitalPlacement> digital;  ///< with the model: its digital operations, in network order
  /// The stage predicted to bound the pipeline: the longest of every linear layer's stage and
  /// every digital operation's busy time (the simulation reports the one it measured).
  std::string bottleneck_stage;
  double bottleneck_ns = 0;
  long long imas_per_tile = 0;
  /// The tile holding the chip-wide IMA `ima`.
  int tile_of(long long ima) const { return imas_per_tile ? static_cast<int>(ima / imas_per_tile) : 0; }
  nlohmann::json to_json() const;
};

/// The estimate of LayerPlacement::compute_ns for `copies` copies of a layer (inventory `v`,
/// one copy) timed with `pc` (a machine's: machine_platform), on a machine or not.
double estimated_compute_ns(const LayerInventory& v, const LinearLayer* L, const MappingSpec* mapping,
                            const PlatformConfig& pc, int copies);

/// Places `layers` (the inventory of each linear layer, in network order, one copy) on
/// `arch` with the replication `pc` asks for (platform.replication: a number, per layer, or
/// auto: copies of the slowest compute-bound stage while IMAs remain), timed with
/// machine_platform(pc, arch). `model` (whose linear layers `layers` are) adds the input
/// register's shifts to the iterations' timing and plans its digital operations; `mapping`
/// gives the crossbars' exact widths (without it: the column blocks' average).
Mapping map_network(const std::vector<LayerInventory>& layers, const Architecture& arch, const PlatformConfig& pc,
                    const Model* model = nullptr, const MappingSpec* mapping = nullptr);

/// The name a machine's digital units list an operation by (tile.units.<unit>.ops), or "" for
/// operations that only move data (and linear layers, which are the IMAs').
const char* digital_op_name(OpKind k);

/// Where a network's operations sit on a machine with mapping `mp`: per operation, the tiles
/// its input buffers live on, the first being the one its outputs leave from. A linear layer
/// sits on the tiles of its IMAs (its inputs are sent to all of them); any other operation on
/// the tile its first input comes from (the network's input enters at router 0: tile 0).
std::vector<std::vector<int>> place_operations(const Model& m, const Mapping& mp);

/// Per image, what a mapped network moves between tiles, in closed form, as the simulation
/// sends it: every value from its producer's tile (the network's input from the off-chip port,
/// tile -1) to the tiles of its consumers' buffers (the logits to the off-chip port), as one
/// multicast over the mesh, or within the tile (its eDRAM) when every consumer is there.
struct MachineTraffic {
  double noc_bytes = 0;     ///< bytes injected into the mesh
  double router_bytes = 0;  ///< bytes x routers crossed (every link of a multicast tree but its injection)
  double local_bytes = 0;   ///< bytes that stayed on their tile
};
MachineTraffic machine_traffic(const Model& m, const std::vector<std::vector<int>>& op_tiles, const MeshGeometry& mesh,
                               int activation_bytes);

}  // namespace xbarsim
