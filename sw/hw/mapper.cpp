#include "sw/hw/mapper.h"

#include "sw/hw/cost.h"
#include "sw/nn/ops.h"

#include <algorithm>
#include <cmath>

namespace xbarsim {

namespace {

/// A layer's iterations at the units of its tile (platform/Tile.h, modules/TileUnit.h): the
/// output's rows x columns, and what each iteration holds each unit for, in whole cycles (only
/// the shift register's reload at a row's start, or at every step when the stride skips the
/// kernel, differs from one output column to the next).
struct LayerTiming {
  long long rows = 1, cols = 1, iterations = 0;
  std::vector<double> shift_ns;  ///< per output column: the shift register
  double dac_ns = 0, crossbar_ns = 0, adc_ns = 0, accumulate_ns = 0;  ///< per iteration
};

LayerTiming layer_timing(const LayerInventory& v, const LinearLayer* L, const MappingSpec* mapping,
                         const PlatformConfig& pc) {
  LayerTiming t;
  t.iterations = v.iterations;
  if (L) {
    t.rows = std::max(1, L->out.h);
    t.cols = std::max(1, L->out.w);
  } else {
    t.rows = std::max(1, v.output.h);
    t.cols = std::max(1LL, (v.iterations + t.rows - 1) / t.rows);
  }
  const double clk = pc.clock_ns(), S = v.input_slices * pc.read_cycles(v.reads_image);
  t.shift_ns.assign(static_cast<size_t>(t.cols), 0.0);
  if (!pc.detailed) {  // a read per cycle, at the crossbars
    t.crossbar_ns = clk * S;
    return t;
  }
  auto whole_cycles = [&](double ns) { return std::ceil(ns / clk - 1e-9) * clk; };
  // The conversions of a read: the slowest crossbar's (balanced column blocks: the widest, and
  // one weight column narrower).
  const long long blocks = std::max(1LL, v.col_blocks);
  std::vector<long long> widths;
  if (mapping) {
    const long long wide = (v.cols + blocks - 1) / blocks, narrow = v.cols / blocks;
    widths.push_back(mapping->physical_columns(static_cast<int>(wide)));
    if (narrow > 0) widths.push_back(mapping->physical_columns(static_cast<int>(narrow)));
  } else {
    widths.push_back((v.physical_cols + blocks - 1) / blocks);
  }
  double adc = 0;
  for (long long w : widths)
    adc = std::max(adc, adc_read_ns(w, pc.adc_columns_per_unit, pc.crossbars_per_adc, pc.adc_rate_gsps));
  t.dac_ns = whole_cycles(pc.dac_latency_ns * S);
  t.crossbar_ns = whole_cycles(pc.crossbar_settle_ns * S);
  t.adc_ns = whole_cycles(adc * S);
  t.accumulate_ns = whole_cycles(pc.accumulator_latency_ns);
  for (long long ox = 0; ox < t.cols && L; ++ox) {
    const bool reload = ox == 0 || L->stride_w >= L->k_w;
    const long long entries = reload ? L->rows() : static_cast<long long>(L->stride_w) * L->k_h * L->c_in;
    t.shift_ns[static_cast<size_t>(ox)] = std::ceil(static_cast<double>(entries) / pc.shift_entries_per_cycle) * clk;
  }
  return t;
}

/// Per image, the time `copies` copies of a layer compute: what their busiest unit works
/// (the simulation's busy time: a unit that bounds the throughput, without the pipeline's
/// fill). Per row group (platform.grain_rows output rows) the copies take contiguous shares of
/// its iterations; copy q's unit works its shares of every group.
double compute_ns(const LayerTiming& t, int copies, int grain_rows) {
  grain_rows = std::max(1, grain_rows);
  const long long lanes = std::max(1, copies);
  std::vector<double> shift(static_cast<size_t>(lanes), 0.0);
  std::vector<long long> count(static_cast<size_t>(lanes), 0);
  for (long long r0 = 0; r0 < t.rows; r0 += grain_rows) {
    const long long first = r0 * t.cols;
    const long long n = std::min((std::min(t.rows, r0 + grain_rows) - r0) * t.cols, t.iterations - first);
    if (n <= 0) break;
    const long long nrep = std::min(lanes, n);
    for (long long q = 0; q < nrep; ++q)
      for (long long k = first + q * n / nrep; k < first + (q + 1) * n / nrep; ++k) {
        shift[static_cast<size_t>(q)] += t.shift_ns[static_cast<size_t>(k % t.cols)];
        ++count[static_cast<size_t>(q)];
      }
  }
  const double per_iteration = std::max({t.dac_ns, t.crossbar_ns, t.adc_ns, t.accumulate_ns});
  double busiest = 0;
  for (long long q = 0; q < lanes; ++q)
    busiest = std::max({busiest, shift[static_cast<size_t>(q)],
                        static_cast<double>(count[static_cast<size_t>(q)]) * per_iteration});
  return busiest;
}

/// The iterations a layer's copies can share: one row group's.
long long group_iterations(const LayerTiming& t, int grain_rows) {
  return std::min(t.iterations, std::min<long long>(t.rows, std::max(1, grain_rows)) * t.cols);
}

}  // namespace

double estimated_compute_ns(const LayerInventory& v, const LinearLayer* L, const MappingSpec* mapping,
                            const PlatformConfig& pc, int copies) {
  return compute_ns(layer_timing(v, L, mapping, pc), copies, pc.grain_rows);
}

Mapping map_network(const std::vector<LayerInventory>& layers, const Architecture& arch, const PlatformConfig& config,
                    const Model* model, const MappingSpec* mapping) {
  if (!arch.machine) throw std::logic_error("map_network: layer-sized is no machine");
  const PlatformConfig pc = machine_platform(config, arch);  // the timing the simulated tiles run with
  Mapping m;
  m.machine = arch.name;
  m.imas_per_tile = arch.tile.imas;
  m.tiles_available = arch.chip.tiles;
  m.imas_available = arch.imas();
  const int L = static_cast<int>(layers.size());
  if (model && model->linear.size() != layers.size())
    throw std::logic_error("map_network: the model's linear layers are not the inventories'");
  if (!pc.replication_per_layer.empty() && static_cast<int>(pc.replication_per_layer.size()) != L)
    throw InputError("platform.replication_per_layer lists " + std::to_string(pc.replication_per_layer.size()) +
                     " values for " + std::to_string(L) + " linear layers");
  const long long cells_per_ima = static_cast<long long>(arch.ima.crossbars) * arch.crossbar.rows * arch.crossbar.cols;
  std::vector<LayerTiming> timing;
  for (int l = 0; l < L; ++l) {
    const LayerInventory& v = layers[l];
    timing.push_back(layer_timing(v, model ? &model->linear[static_cast<size_t>(l)] : nullptr, mapping, pc));
    LayerPlacement p;
    p.name = v.name;
    p.crossbars = v.crossbars;
    p.imas = (v.crossbars + arch.ima.crossbars - 1) / arch.ima.crossbars;
    p.replication = pc.replication_per_layer.empty() ? pc.replication : pc.replication_per_layer[l];
    if (pc.auto_replication && pc.replication_per_layer.empty()) p.replication = 1;
    p.cell_utilization = static_cast<double>(v.cells_used) / (static_cast<double>(p.imas) * cells_per_ima);
    // The input's arrival over a router link, or (cores without a mesh) the chip's port.
    const double link = arch.chip.transfer_bytes_per_ns();
    p.input_ns = link > 0 ? static_cast<double>(v.input.size()) * pc.activation_bytes / link : 0.0;
    const LayerTiming& lt = timing.back();
    p.iteration_ns = std::max({lt.shift_ns.back(), lt.dac_ns, lt.crossbar_ns, lt.adc_ns, lt.accumulate_ns});
    m.layers.push_back(p);
  }
  auto used = [&] {
    long long n = 0;
    for (const LayerPlacement& p : m.layers) n += static_cast<long long>(p.imas) * p.replication;
    return n;
  };
  auto update_time = [&](int l) {
    m.layers[l].compute_ns = compute_ns(timing[l], m.layers[l].replication, pc.grain_rows);
  };
  for (int l = 0; l < L; ++l) update_time(l);
  if (pc.auto_replication && pc.replication_per_layer.empty()) {
    // Greedy, as ISAAC balances its pipeline: more copies of the slowest stage that can gain
    // from them: compute-bound (a stage bound by its input link gains nothing), and IMAs for
    // the fewest copies that take an iteration off each copy's share of a row group. Once the
    // bottleneck cannot grow, the spare IMAs shorten the other stages (latency, and the fill).
    auto next_copies = [&](int l) {  // 0: no more copies help
      const long long g = group_iterations(timing[l], pc.grain_rows), c = m.layers[l].replication;
      const long long share = (g + c - 1) / c;
      return share <= 1 ? 0LL : (g + share - 2) / (share - 1);
    };
    for (;;) {
      int slow = -1;
      for (int l = 0; l < L; ++l) {
        const LayerPlacement& s = m.layers[l];
        const long long copies = next_copies(l);
        const bool grows =
            s.compute_ns > s.input_ns && copies > 0 && used() + (copies - s.replication) * s.imas <= m.imas_available;
        if (grows && (slow < 0 || s.stage_ns() > m.layers[slow].stage_ns())) slow = l;
      }
      if (slow < 0) break;
      m.layers[slow].replication = static_cast<int>(next_copies(slow));
      update_time(slow);
    }
  }
  const long long needed = used();
  m.imas_used = std::min(needed, m.imas_available);
  if (needed > m.imas_available) {
    long long crossbars = 0;
    for (const LayerPlacement& p : m.layers) crossbars += p.crossbars * p.replication;
    m.fits = false;
    m.reason = "the network needs " + std::to_string(needed) + " IMAs (" + std::to_string(crossbars) +
               " crossbars in whole IMAs of " + std::to_string(arch.ima.crossbars) + "), " + arch.name + " has " +
               std::to_string(m.imas_available) + " (" + std::to_string(arch.chip.tiles) + " tiles x " +
               std::to_string(arch.tile.imas) + ")";
    return m;
  }
  long long next = 0, cells = 0;
  for (int l = 0; l < L; ++l) {
    m.layers[l].first_ima = next;
    next += m.layers[l].imas * m.layers[l].replication;
    cells += layers[l].cells_used * m.layers[l].replication;
    if (m.bottleneck < 0 || m.layers[l].stage_ns() > m.layers[m.bottleneck].stage_ns()) m.bottleneck = l;
  }
  m.tiles_used = next ? m.tile_of(next - 1) + 1 : 0;
  m.cell_utilization = static_cast<double>(cells) / (static_cast<double>(m.imas_available) * cells_per_ima);
  if (m.bottleneck >= 0) {
    m.bottleneck_stage = m.layers[m.bottleneck].name;
    m.bottleneck_ns = m.layers[m.bottleneck].stage_ns();
  }
  if (model) {
    // Its digital operations, as the simulation runs them: a row group's operations at the
    // rate of the tile's units that perform them.
    const std::vector<std::vector<int>> tiles = place_operations(*model, m);
    for (size_t k = 0; k < model->ops.size(); ++k) {
      const Op& op = model->ops[k];
      if (op.kind == OpKind::Linear) continue;
      DigitalPlacement d;
      d.name = op.name;
      d.operation = digital_op_name(op.kind);
      const Shape& out = model->values[static_cast<size_t>(op.out)];
      d.ops = digital_row_ops(op, out, model->values[static_cast<size_t>(op.in[0])]) * out.h;
      const double rate = d.operation.empty() ? 0.0 : arch.ops_per_ns(d.operation);
      d.busy_ns = rate > 0 ? static_cast<double>(d.ops) / rate : 0.0;
      d.tile = tiles[k].front();
      if (d.busy_ns > m.bottleneck_ns) {
        m.bottleneck_stage = d.name;
        m.bottleneck_ns = d.busy_ns;
      }
      m.digital.push_back(d);
    }
  }
  return m;
}

nlohmann::json Mapping::to_json() const {
  nlohmann::json layers_json = nlohmann::json::array();
  for (const LayerPlacement& p : layers)
    layers_json.push_back(
        {{"name", p.name},
         {"crossbars", p.crossbars},
         {"imas", p.imas},
         {"replication", p.replication},
         {"first_ima", p.first_ima},
         {"tiles", p.first_ima < 0 ? nlohmann::json() : nlohmann::json{tile_of(p.first_ima), tile_of(p.last_ima())}},
         {"compute_ns", p.compute_ns},
         {"input_ns", p.input_ns},
         {"iteration_ns", p.iteration_ns},
         {"stage_ns", p.stage_ns()},
         {"cell_utilization", p.cell_utilization}});
  nlohmann::json j = {{"machine", machine},
                      {"fits", fits},
                      {"imas_used", imas_used},
                      {"imas_available", imas_available},
                      {"tiles_used", tiles_used},
                      {"tiles_available", tiles_available},
                      {"ima_utilization", imas_available ? static_cast<double>(imas_used) / imas_available : 0.0},
                      {"cell_utilization", cell_utilization},
                      {"predicted_bottleneck", bottleneck_stage.empty() ? nlohmann::json() : nlohmann::json(bottleneck_stage)},
                      {"predicted_bottleneck_us", bottleneck_ns * 1e-3},
                      {"layers", layers_json}};
  if (!digital.empty()) {
    nlohmann::json d = nlohmann::json::array();
    for (const DigitalPlacement& p : digital)
      d.push_back({{"name", p.name},
                   {"operation", p.operation.empty() ? "data movement" : p.operation},
                   {"tile", p.tile},
                   {"operations", p.ops},
                   {"busy_ns", p.busy_ns}});
    j["digital"] = d;
  }
  if (!fits) j["reason"] = reason;
  return j;
}

const char* digital_op_name(OpKind k) { return op_info(k).unit_op; }

std::vector<std::vector<int>> place_operations(const Model& m, const Mapping& mp) {
  std::vector<std::vector<int>> tiles(m.ops.size());
  std::vector<int> produced_on(m.values.size(), 0);  // the network's input: router 0
  for (size_t k = 0; k < m.ops.size(); ++k) {
    const Op& op = m.ops[k];
    if (op.kind == OpKind::Linear) {
      const LayerPlacement& pl = mp.layers.at(static_cast<size_t>(op.linear));
      for (int t = mp.tile_of(pl.first_ima); t <= mp.tile_of(pl.last_ima()); ++t) tiles[k].push_back(t);
    } else {
      tiles[k].push_back(produced_on[static_cast<size_t>(op.in[0])]);
    }
    produced_on[static_cast<size_t>(op.out)] = tiles[k].front();
  }
  return tiles;
}

MachineTraffic machine_traffic(const Model& m, const std::vector<std::vector<int>>& op_tiles, const MeshGeometry& mesh,
                               int activation_bytes) {
  MachineTraffic t;
  std::vector<int> source(m.values.size(), -1);  // the network's input: the off-chip port
  for (size_t k = 0; k < m.ops.size(); ++k) source[static_cast<size_t>(m.ops[k].out)] = op_tiles[k].front();
  std::vector<std::pair<long long, int>> tree;
  std::vector<std::pair<MeshGeometry::Link, int>> path;
  for (size_t v = 0; v < m.values.size(); ++v) {
    std::vector<int> remote;  // the consumers' tiles that are not the source's, in network order
    auto add = [&](int tile) {
      if (tile != source[v] && std::find(remote.begin(), remote.end(), tile) == remote.end()) remote.push_back(tile);
    };
    bool consumed = false;
    for (size_t k = 0; k < m.ops.size(); ++k)
      for (int in : m.ops[k].in)
        if (in == static_cast<int>(v)) {
          consumed = true;
          for (int tile : op_tiles[k]) add(tile);
        }
    if (static_cast<int>(v) == m.output) {
      consumed = true;
      add(-1);  // the logits leave through the off-chip port
    }
    if (!consumed) continue;
    const double bytes = static_cast<double>(activation_row_bytes(m.values[v], activation_bytes)) * m.values[v].h;
    if (remote.empty()) {
      t.local_bytes += bytes;
      continue;
    }
    mesh.multicast_tree(source[v], remote, tree, path);
    t.noc_bytes += bytes;
    t.router_bytes += bytes * static_cast<double>(tree.size() - 1);
  }
  return t;
}

}  // namespace xbarsim
