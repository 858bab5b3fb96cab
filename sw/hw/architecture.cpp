#include "sw/hw/architecture.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <tuple>

#include "sw/analog/input_slicing.h"
#include "sw/common/input_file.h"
#include "sw/common/yaml_section.h"

namespace xbarsim {

namespace {

UnitUse unit_use(YamlSection& s, const char* rate_key) {
  UnitUse u;
  u.unit = s.word("unit");
  u.count = s.has("count") ? s.integer("count") : 1;
  u.actions_per_ns = s.number(rate_key, true);
  return u;
}

}  // namespace

Architecture parse_architecture(const std::string& text, const std::string& origin) {
  const YAML::Node root = load_yaml_map(text, origin, "an architecture");
  check_yaml_sections(root, {"name", "crossbar", "ima", "tile", "chip", "input", "readout"}, origin);
  Architecture a;
  a.machine = true;
  a.source = origin;
  if (!root["name"] || !root["name"].IsScalar() || root["name"].Scalar().empty())
    throw InputError(origin + ": 'name' must name the architecture");
  a.name = root["name"].Scalar();
  if (a.name == "layer-sized") throw InputError(origin + ": 'layer-sized' is the built-in no-machine setting");

  YamlSection xb(root, "crossbar", origin);
  a.crossbar = {xb.integer("rows"), xb.integer("cols"), xb.integer("cell_bits")};
  xb.finish();

  YamlSection ima(root, "ima", origin);
  a.ima.crossbars = ima.integer("crossbars");
  a.ima.adcs = ima.integer("adcs");
  if (root["input"]) {
    YamlSection in(root, "input", origin);
    a.input = parse_input_spec(in);
  }
  if (root["readout"]) {
    YamlSection out(root, "readout", origin);
    a.readout = parse_readout_spec(out);
  }
  a.core().read_ima(a, ima, origin);
  a.ima.input_register_bytes = ima.integer("input_register_bytes");
  a.ima.output_register_bytes = ima.integer("output_register_bytes");
  if (ima.has("components")) {
    YamlSection comps = ima.section("components");
    for (const std::string& name : comps.keys()) {
      YamlSection c = comps.section(name);
      Instance i;
      i.name = name;
      i.component = c.word("component");
      i.part = c.word("part");
      i.count = c.integer("count");
      if (c.has("params")) {
        YamlSection p = c.section("params");
        for (const std::string& k : p.keys()) i.params[k] = p.number(k);
        p.finish();
      }
      c.finish();
      a.ima.components.push_back(i);
    }
    comps.finish();
  }
  ima.finish();
  const long long ima_columns = static_cast<long long>(a.ima.crossbars) * a.crossbar.cols;
  if (ima_columns > Architecture::kMaxImaColumns)
    throw InputError(origin + ": an IMA's columns ('ima.crossbars' x 'crossbar.cols') = " + std::to_string(ima_columns) +
                     " must be at most 2^30 = " + std::to_string(Architecture::kMaxImaColumns));
  if (ima_columns % a.ima.adcs != 0)
    throw InputError(origin + ": 'ima.adcs' = " + std::to_string(a.ima.adcs) + " must divide the IMA's " +
                     std::to_string(ima_columns) +
                     " physical columns (crossbars x cols), which its ADCs share equally");

  YamlSection tile(root, "tile", origin);
  a.tile.imas = tile.integer("imas");
  if (tile.has("edram")) {  // optional: cores without a buffer of their own
    YamlSection e = tile.section("edram");
    a.tile.edram_bytes = static_cast<long long>(e.integer("kib")) * 1024;
    a.tile.edram_bytes_per_ns = e.number("bytes_per_ns", true);
    e.finish();
  }
  if (tile.has("bus")) {
    YamlSection bus = tile.section("bus");
    a.tile.bus = unit_use(bus, "bytes_per_ns");
    bus.finish();
  }
  if (tile.has("units")) {
    YamlSection units = tile.section("units");
    for (const std::string& name : units.keys()) {
      YamlSection u = units.section(name);
      UnitUse use{name, u.integer("count"), u.number("actions_per_ns", true), {}};
      if (u.has("ops"))
        for (const std::string& op : u.words("ops")) {
          const auto& known = digital_op_names();
          if (std::find(known.begin(), known.end(), op) == known.end()) {
            std::string list;
            for (const auto& n : known) list += (list.empty() ? "" : ", ") + n;
            throw InputError(origin + ": 'tile.units." + name + ".ops': unknown operation '" + op + "' (" + list + ")");
          }
          use.ops.push_back(op);
        }
      a.tile.units.push_back(use);
      u.finish();
    }
    units.finish();
  }
  tile.finish();

  YamlSection chip(root, "chip", origin);
  a.chip.tiles = chip.integer("tiles");
  const bool routed = chip.has("router");
  a.chip.tiles_per_router = routed ? chip.integer("tiles_per_router") : a.chip.tiles;
  const bool mesh_given = chip.has("mesh");
  if (!routed && (mesh_given || chip.has("tiles_per_router")))
    throw InputError(origin + ": 'chip.mesh' and 'chip.tiles_per_router' need a 'chip.router' (without one the "
                     "cores have no mesh)");
  if (mesh_given) {
    YamlSection m = chip.section("mesh");
    a.chip.mesh_rows = m.integer("rows");
    a.chip.mesh_cols = m.integer("cols");
    m.finish();
  } else {
    std::tie(a.chip.mesh_rows, a.chip.mesh_cols) = derive_mesh(a.chip.routers_needed());
  }
  {
    if (routed) {
      YamlSection router = chip.section("router");
      a.chip.router = unit_use(router, "bytes_per_ns");
      a.chip.hop_ns = router.number("hop_ns");
      router.finish();
    }
    if (chip.has("offchip")) {
      YamlSection offchip = chip.section("offchip");
      a.chip.offchip = unit_use(offchip, "bytes_per_ns");
      offchip.finish();
    }
  }
  chip.finish();
  a.core().check_machine(a, origin);
  // The chip's crossbars (each factor at most 2^30: the product fits in 128 bits; within the
  // limit every count of the machine fits in 64).
  const __int128 chip_crossbars = static_cast<__int128>(a.chip.tiles) * a.tile.imas * a.ima.crossbars;
  if (chip_crossbars > Architecture::kMaxChipCrossbars)
    throw InputError(origin + ": the chip's crossbars ('chip.tiles' x 'tile.imas' x 'ima.crossbars') = " +
                     std::to_string(a.chip.tiles) + " x " + std::to_string(a.tile.imas) + " x " +
                     std::to_string(a.ima.crossbars) + " must be at most 2^53 = " +
                     std::to_string(Architecture::kMaxChipCrossbars));
  const long long places = a.chip.routers() * a.chip.tiles_per_router;
  if (places < a.chip.tiles)
    throw InputError(origin + ": 'chip.tiles' = " + std::to_string(a.chip.tiles) + " do not fit the mesh: " +
                     std::to_string(a.chip.mesh_rows) + " x " + std::to_string(a.chip.mesh_cols) + " routers of " +
                     std::to_string(a.chip.tiles_per_router) + " tiles hold " + std::to_string(places));
  // Tile t sits at router t / tiles_per_router: routers beyond the last tile's would be priced
  // (and simulated) for nothing.
  const long long needed = a.chip.routers_needed();
  if (mesh_given && a.chip.routers() > needed)
    throw InputError(origin + ": 'chip.mesh' = " + std::to_string(a.chip.mesh_rows) + " x " +
                     std::to_string(a.chip.mesh_cols) + ": " + std::to_string(a.chip.routers() - needed) +
                     " of its " + std::to_string(a.chip.routers()) + " routers serve no tile ('chip.tiles' " +
                     std::to_string(a.chip.tiles) + " at 'chip.tiles_per_router' " +
                     std::to_string(a.chip.tiles_per_router) + " need " + std::to_string(needed) +
                     "); give a mesh of " + std::to_string(needed) +
                     " routers, or leave chip.mesh out to derive one");
  return a;
}

std::pair<int, int> derive_mesh(long long routers) {
  if (routers < 1) throw std::logic_error("derive_mesh: no routers");
  long long rows = static_cast<long long>(std::sqrt(static_cast<double>(routers)));
  while (rows * rows > routers) --rows;
  while ((rows + 1) * (rows + 1) <= routers) ++rows;
  while (routers % rows != 0) --rows;
  return {static_cast<int>(rows), static_cast<int>(routers / rows)};
}

const std::vector<std::string>& digital_op_names() {
  // Every name digital_op_name (sw/hw/mapper.h) gives an operation that computes.
  static const std::vector<std::string> names = {"relu",    "affine",  "add",           "mul",        "div",
                                                 "maxpool", "avgpool", "globalavgpool", "activation", "softmax"};
  return names;
}

double Architecture::ops_per_ns(const std::string& op) const {
  double rate = 0;
  for (const UnitUse& u : tile.units)
    if (std::find(u.ops.begin(), u.ops.end(), op) != u.ops.end()) rate += u.count * u.actions_per_ns;
  return rate;
}

Architecture load_architecture(const ConfigTree& cfg) {
  const std::string name = cfg.get_string("architecture.machine");
  if (name == "layer-sized") return Architecture{};
  if (const char* text = builtin_architecture_yaml(name.c_str()))
    return parse_architecture(text, "built-in configs/architectures/" + name + ".yaml");
  return parse_architecture(read_input_file(name, "the architecture (architecture.machine)", kMaxYamlBytes), name);
}

void check_crossbar_geometry(const Architecture& arch, const MappingSpec& mapping) {
  if (!arch.machine) return;
  const auto& x = arch.crossbar;
  if (mapping.max_rows == x.rows && mapping.max_cols == x.cols && mapping.cell_bits == x.cell_bits) return;
  auto bits = [](int b) { return b ? std::to_string(b) : std::string("none"); };
  throw InputError("architecture.machine " + arch.name + " has crossbars of " + std::to_string(x.rows) + " x " +
                   std::to_string(x.cols) + " cells of " + std::to_string(x.cell_bits) +
                   " bits; the configuration maps onto " + std::to_string(mapping.max_rows) + " x " +
                   std::to_string(mapping.max_cols) + " (mapping.max_rows, mapping.max_cols) with crossbar.cell_bits " +
                   bits(mapping.cell_bits) +
                   ": set them to the machine's (configs/isaac.yaml does for isaac-ce), or to vary them (a sweep "
                   "over them) leave the machine: --set architecture.machine=layer-sized (a tile per layer, sized to "
                   "it)");
}

double MachineBill::area(const std::vector<BillLine>& lines) {
  double a = 0;
  for (const BillLine& l : lines) a += l.area_mm2;
  return a;
}

double MachineBill::leakage(const std::vector<BillLine>& lines) {
  double p = 0;
  for (const BillLine& l : lines) p += l.leakage_mw;
  return p;
}

double MachineBill::peak_mw(const std::vector<BillLine>& lines) {
  double p = 0;
  for (const BillLine& l : lines) p += l.peak_mw;
  return p;
}

MachineBill price_machine(const Architecture& arch, const CostModel& cost, const ConvertersSpec& converters,
                          const MappingSpec& mapping) {
  if (!arch.machine) throw std::logic_error("price_machine: layer-sized is no machine");
  MachineBill bill;
  const ComponentLibrary& lib = cost.lib;
  // One IMA as the counting rule's inventory: every crossbar present and read each read_ns.
  const long long xb = arch.ima.crossbars, rows = arch.crossbar.rows, cols = arch.crossbar.cols;
  LayerInventory v;
  v.crossbars = v.accumulators = xb;
  v.dacs = xb * rows;
  v.adcs = arch.ima.adcs;
  v.cells_present = v.cells_used = xb * rows * cols;
  v.sample_holds = xb * cols;
  v.shift_register_entries = arch.ima.input_register_bytes;
  v.input_bytes = 1;
  v.output_register_bytes = arch.ima.output_register_bytes;
  v.columns_per_adc = arch.columns_per_adc();
  v.input_slices = make_input_slicing(converters.activation_bits(), converters.dac_bits, false, 1.0).slices;
  v.weight_slices = mapping.weight_slices();
  CostModel per_read = cost;
  per_read.clock_mhz = 1e3 / arch.ima.read_ns;
  // Conversions are actions: a read converts every physical column once, at most what the
  // ADCs can at their sample rate (fewer ADCs stretch the read); idle converters only leak.
  const double conversions_per_ns =
      std::min(v.adcs * lib.adc_sample_rate_gsps(), static_cast<double>(v.sample_holds) / arch.ima.read_ns);
  const ComponentBreakdown area = per_read.area_mm2(v), peak = per_read.peak_power_mw(v, conversions_per_ns),
                           leak = per_read.leakage_mw(v);
  const std::pair<const char*, double ComponentBreakdown::*> parts[] = {
      {"crossbar", &ComponentBreakdown::crossbar},
      {"adc", &ComponentBreakdown::adc},
      {"dac", &ComponentBreakdown::dac},
      {"sample_hold", &ComponentBreakdown::sample_hold},
      {"shift_add", &ComponentBreakdown::shift_add},
      {"input_register", &ComponentBreakdown::shift_register},
      {"output_register", &ComponentBreakdown::output_register},
      {"accumulator", &ComponentBreakdown::accumulator}};
  const long long counts[] = {xb,
                              v.adcs,
                              v.dacs,
                              v.sample_holds,
                              per_read.shift_add_units(v),
                              arch.ima.input_register_bytes,
                              arch.ima.output_register_bytes,
                              v.accumulators};
  for (size_t k = 0; k < std::size(parts); ++k)
    if (area.*parts[k].second > 0 || peak.*parts[k].second > 0)
      bill.ima.push_back(
          {parts[k].first, counts[k], area.*parts[k].second, peak.*parts[k].second, leak.*parts[k].second});
  const double imas = static_cast<double>(arch.chip.tiles) * arch.tile.imas;
  bill.chip_area_mm2 = area * imas;
  bill.chip_peak_mw = peak * imas;
  bill.chip_leakage_mw = leak * imas;
  auto add = [&](double ComponentBreakdown::*part, const BillLine& l, double times) {
    bill.chip_area_mm2.*part += l.area_mm2 * times;
    bill.chip_peak_mw.*part += l.peak_mw * times;
    bill.chip_leakage_mw.*part += l.leakage_mw * times;
  };

  // A line of units at their peak: price() of the instances and of one ns of their actions.
  auto line = [&](const std::string& name, long long count, const Bill& b) {
    return BillLine{name, count, b.total_area_mm2(), b.total_leakage_mw() + b.total_energy_pj(), b.total_leakage_mw()};
  };
  auto priced = [&](const UnitUse& u) {
    Ledger per_ns;
    per_ns.add(u.unit, "action", static_cast<double>(u.count) * u.actions_per_ns);
    return line(u.unit, u.count, price(lib.named, {{u.unit, u.unit, u.unit, static_cast<double>(u.count), {}}}, per_ns, 0.0));
  };
  const double kib = arch.tile.edram_bytes / 1024.0, tiles = arch.chip.tiles;
  bill.tile.push_back({"ima", arch.tile.imas, arch.tile.imas * MachineBill::area(bill.ima),
                       arch.tile.imas * MachineBill::peak_mw(bill.ima),
                       arch.tile.imas * MachineBill::leakage(bill.ima)});
  Ledger edram_per_ns;  // the eDRAM read at its rate
  edram_per_ns.add("buffer", "read", arch.tile.edram_bytes_per_ns);
  bill.tile.push_back(line("edram", arch.tile.edram_bytes,
                           price(lib.named, {{"buffer", "buffer", "buffer", kib, {}}}, edram_per_ns, 0.0)));
  add(&ComponentBreakdown::buffer, bill.tile.back(), tiles);
  bill.tile.push_back(priced(arch.tile.bus));
  add(&ComponentBreakdown::interconnect, bill.tile.back(), tiles);
  for (const UnitUse& u : arch.tile.units) {
    bill.tile.push_back(priced(u));
    add(&ComponentBreakdown::digital, bill.tile.back(), tiles);
  }
  // The tile's share of the routers (one per tiles_per_router tiles), so that tiles x tile
  // is the chip without its off-chip links.
  const BillLine routers = priced({arch.chip.router.unit, arch.chip.routers(), arch.chip.router.actions_per_ns, {}});
  add(&ComponentBreakdown::interconnect, routers, 1);
  bill.tile.push_back(
      {"router share", 1, routers.area_mm2 / tiles, routers.peak_mw / tiles, routers.leakage_mw / tiles});

  bill.chip.push_back({"tile", arch.chip.tiles, tiles * MachineBill::area(bill.tile),
                       tiles * MachineBill::peak_mw(bill.tile), tiles * MachineBill::leakage(bill.tile)});
  bill.chip.push_back(priced(arch.chip.offchip));
  add(&ComponentBreakdown::memory, bill.chip.back(), 1);
  return bill;
}

}  // namespace xbarsim
