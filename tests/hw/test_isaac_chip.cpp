// configs/architectures/isaac-ce.yaml priced by configs/components/isaac.yaml against ISAAC's
// published chip (Shafiee et al., ISCA 2016, Table 6): 168 tiles of 12 IMAs, the tile's
// digital units and eDRAM, a router per 4 tiles, HyperTransport. Counts x components must
// give the published figures within 1 %; the figures are typed here, not read from a file.
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>

#include "sw/common/config.h"
#include "sw/hw/architecture.h"
#include "sw/hw/mapper.h"
#include "sw/nn/network.h"
#include "sw/nn/presets.h"
#include "sw/study/hardware.h"

using namespace xbarsim;

namespace {

struct Published {
  double power_mw, area_mm2;
};
// ISAAC Table 6.
constexpr Published kIma{24.08, 0.0131}, kImas{289, 0.157}, kTileDigital{40.9, 0.215}, kTile{330, 0.372},
    kChip{65.8e3, 85.4}, kHyperTransport{10.4e3, 22.88};
constexpr double kAdcPerIma = 16;  // mW: 8 ADCs
constexpr Published kEdram{20.7, 0.083}, kBus{7, 0.090}, kRouterPerFourTiles{42, 0.151}, kSigmoid{0.52, 0.0006},
    kShiftAdd{0.05, 0.00006}, kMaxPool{0.4, 0.00024}, kOutputRegister{1.68, 0.0032};

struct Isaac {
  /// configs/isaac.yaml as it is (it selects architecture.machine: isaac-ce and ISAAC's
  /// library and datapath), at ISAAC-CE's 16-bit inputs and weights.
  Isaac() {
    const ConfigTree cfg = ConfigTree::load(std::string(XBARSIM_SOURCE_DIR) + "/configs/isaac.yaml",
                                            {"converters.input_bits=16", "mapping.weight_bits=16"});
    arch = load_architecture(cfg);
    cost.lib = load_component_library(cfg);
    const AnalogConfig ac = parse_analog_config(cfg);
    converters = ac.converters;
    mapping = ac.mapping;
    cost.dac_bits = converters.dac_bits;
    cost.adc_bits = converters.adc_bits;
    // The datapath ISAAC's Table 6 prices: 1-bit DACs, 8-bit ADCs, 128 x 128 crossbars of
    // 2-bit cells.
    EXPECT_EQ(arch.name, "isaac-ce");
    EXPECT_EQ(converters.dac_bits, 1);
    EXPECT_EQ(converters.adc_bits, 8);
    EXPECT_EQ(mapping.max_rows, 128);
    EXPECT_EQ(mapping.max_cols, 128);
    EXPECT_EQ(mapping.cell_bits, 2);
    bill = price_machine(arch, cost, converters, mapping);
  }
  const BillLine& line(const std::vector<BillLine>& lines, const std::string& unit) const {
    for (const BillLine& l : lines)
      if (l.unit == unit) return l;
    throw std::out_of_range(unit);
  }
  Architecture arch;
  CostModel cost;
  ConvertersSpec converters;
  MappingSpec mapping;
  MachineBill bill;
};

void expect_within_1_percent(double got, double published, const std::string& what) {
  EXPECT_NEAR(got, published, 0.01 * published) << what;
}

}  // namespace

TEST(IsaacChip, CountsOfTheMachine) {
  const Isaac m;
  EXPECT_EQ(m.arch.chip.tiles, 168);
  EXPECT_EQ(m.arch.tile.imas, 12);
  EXPECT_EQ(m.arch.ima.crossbars, 8);
  EXPECT_EQ(m.arch.crossbars(), 168 * 12 * 8);
  EXPECT_EQ(m.arch.chip.routers(), 42);  // one per 4 tiles
  EXPECT_EQ(m.arch.columns_per_adc(), 128);
  EXPECT_EQ(m.line(m.bill.ima, "dac").count, 8 * 128);
  EXPECT_EQ(m.line(m.bill.ima, "sample_hold").count, 8 * 128);
  EXPECT_EQ(m.line(m.bill.ima, "shift_add").count, 4);
  EXPECT_EQ(m.line(m.bill.chip, "hypertransport").count, 4);
}

TEST(IsaacChip, ImaTileAndChipEqualThePublishedFigures) {
  const Isaac m;
  const double ima_mw = MachineBill::peak_mw(m.bill.ima), ima_mm2 = MachineBill::area(m.bill.ima);
  expect_within_1_percent(ima_mw, kIma.power_mw, "IMA power");
  expect_within_1_percent(ima_mm2, kIma.area_mm2, "IMA area");
  const BillLine& imas = m.line(m.bill.tile, "ima");
  expect_within_1_percent(imas.peak_mw, kImas.power_mw, "12 IMAs power");
  expect_within_1_percent(imas.area_mm2, kImas.area_mm2, "12 IMAs area");
  const double tile_mw = MachineBill::peak_mw(m.bill.tile), tile_mm2 = MachineBill::area(m.bill.tile);
  expect_within_1_percent(tile_mw - imas.peak_mw, kTileDigital.power_mw, "tile digital power");
  expect_within_1_percent(tile_mm2 - imas.area_mm2, kTileDigital.area_mm2, "tile digital area");
  expect_within_1_percent(tile_mw, kTile.power_mw, "tile power");
  expect_within_1_percent(tile_mm2, kTile.area_mm2, "tile area");
  expect_within_1_percent(MachineBill::peak_mw(m.bill.chip), kChip.power_mw, "chip power");
  expect_within_1_percent(MachineBill::area(m.bill.chip), kChip.area_mm2, "chip area");
  // The chip by component class adds up to the same totals.
  EXPECT_NEAR(m.bill.chip_area_mm2.total(), MachineBill::area(m.bill.chip), 1e-9);
  EXPECT_NEAR(m.bill.chip_peak_mw.total(), MachineBill::peak_mw(m.bill.chip), 1e-6);
  EXPECT_NEAR(m.bill.chip_peak_mw.adc, 168 * 12 * kAdcPerIma, 1e-6);
}

TEST(IsaacChip, EveryTileUnitEqualsItsPublishedFigure) {
  const Isaac m;
  const std::pair<const char*, Published> units[] = {{"edram", kEdram},     {"tile_bus", kBus},
                                                     {"sigmoid", kSigmoid}, {"tile_shift_add", kShiftAdd},
                                                     {"maxpool", kMaxPool}, {"tile_output_register", kOutputRegister}};
  for (const auto& [unit, published] : units) {
    expect_within_1_percent(m.line(m.bill.tile, unit).peak_mw, published.power_mw, std::string(unit) + " power");
    expect_within_1_percent(m.line(m.bill.tile, unit).area_mm2, published.area_mm2, std::string(unit) + " area");
  }
  // A router per four tiles: each tile carries a quarter of one.
  expect_within_1_percent(m.line(m.bill.tile, "router share").peak_mw, kRouterPerFourTiles.power_mw / 4, "router");
  expect_within_1_percent(m.line(m.bill.tile, "router share").area_mm2, kRouterPerFourTiles.area_mm2 / 4, "router");
  expect_within_1_percent(m.line(m.bill.chip, "hypertransport").peak_mw, kHyperTransport.power_mw, "HT power");
  expect_within_1_percent(m.line(m.bill.chip, "hypertransport").area_mm2, kHyperTransport.area_mm2, "HT area");
}

TEST(Architecture, BadFilesAreRefusedWithTheKey) {
  const std::string good = builtin_architecture_yaml("isaac-ce");
  auto refused = [&](const std::string& from, const std::string& to, const std::string& says) {
    std::string text = good;
    const size_t at = text.find(from);
    ASSERT_NE(at, std::string::npos) << from;
    text.replace(at, from.size(), to);
    try {
      parse_architecture(text, "arch.yaml");
      ADD_FAILURE() << "accepted: " << to;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(says), std::string::npos) << e.what();
    }
  };
  refused("  adcs: 8 ", "  adcs: 7 ", "'ima.adcs' = 7 must divide");
  refused("  tiles: 168", "  tiles: 169\n  mesh: {rows: 6, cols: 7}", "do not fit the mesh");
  refused("  crossbars: 8", "  crossbars: 0", "'ima.crossbars' must be a positive");
  refused("  imas: 12", "  imas: 12\n  imaz: 3", "unknown key 'tile.imaz'");
  refused("    unit: tile_bus\n", "", "missing key 'tile.bus.unit'");
}

TEST(Architecture, AMachineFixesTheCrossbarGeometry) {
  ConfigTree cfg;
  cfg.set("architecture.machine", "isaac-ce");
  const Architecture arch = load_architecture(cfg);
  MappingSpec m;
  m.max_rows = 144;
  m.max_cols = 128;
  try {
    check_crossbar_geometry(arch, m);
    ADD_FAILURE() << "a 144-row mapping accepted on 128-row crossbars";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("mapping.max_rows"), std::string::npos) << e.what();
  }
  // Cells of 1 bit (a sweep of crossbar.cell_bits on configs/isaac.yaml): the message says how
  // to vary them, on the layer-sized platform (issue 39, item 7).
  m.max_rows = 128;
  m.cell_bits = 1;
  try {
    check_crossbar_geometry(arch, m);
    ADD_FAILURE() << "1-bit cells accepted on a machine of 2-bit cells";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("crossbar.cell_bits 1"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("--set architecture.machine=layer-sized"), std::string::npos) << e.what();
  }
  m.cell_bits = 2;
  EXPECT_NO_THROW(check_crossbar_geometry(arch, m));
  EXPECT_NO_THROW(check_crossbar_geometry(Architecture{}, MappingSpec{}));  // layer-sized
}

namespace {

/// A machine of 2 tiles x 2 IMAs x 2 crossbars of 8 x 8 cells, a read per 10 ns, links of
/// 1 byte/ns.
Architecture toy_machine() {
  Architecture a;
  a.name = "toy";
  a.machine = true;
  a.crossbar = {8, 8, 2};
  a.ima = {2, 2, 10.0, 16, 16};
  a.tile.imas = 2;
  a.chip.tiles = 2;
  a.chip.mesh_rows = 1;
  a.chip.mesh_cols = 2;
  a.chip.router = {"router", 1, 1.0, {}};
  return a;
}

/// A layer of `crossbars` crossbars, `iterations` reads of `slices` slices, an input of
/// `input_values` values, `cells` cells used.
LayerInventory toy_layer(const std::string& name, long long crossbars, long long iterations, int slices,
                         int input_values, long long cells) {
  LayerInventory v;
  v.name = name;
  v.crossbars = crossbars;
  v.iterations = iterations;
  v.input_slices = slices;
  v.input = Shape{1, 1, input_values};
  v.cells_used = cells;
  return v;
}

}  // namespace

TEST(Mapper, PlacesCopiesInWholeImasInNetworkOrder) {
  const Architecture a = toy_machine();
  PlatformConfig pc;
  pc.detailed = false;  // ideal timing: a read per read_ns, no fill (detailed: PlansIsaacCe... below)
  pc.replication_per_layer = {1, 2};
  // Layer a: 3 crossbars -> 2 IMAs; layer b: 1 crossbar -> 1 IMA, two copies.
  const Mapping m = map_network({toy_layer("a", 3, 16, 2, 100, 3 * 64), toy_layer("b", 1, 4, 1, 50, 40)}, a, pc);
  ASSERT_TRUE(m.fits) << m.reason;
  EXPECT_EQ(m.layers[0].imas, 2);
  EXPECT_EQ(m.layers[0].first_ima, 0);
  EXPECT_EQ(m.layers[1].imas, 1);
  EXPECT_EQ(m.layers[1].first_ima, 2);
  EXPECT_EQ(m.tile_of(m.layers[1].last_ima()), 1);
  EXPECT_EQ(m.imas_used, 4);
  EXPECT_EQ(m.tiles_used, 2);
  // Cells: a uses 192 of its 2 IMAs' 256; the chip's 4 IMAs hold 512, the weights 192 + 2 x 40.
  EXPECT_DOUBLE_EQ(m.layers[0].cell_utilization, 192.0 / 256.0);
  EXPECT_DOUBLE_EQ(m.cell_utilization, (192.0 + 80.0) / 512.0);
  // Stage times: a = 16 reads x 2 slices x 10 ns = 320 ns (input 100 bytes over 1 byte/ns:
  // 100 ns); b = ceil(4 / 2) x 1 x 10 = 20 ns of compute, 50 ns of input.
  EXPECT_DOUBLE_EQ(m.layers[0].stage_ns(), 320.0);
  EXPECT_DOUBLE_EQ(m.layers[1].compute_ns, 20.0);
  EXPECT_DOUBLE_EQ(m.layers[1].stage_ns(), 50.0);
  EXPECT_EQ(m.bottleneck, 0);
}

TEST(Mapper, AutoReplicationCopiesTheSlowestComputeBoundStageWhileImasRemain) {
  const Architecture a = toy_machine();
  PlatformConfig pc;
  pc.detailed = false;
  pc.auto_replication = true;
  // a: 1 IMA, 320 ns; b: 1 IMA, 10 ns. Two IMAs remain: a gets both (320 -> 160 -> 107 ns:
  // ceil(16 / 3) = 6 reads of 2 slices = 120 ns).
  const Mapping m = map_network({toy_layer("a", 1, 16, 2, 10, 64), toy_layer("b", 1, 1, 1, 5, 64)}, a, pc);
  ASSERT_TRUE(m.fits);
  EXPECT_EQ(m.layers[0].replication, 3);
  EXPECT_EQ(m.layers[1].replication, 1);
  EXPECT_DOUBLE_EQ(m.layers[0].compute_ns, 120.0);
  EXPECT_EQ(m.imas_used, 4);
  // A stage bound by its input link is not copied: a's input takes 400 ns.
  const Mapping n = map_network({toy_layer("a", 1, 16, 2, 400, 64), toy_layer("b", 1, 1, 1, 5, 64)}, a, pc);
  EXPECT_EQ(n.layers[0].replication, 1);
  EXPECT_EQ(n.bottleneck, 0);
}

TEST(Mapper, CopiesShareARowGroupsIterationsAndSpareImasGoToTheNextSlowest) {
  const Architecture a = toy_machine();
  PlatformConfig pc;
  pc.detailed = false;
  pc.auto_replication = true;  // grain_rows 1: a layer's copies share one output row at a time
  // a: 4 rows of 2 iterations, 4 x 2 x 10 = 80 ns; b: 1 row of 4 iterations, 40 ns. a takes a
  // second copy (4 x 1 x 10 = 40 ns) and can use no third (a row has 2 iterations); the two
  // IMAs left go to b, which a third copy could not speed up further: ceil(4 / 2) x 10 = 20 ns.
  LayerInventory la = toy_layer("a", 1, 8, 1, 1, 64), lb = toy_layer("b", 1, 4, 1, 1, 64);
  la.output = Shape{1, 4, 2};
  lb.output = Shape{1, 1, 4};
  const Mapping m = map_network({la, lb}, a, pc);
  ASSERT_TRUE(m.fits);
  EXPECT_EQ(m.layers[0].replication, 2);
  EXPECT_DOUBLE_EQ(m.layers[0].compute_ns, 40.0);
  EXPECT_EQ(m.layers[1].replication, 2);
  EXPECT_DOUBLE_EQ(m.layers[1].compute_ns, 20.0);
  EXPECT_EQ(m.imas_used, 4);
  // Two output rows per transaction: a's copies share 4 iterations. A third copy would take
  // none off a copy's share (ceil(4 / 3) = 2), a fourth would: it gets none, b gets a second.
  pc.grain_rows = 2;
  const Mapping g = map_network({la, lb}, a, pc);
  EXPECT_EQ(g.layers[0].replication, 2);
  EXPECT_EQ(g.layers[1].replication, 2);
}

TEST(Mapper, ANetworkThatDoesNotFitIsAStatusWithItsReason) {
  const Architecture a = toy_machine();
  const Mapping m = map_network({toy_layer("a", 7, 1, 1, 1, 1), toy_layer("b", 2, 1, 1, 1, 1)}, a, PlatformConfig{});
  EXPECT_FALSE(m.fits);  // 4 + 1 IMAs on a chip of 4
  EXPECT_NE(m.reason.find("needs 5 IMAs (9 crossbars"), std::string::npos) << m.reason;
  EXPECT_NE(m.reason.find("toy has 4"), std::string::npos) << m.reason;
}

// ISAAC's peak computational efficiency (Section VIII-B: 479 GOPS/s/mm^2 for ISAAC-CE, 16-bit
// weights and inputs): every crossbar holds 128 x 16 weights and finishes a vector every 16
// reads of 100 ns, over the chip's area.
TEST(IsaacChip, PeakComputationalEfficiencyIsThePublishedOne) {
  const ConfigTree cfg = ConfigTree::load(std::string(XBARSIM_SOURCE_DIR) + "/configs/isaac.yaml",
                                          {"converters.input_bits=16", "mapping.weight_bits=16"});
  const AnalogConfig ac = parse_analog_config(cfg);
  const HardwareContext hw = make_hardware_context(cfg, ac);
  const Model m = make_preset("resnet20", 3);
  const MachineReport r = machine_report(m, hw, linear_inputs_signed(m));
  EXPECT_NEAR(r.peak_gops, 41.3e3, 0.01 * 41.3e3);  // 16128 crossbars x 2 x 2048 MACs / 1.6 us
  expect_within_1_percent(r.peak_gops / r.area_mm2(), 479, "GOPS/s/mm^2");
  EXPECT_TRUE(r.mapping.fits);
}

// Every operation that computes has a unit name an architecture can list (tile.units.*.ops),
// and the built-in ISAAC-CE has a unit for each (a network with Mul, Div or Sub of two values,
// as MobileNetV3's, runs on it).
TEST(Mapper, EveryComputingOperationHasAUnitNameArchitecturesAccept) {
  const Architecture ce = parse_architecture(builtin_architecture_yaml("isaac-ce"), "isaac-ce");
  for (const std::string& name : digital_op_names()) EXPECT_GT(ce.ops_per_ns(name), 0) << name;
  for (OpKind k : {OpKind::Linear, OpKind::Relu, OpKind::Add, OpKind::Sub, OpKind::Mul, OpKind::Div, OpKind::MaxPool,
                   OpKind::AvgPool, OpKind::GlobalAvgPool, OpKind::Flatten, OpKind::Slice, OpKind::Pad, OpKind::Affine,
                   OpKind::Activation, OpKind::Softmax, OpKind::Concat, OpKind::Shuffle}) {
    const std::string name = digital_op_name(k);
    if (name.empty()) continue;
    const auto& names = digital_op_names();
    EXPECT_NE(std::find(names.begin(), names.end(), name), names.end()) << name;
  }
}

namespace {

/// An architecture file: ISAAC-CE's units with the counts given; `mesh` is the chip.mesh
/// section's text ("" leaves it out).
std::string machine_yaml(long long tiles, long long imas, long long crossbars, long long adcs,
                         const std::string& mesh = "", long long tiles_per_router = 4) {
  return "name: m\ncrossbar: {rows: 128, cols: 128, cell_bits: 2}\n"
         "ima: {crossbars: " + std::to_string(crossbars) + ", adcs: " + std::to_string(adcs) +
         ", read_ns: 100, input_register_bytes: 2048, output_register_bytes: 256}\n"
         "tile:\n  imas: " + std::to_string(imas) +
         "\n  edram: {kib: 64, bytes_per_ns: 38.4}\n  bus: {unit: tile_bus, bytes_per_ns: 38.4}\n"
         "  units:\n    sigmoid: {count: 2, actions_per_ns: 1.2, ops: [relu, affine, activation, softmax]}\n"
         "    maxpool: {count: 1, actions_per_ns: 1.2, ops: [maxpool, avgpool, globalavgpool]}\n"
         "    tile_shift_add: {count: 1, actions_per_ns: 1.2, ops: [add]}\n"
         "    tile_output_register: {count: 1, actions_per_ns: 1.2}\n"
         "chip:\n  tiles: " + std::to_string(tiles) + "\n  tiles_per_router: " + std::to_string(tiles_per_router) +
         "\n" + (mesh.empty() ? "" : "  mesh: " + mesh + "\n") +
         "  router: {unit: router, bytes_per_ns: 38.4, hop_ns: 0.8333}\n"
         "  offchip: {unit: hypertransport, count: 4, bytes_per_ns: 6.4}\n";
}

std::string refusal(const std::string& yaml) {
  try {
    parse_architecture(yaml, "arch.yaml");
  } catch (const InputError& e) {
    return e.what();
  }
  return "(accepted)";
}

}  // namespace

// Issue 38 item 2: the machine's counts are 64-bit products of the file's counts (each at most
// 2^30); a product beyond 2^53 is refused naming its keys. (Before: tiles x IMAs wrapped in
// 32 bits: 1.68e11 IMAs reported as 496275456, 1e9 tiles x 12 IMAs as -884901888.)
TEST(Architecture, MachineCountsAreSixtyFourBitProducts) {
  PlatformConfig pc;
  const LayerInventory one = [] {
    LayerInventory v;
    v.name = "l";
    v.crossbars = 8;
    v.iterations = 1;
    v.input = Shape{1, 1, 1};
    v.cells_used = 1;
    return v;
  }();
  // 14e6 tiles of 12000 IMAs on a 1750 x 2000 mesh of routers of 4 tiles (every router used).
  const Architecture big = parse_architecture(machine_yaml(14000000, 12000, 8, 8, "{rows: 1750, cols: 2000}"), "a");
  EXPECT_EQ(big.crossbars(), 14000000LL * 12000 * 8);
  const Mapping m = map_network({one}, big, pc);
  EXPECT_TRUE(m.fits) << m.reason;
  EXPECT_EQ(m.imas_available, 168000000000LL);
  // 1e9 tiles (the mesh derived: 2.5e8 routers).
  const Architecture giga = parse_architecture(machine_yaml(1000000000, 12, 8, 8), "a");
  EXPECT_EQ(giga.chip.routers(), 250000000LL);
  const Mapping g = map_network({one}, giga, pc);
  EXPECT_TRUE(g.fits) << g.reason;
  EXPECT_EQ(g.imas_available, 12000000000LL);
  EXPECT_EQ(g.tiles_available, 1000000000LL);
  // Limits: a count above 2^30, and products above 2^53, are refused naming the key.
  EXPECT_NE(refusal(machine_yaml(2000000000, 12, 8, 8)).find("'chip.tiles' must be a positive integer at most 1073741824"),
            std::string::npos)
      << refusal(machine_yaml(2000000000, 12, 8, 8));
  const std::string chip = refusal(machine_yaml(1 << 30, 1 << 30, 8, 8));
  EXPECT_NE(chip.find("arch.yaml: the chip's crossbars ('chip.tiles' x 'tile.imas' x 'ima.crossbars')"),
            std::string::npos)
      << chip;
  EXPECT_NE(chip.find("at most 2^53"), std::string::npos) << chip;
  const std::string ima = refusal(machine_yaml(4, 1, 1 << 30, 1 << 30));
  EXPECT_NE(ima.find("an IMA's columns ('ima.crossbars' x 'crossbar.cols') = 137438953472"), std::string::npos) << ima;
}

// Issue 38 item 12: the mesh is derived from tiles / tiles_per_router when not given (21
// routers for 84 tiles, as 3 x 7), and a given mesh with a router that serves no tile is
// refused. Prices from ISAAC's published unit figures (Table 6), counted by hand: 84 tiles of
// 12 IMAs, eDRAM, bus, 2 sigmoid, shift-and-add, max-pool, output register; 21 routers; 4
// HyperTransport links = 54.17 mm^2 (with the 42 routers of 6 x 7: 57.34 mm^2).
TEST(Architecture, TheMeshServesTheTilesAndIsDerivedWhenNotGiven) {
  // The 6 x 7 mesh left in place for 84 tiles: 21 of its routers would serve none.
  const std::string why = refusal(machine_yaml(84, 12, 8, 8, "{rows: 6, cols: 7}"));
  EXPECT_NE(why.find("'chip.mesh'"), std::string::npos) << why;
  EXPECT_NE(why.find("21 of its 42 routers serve no tile"), std::string::npos) << why;
  const Architecture a = parse_architecture(machine_yaml(84, 12, 8, 8), "a");
  EXPECT_EQ(a.chip.routers(), 21);
  EXPECT_EQ(a.chip.mesh_rows, 3);
  EXPECT_EQ(a.chip.mesh_cols, 7);
  const Isaac isaac;  // ISAAC's library and datapath
  const MachineBill bill = price_machine(a, isaac.cost, isaac.converters, isaac.mapping);
  const double tile_mm2 = kImas.area_mm2 + kEdram.area_mm2 + kBus.area_mm2 + 2 * kSigmoid.area_mm2 +
                          kShiftAdd.area_mm2 + kMaxPool.area_mm2 + kOutputRegister.area_mm2;
  const double chip_mm2 = 84 * tile_mm2 + 21 * kRouterPerFourTiles.area_mm2 + kHyperTransport.area_mm2;
  EXPECT_NEAR(chip_mm2, 54.17, 0.01);
  expect_within_1_percent(MachineBill::area(bill.chip), chip_mm2, "84-tile chip area");
  // ISAAC-CE's 168 tiles derive its published 6 x 7 mesh.
  const Architecture ce = parse_architecture(machine_yaml(168, 12, 8, 8), "a");
  EXPECT_EQ(ce.chip.mesh_rows, 6);
  EXPECT_EQ(ce.chip.mesh_cols, 7);
  // 83 tiles: 21 routers, the last serving 3.
  EXPECT_EQ(parse_architecture(machine_yaml(83, 12, 8, 8), "a").chip.routers(), 21);
  EXPECT_EQ(parse_architecture(machine_yaml(84, 12, 8, 8, "{rows: 7, cols: 3}"), "a").chip.routers(), 21);
}

// Issue 38 item 12: an ADC's conversions are actions (a read converts every physical column of
// the IMA once per read_ns), idle converters only leak. An IMA of 4 crossbars with 8 ADCs
// needs 512 conversions per 100 ns, half what its ADCs could do at 1.28 GS/s: 5.12 per ns x
// 1.5625 pJ = 8 mW (not 16), its shift-and-add 5.12 x 0.01953125 pJ = 0.1 mW and its output
// register 5.12 x 0.0224609375 pJ = 0.115 mW; with 0.5 mW of leakage per ADC, 8 x 0.5 more.
// ADCs too few for a read per read_ns run at their full rate: 4 ADCs for 8 crossbars, 8 mW.
TEST(IsaacChip, AnImaPricesTheConversionsItsReadsNeed) {
  Isaac isaac;
  auto line = [&](const Architecture& a, const char* unit) {
    return isaac.line(price_machine(a, isaac.cost, isaac.converters, isaac.mapping).ima, unit);
  };
  const Architecture half = parse_architecture(machine_yaml(168, 12, 4, 8, "{rows: 6, cols: 7}"), "a");
  EXPECT_NEAR(line(half, "adc").peak_mw, 8.0, 1e-9);
  EXPECT_NEAR(line(half, "shift_add").peak_mw, 0.1, 1e-9);
  EXPECT_NEAR(line(half, "output_register").peak_mw, 0.115, 1e-9);
  isaac.cost.lib.named.components.at("adc").leakage.value = 0.5;
  EXPECT_NEAR(line(half, "adc").peak_mw, 8.0 + 8 * 0.5, 1e-9);
  EXPECT_NEAR(line(half, "adc").leakage_mw, 8 * 0.5, 1e-9);
  isaac.cost.lib.named.components.at("adc").leakage.value = 0;
  const Architecture scarce = parse_architecture(machine_yaml(168, 12, 8, 4, "{rows: 6, cols: 7}"), "a");
  EXPECT_NEAR(line(scarce, "adc").peak_mw, 4 * 2.0, 1e-9);
}

// The mapper plans with the simulated tile's units (configs/isaac.yaml: ResNet-20 on ISAAC-CE,
// auto replication). By hand: layer2.0/conv2 (16 x 16 outputs on 3 crossbars of 128 columns in
// one IMA, 8 bit-serial reads per iteration, a read per 100 ns), one output row per
// transaction, gets 16 copies (a row's iterations): each works one iteration of each of the
// 16 rows at its busiest unit, the ADCs: 8 x 128 / 1.28 GS/s = 800 ns, or with 4 ADCs per IMA
// (an ADC shared by 2 crossbars) 8 x 256 / 1.28 = 1600 ns (the pipeline's fill is latency, not
// busy time). With 4 ADCs the pipeline is then bound at 25.6 us (several stages tie; the
// first, conv1, is named). Two rows per transaction halve the convolutions' rows, and
// layer1.0/add (16 x 32 x 32 additions on one shift-and-add unit at 1.2 per ns, 13.65 us)
// bounds the pipeline: the mapper names it, not a convolution.
TEST(Mapper, PlansIsaacCeWithTheSimulatedTilesTiming) {
  const Model m = make_preset("resnet20", 3);
  auto plan = [&](int adcs, int grain_rows) {
    const ConfigTree cfg = ConfigTree::load(std::string(XBARSIM_SOURCE_DIR) + "/configs/isaac.yaml",
                                            {"platform.grain_rows=" + std::to_string(grain_rows)});
    HardwareContext hw = make_hardware_context(cfg, parse_analog_config(cfg));
    hw.arch.ima.adcs = adcs;
    return machine_report(m, hw, linear_inputs_signed(m)).mapping;
  };
  auto layer = [](const Mapping& mp, const std::string& name) {
    for (const LayerPlacement& p : mp.layers)
      if (p.name == name) return p;
    ADD_FAILURE() << name;
    return LayerPlacement{};
  };
  const Mapping eight = plan(8, 1), four = plan(4, 1), rows2 = plan(8, 2);
  ASSERT_TRUE(eight.fits && four.fits && rows2.fits);
  ASSERT_EQ(layer(eight, "layer2.0/conv2").replication, 16);
  ASSERT_EQ(layer(four, "layer2.0/conv2").replication, 16);
  EXPECT_DOUBLE_EQ(layer(eight, "layer2.0/conv2").compute_ns, 16 * 800.0);
  EXPECT_DOUBLE_EQ(layer(four, "layer2.0/conv2").compute_ns, 16 * 1600.0);
  EXPECT_EQ(four.bottleneck_stage, "conv1");
  EXPECT_DOUBLE_EQ(four.bottleneck_ns, 25600.0);
  EXPECT_EQ(rows2.bottleneck_stage, "layer1.0/add");
  EXPECT_NEAR(rows2.bottleneck_ns, 16 * 32 * 32 / 1.2, 1e-6);
}

// Issue 53: ISAAC's library is in the one named form, so a new component is one entry of the
// library file (and the architecture's use of it): a 0.01 mm^2 unit of 2 pJ per action, one
// per tile at 1.2 actions per ns, adds 168 x 0.01 mm^2 and 168 x 1.2 x 2 mW to the chip, and
// nothing else moves.
TEST(IsaacChip, ANewComponentIsOneEntryOfTheLibrary) {
  const Isaac m;
  auto file = [](const std::string& path) {
    std::ifstream in(std::string(XBARSIM_SOURCE_DIR) + path);
    std::stringstream ss;
    ss << in.rdbuf();
    return ss.str();
  };
  const std::string lib = file("/configs/components/isaac.yaml") +
                          "  tile_crypto: {area_mm2: 0.01, leakage_mw: 0, actions: {action: 2.0}}\n";
  std::string arch = file("/configs/architectures/isaac-ce.yaml");
  const size_t at = arch.find("    sigmoid:");
  ASSERT_NE(at, std::string::npos);
  arch.insert(at, "    tile_crypto: {count: 1, actions_per_ns: 1.2}\n");
  CostModel cost = m.cost;
  cost.lib = parse_component_library(lib, "isaac+1.yaml");
  const MachineBill b = price_machine(parse_architecture(arch, "isaac-ce+1.yaml"), cost, m.converters, m.mapping);
  EXPECT_NEAR(b.chip_area_mm2.total() - m.bill.chip_area_mm2.total(), 168 * 0.01, 1e-9);
  EXPECT_NEAR(b.chip_peak_mw.total() - m.bill.chip_peak_mw.total(), 168 * 1.2 * 2.0, 1e-6);
  EXPECT_NEAR(m.line(b.tile, "tile_crypto").area_mm2, 0.01, 1e-15);
  EXPECT_EQ(b.chip_area_mm2.crossbar, m.bill.chip_area_mm2.crossbar);
  EXPECT_EQ(b.chip_peak_mw.adc, m.bill.chip_peak_mw.adc);
}
