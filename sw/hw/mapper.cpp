#include "sw/hw/mapper.h"

#include "sw/hw/cost.h"

#include <algorithm>
#include <cmath>

namespace xbarsim {

namespace {

/// The iterations a layer's copies can share: one row group's (platform.grain_rows output
/// rows; the pipeline hands a layer its inputs a row group at a time).
long long group_iterations(const LayerInventory& v, int grain_rows) {
  const long long rows = std::max(1, v.output.h), groups = (rows + grain_rows - 1) / grain_rows;
  return (v.iterations + groups - 1) / groups;
}

/// Crossbar reads of one copy per image, at one read per read_ns: every row group's
/// iterations shared by the copies, times the input slices.
double compute_ns(const LayerInventory& v, const Architecture& arch, int copies, int grain_rows) {
  const long long per_group = group_iterations(v, grain_rows);
  const long long groups = (v.iterations + per_group - 1) / std::max(1LL, per_group);
  return static_cast<double>(groups * ((per_group + copies - 1) / copies)) * v.input_slices * arch.ima.read_ns;
}

}  // namespace

Mapping map_network(const std::vector<LayerInventory>& layers, const Architecture& arch, const PlatformConfig& pc) {
  if (!arch.machine) throw std::logic_error("map_network: layer-sized is no machine");
  Mapping m;
  m.machine = arch.name;
  m.imas_per_tile = arch.tile.imas;
  m.tiles_available = arch.chip.tiles;
  m.imas_available = arch.imas();
  const int L = static_cast<int>(layers.size());
  if (!pc.replication_per_layer.empty() && static_cast<int>(pc.replication_per_layer.size()) != L)
    throw InputError("platform.replication_per_layer lists " + std::to_string(pc.replication_per_layer.size()) +
                     " values for " + std::to_string(L) + " linear layers");
  const long long cells_per_ima = static_cast<long long>(arch.ima.crossbars) * arch.crossbar.rows * arch.crossbar.cols;
  for (int l = 0; l < L; ++l) {
    const LayerInventory& v = layers[l];
    LayerPlacement p;
    p.name = v.name;
    p.crossbars = v.crossbars;
    p.imas = (v.crossbars + arch.ima.crossbars - 1) / arch.ima.crossbars;
    p.replication = pc.replication_per_layer.empty() ? pc.replication : pc.replication_per_layer[l];
    if (pc.auto_replication && pc.replication_per_layer.empty()) p.replication = 1;
    p.cell_utilization = static_cast<double>(v.cells_used) / (static_cast<double>(p.imas) * cells_per_ima);
    p.input_ns = static_cast<double>(v.input.size()) * pc.activation_bytes / arch.chip.router.actions_per_ns;
    m.layers.push_back(p);
  }
  auto used = [&] {
    long long n = 0;
    for (const LayerPlacement& p : m.layers) n += static_cast<long long>(p.imas) * p.replication;
    return n;
  };
  auto update_times = [&] {
    for (int l = 0; l < L; ++l)
      m.layers[l].compute_ns = compute_ns(layers[l], arch, m.layers[l].replication, pc.grain_rows);
  };
  update_times();
  if (pc.auto_replication && pc.replication_per_layer.empty()) {
    // Greedy, as ISAAC balances its pipeline: more copies of the slowest stage that can gain
    // from them: compute-bound (a stage bound by its input link gains nothing), and IMAs for
    // the fewest copies that take an iteration off each copy's share of a row group. Once the
    // bottleneck cannot grow, the spare IMAs shorten the other stages (latency, and the fill).
    auto next_copies = [&](int l) {  // 0: no more copies help
      const long long g = group_iterations(layers[l], pc.grain_rows), c = m.layers[l].replication;
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
      update_times();
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
                      {"bottleneck", bottleneck >= 0 ? nlohmann::json(layers[bottleneck].name) : nlohmann::json()},
                      {"layers", layers_json}};
  if (!fits) j["reason"] = reason;
  return j;
}

const char* digital_op_name(OpKind k) {
  switch (k) {
    case OpKind::Relu:
      return "relu";
    case OpKind::Affine:
      return "affine";
    case OpKind::Add:
      return "add";
    case OpKind::MaxPool:
      return "maxpool";
    case OpKind::AvgPool:
      return "avgpool";
    case OpKind::GlobalAvgPool:
      return "globalavgpool";
    case OpKind::Activation:
      return "activation";
    case OpKind::Softmax:
      return "softmax";
    case OpKind::Linear:
    case OpKind::Flatten:
    case OpKind::Slice:
    case OpKind::Pad:
    case OpKind::Concat:
    case OpKind::Shuffle:
      return "";
  }
  return "";
}

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
