#pragma once
/// The machine networks are mapped onto (configuration key architecture.machine), a
/// hierarchy in the style of Timeloop/Accelergy: chip -> tiles (on the routers of a 2-D mesh)
/// -> IMAs -> crossbars, every unit a component of the library (sw/hw/component_library.h)
/// by name. `layer-sized` is no fixed machine: a tile per linear layer, sized to it (the
/// seed paper's setting, and every command's behaviour before machines existed).
/// Architecture files live in configs/architectures/ (built in by name) or anywhere (a path).
#include <string>
#include <utility>
#include <vector>

#include "sw/analog/analog_spec.h"
#include "sw/common/config.h"
#include "sw/hw/components.h"
#include "sw/hw/core_kind.h"
#include "sw/hw/core_parts.h"
#include "sw/hw/cost.h"

namespace xbarsim {

/// A unit of the library instantiated `count` times, each doing up to `actions_per_ns`
/// actions (bytes moved, operations) at its peak; a digital unit also names the network
/// operations it performs (`ops`: relu, affine, add, maxpool, avgpool, globalavgpool,
/// activation (Clip, LeakyRelu, Sigmoid, Tanh, HardSigmoid, HardSwish), softmax).
struct UnitUse {
  std::string unit;
  long long count = 1;
  double actions_per_ns = 0;
  std::vector<std::string> ops;
};

/// The names of the digital operations a tile unit may perform.
const std::vector<std::string>& digital_op_names();

struct Architecture {
  std::string name = "layer-sized";
  std::string source;  ///< the file it was read from ("" for layer-sized)
  bool machine = false;
  struct Crossbar {
    int rows = 0, cols = 0, cell_bits = 0;
  } crossbar;
  struct Ima {
    int crossbars = 0;
    int adcs = 0;        ///< shared by the IMA's physical columns (columns_per_adc each)
    /// One read of every crossbar (DACs, cells, sample-and-holds). A neuron readout derives it
    /// from its steps at the configured precision (read_steps): one file for every precision.
    double read_ns = 0;
    long long input_register_bytes = 0, output_register_bytes = 0;
    /// Named components of an IMA (a core), priced by a named library (sw/hw/components.h):
    /// its neurons' parts, word lines, cells, drivers; the parts count their actions.
    std::vector<Instance> components;
  } ima;
  InputSpec input;      ///< section input: how inputs reach the rows (default bit_serial)
  ReadoutSpec readout;  ///< section readout: how columns are read (default current_adc)
  /// What the cores' kind (their readout) decides: sw/hw/core_kind.h.
  const CoreKind& core() const { return core_kind(readout.kind); }
  /// A neuron core's steps of one read at (input, output) bits.
  ReadSteps read_steps(int input_bits, int output_bits) const {
    return neuron_read_steps(input, readout, input_bits, output_bits);
  }
  struct Tile {
    int imas = 0;
    long long edram_bytes = 0;
    double edram_bytes_per_ns = 0;
    UnitUse bus;
    std::vector<UnitUse> units;  ///< digital units (sigmoid, pooling, shift-and-add, output register)
  } tile;
  struct Chip {
    int tiles = 0;
    int tiles_per_router = 1;
    /// The routers' grid: chip.mesh, or derived (derive_mesh) when the file leaves it out.
    int mesh_rows = 0, mesh_cols = 0;
    /// One per mesh node; actions_per_ns per link. Without chip.router the cores have no mesh:
    /// one node holds every tile (mesh 1 x 1, nothing routed, nothing priced).
    UnitUse router;
    bool has_router() const { return !router.unit.empty(); }
    double hop_ns = 0;  ///< a transfer's head through one router
    UnitUse offchip;    ///< off-chip links
    double offchip_bytes_per_ns() const { return static_cast<double>(offchip.count) * offchip.actions_per_ns; }
    /// The rate of a transfer between tiles: a router link, or (cores without a mesh) the
    /// off-chip links it is relayed through.
    double transfer_bytes_per_ns() const { return has_router() ? router.actions_per_ns : offchip_bytes_per_ns(); }
    long long routers() const { return static_cast<long long>(mesh_rows) * mesh_cols; }
    /// Routers the tiles need: ceil(tiles / tiles_per_router).
    long long routers_needed() const { return (static_cast<long long>(tiles) + tiles_per_router - 1) / tiles_per_router; }
  } chip;
  /// Counts of the machine are 64-bit products of the file's counts (each at most 2^30); the
  /// file's limits (parse_architecture) keep an IMA's columns within 2^30 and the chip's
  /// crossbars within 2^53 (exact as doubles, which price them).
  static constexpr long long kMaxImaColumns = 1LL << 30;
  static constexpr long long kMaxChipCrossbars = 1LL << 53;
  /// Physical columns one ADC serves: the IMA's columns shared by its ADCs.
  int columns_per_adc() const {
    return static_cast<int>(static_cast<long long>(ima.crossbars) * crossbar.cols / ima.adcs);
  }
  long long imas() const { return static_cast<long long>(chip.tiles) * tile.imas; }
  long long crossbars() const { return imas() * ima.crossbars; }
  /// Operations per ns a tile performs of the digital operation `op` (a name of
  /// digital_op_names()): every unit that lists it, at its rate; 0 when none does.
  double ops_per_ns(const std::string& op) const;
};

/// Parses an architecture file; errors name `origin`, the section and the key (unknown or
/// missing keys, non-positive counts or counts above 2^30, an IMA of more than 2^30 columns, a
/// chip of more than 2^53 crossbars, ADCs that do not divide the IMA's columns, a mesh too small
/// for the tiles or with routers that serve no tile). Without chip.mesh the mesh is derived:
/// ceil(tiles / tiles_per_router) routers as rows x cols, rows the largest divisor not above
/// the square root (ISAAC-CE's 42: 6 x 7; a prime count is a line).
Architecture parse_architecture(const std::string& yaml_text, const std::string& origin);

/// The mesh of exactly `routers` routers, as square as a rectangle of them can be: rows the
/// largest divisor of `routers` not above its square root, cols = routers / rows.
std::pair<int, int> derive_mesh(long long routers);

/// The text of configs/architectures/<name>.yaml compiled in, or nullptr.
const char* builtin_architecture_yaml(const char* name);

/// architecture.machine: layer-sized, a built-in machine by name (configs/architectures/
/// <name>.yaml compiled in: isaac-ce), or a YAML file.
Architecture load_architecture(const ConfigTree& cfg);

/// A machine fixes the crossbar: the mapping and the cells must be its (InputError naming the
/// keys to set otherwise, and architecture.machine=layer-sized to vary them). Nothing to check
/// for layer-sized.
void check_crossbar_geometry(const Architecture& arch, const MappingSpec& mapping);

/// One line of a bill of materials: `count` units of one kind and their area and peak power
/// (every unit at its highest action rate, plus leakage).
struct BillLine {
  std::string unit;
  long long count = 0;
  double area_mm2 = 0, peak_mw = 0, leakage_mw = 0;
};

/// A machine priced from counts x components: the units of one IMA, of one tile (its IMAs as
/// one line, then its own units and its share of the routers) and of the chip (its tiles as
/// one line, then the off-chip links).
struct MachineBill {
  std::vector<BillLine> ima, tile, chip;
  /// The whole chip by component class (the IMAs' units in theirs; eDRAM as buffer; buses and
  /// routers as interconnect; tile units as digital; off-chip links as memory).
  ComponentBreakdown chip_area_mm2, chip_peak_mw, chip_leakage_mw;
  static double area(const std::vector<BillLine>& lines);
  static double peak_mw(const std::vector<BillLine>& lines);
  static double leakage(const std::vector<BillLine>& lines);
};

/// Prices `arch`, a machine of crossbar cores, with `cost` (the library and the converters'
/// resolutions; CoreKind::machine_bill prices every kind); the IMA's reads
/// are streamed as `converters` and `mapping` say (bit-serial inputs or sliced weights: its
/// shift-and-add units and output register work at the ADCs' rate).
MachineBill price_machine(const Architecture& arch, const CostModel& cost, const ConvertersSpec& converters,
                          const MappingSpec& mapping);

}  // namespace xbarsim
