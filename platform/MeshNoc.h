#pragma once
/// A machine's network on chip: routers on a 2-D mesh (architecture chip.mesh), each serving
/// `tiles_per_router` tiles (a concentrated mesh), dimension-ordered XY routing, and every
/// directed link a resource that carries one transfer at a time. A transfer's route comes as
/// a `Route` extension of its generic payload (source tile, destination tiles: several make a
/// multicast along the union of their XY paths, each link carrying the data once); the bytes it
/// moves are its wire bytes (platform/Transfer.h).
///
/// Timing (loosely timed: the target books the links and annotates the delay, it never
/// waits): a transfer of B bytes occupies each link of its route for B / bytes_per_ns; its
/// head takes hop_ns per router. Links are reserved along the whole route at once: the
/// transfer starts at the earliest time t0 >= now at which link k of depth d (the routers
/// before it) is free from t0 + d hop_ns, and reaches a destination at depth D at
/// t0 + D hop_ns + B / bytes_per_ns. The source's injection link (tile -> router) and each
/// destination's ejection link (router -> tile) are links too, so two transfers into one
/// tile contend like two over one mesh link.
///
/// Memory follows the links transfers use (a link never used holds nothing), not the mesh's
/// size: a 20000 x 20000 mesh times a transfer in kilobytes.
#include <algorithm>
#include <cmath>
#include <memory>
#include <string>
#include <systemc>
#include <tlm>
#include <tlm_utils/multi_passthrough_target_socket.h>
#include <unordered_map>
#include <vector>

#include "modules/sim_time.h"
#include "platform/Transfer.h"
#include "sw/hw/mesh.h"

namespace xbarsim {

/// Where a transfer goes: from tile `source` to every tile of `destinations`.
struct Route : tlm::tlm_extension<Route> {
  int source = 0;
  std::vector<int> destinations;
  tlm::tlm_extension_base* clone() const override { return new Route(*this); }
  void copy_from(const tlm::tlm_extension_base& other) override { *this = static_cast<const Route&>(other); }
};

class MeshNoc : public sc_core::sc_module {
 public:
  tlm_utils::multi_passthrough_target_socket<MeshNoc> tile2noc{"tile2noc"};

  MeshNoc(sc_core::sc_module_name name, int mesh_rows, int mesh_cols, int tiles_per_router, double bytes_per_ns,
          double hop_ns)
      : sc_module(name),
        geo_{mesh_rows, mesh_cols, tiles_per_router},
        bytes_per_ns_(bytes_per_ns),
        hop_ns_(hop_ns) {
    tile2noc.register_b_transport(this, &MeshNoc::b_transport);
  }

  const MeshGeometry& geometry() const { return geo_; }
  /// Mesh links between the routers of two tiles (XY: |dx| + |dy|).
  int hops(int from_tile, int to_tile) const { return geo_.hops(from_tile, to_tile); }

  long long bytes() const { return bytes_; }
  long long transfers() const { return transfers_; }
  /// Bytes times the routers each byte passed (for the routers' energy per byte).
  double router_bytes() const { return router_bytes_; }
  /// Sum over links of the time they carried data (ns), and their count.
  double link_busy_ns() const { return busy_ns_; }
  long long links() const { return geo_.links(); }
  /// Time transfers waited for a busy link beyond their unloaded latency (ns).
  double contention_ns() const { return contention_ns_; }

  /// Traces the bytes every link has carried (its slope is the link's utilization) into `tf`
  /// under `scope`: scope.router_R.{east,west,south,north} for the mesh links, and
  /// scope.tile_T.{inject,eject} for the tiles' ports (before the simulation starts). `on`:
  /// tracing continues while it is true. Only the links transfers among tiles 0 .. `tiles` - 1
  /// and the off-chip port can take: their ports, and the mesh links of the rectangle of
  /// routers from router 0 to the last tile's (an XY route stays in its ends' rectangle).
  void trace(sc_core::sc_trace_file* tf, const std::string& scope, const bool* on, long long tiles) {
    static const char* kDir[] = {"east", "west", "south", "north", "inject", "eject"};
    tracing_ = on;
    auto add = [&](long long k, const std::string& name) {
      auto& sig = link_sigs_[k];
      sig = std::make_unique<sc_core::sc_signal<int, sc_core::SC_UNCHECKED_WRITERS>>();
      sc_core::sc_trace(tf, *sig, name);
    };
    const long long routers = geo_.routers();
    auto padded = [](long long v, long long count) {
      const std::string s = std::to_string(v), w = std::to_string(std::max(count - 1, 0LL));
      return std::string(w.size() > s.size() ? w.size() - s.size() : 0, '0') + s;
    };
    tiles = std::min(std::max(tiles, 1LL), geo_.tiles());
    const int last = geo_.router_of(static_cast<int>(tiles - 1));
    const int box_rows = geo_.y_of(last) + 1, box_cols = box_rows > 1 ? geo_.cols : geo_.x_of(last) + 1;
    for (int y = 0; y < box_rows; ++y)
      for (int x = 0; x < box_cols; ++x)
        for (int d = 0; d < 4; ++d) {
          // Only the links that exist: none leaves the mesh's edge.
          if ((d == 0 && x + 1 >= geo_.cols) || (d == 1 && x == 0) || (d == 2 && y + 1 >= geo_.rows) ||
              (d == 3 && y == 0))
            continue;
          const int r = y * geo_.cols + x;
          add(geo_.link_index({r, d}), scope + ".router_" + padded(r, routers) + "." + kDir[d] + "_bytes");
        }
    for (int t = -1; t < tiles; ++t)
      for (int d = 4; d < 6; ++d)
        add(geo_.link_index({t, d}), scope + (t < 0 ? std::string(".offchip") : ".tile_" + padded(t, geo_.tiles())) +
                                         "." + kDir[d] + "_bytes");
  }

 private:
  void b_transport(int, tlm::tlm_generic_payload& p, sc_core::sc_time& delay) {
    Route* route = nullptr;
    p.get_extension(route);
    if (!route || route->destinations.empty()) {
      p.set_response_status(tlm::TLM_GENERIC_ERROR_RESPONSE);
      return;
    }
    auto on_chip = [&](int t) { return t >= -1 && t < geo_.tiles(); };  // -1: the off-chip port
    if (!on_chip(route->source) || !std::all_of(route->destinations.begin(), route->destinations.end(), on_chip)) {
      p.set_response_status(tlm::TLM_ADDRESS_ERROR_RESPONSE);
      return;
    }
    const double now = (sc_core::sc_time_stamp() + delay).to_seconds() * 1e9;
    const long long bytes = wire_bytes(p);
    const double dur = static_cast<double>(bytes) / bytes_per_ns_;
    const int deepest = geo_.multicast_tree(route->source, route->destinations, tree_, path_);
    double t0 = now;
    for (const auto& [k, depth] : tree_) {
      const auto f = free_.find(k);  // a link not booked yet is free
      if (f != free_.end()) t0 = std::max(t0, f->second - depth * hop_ns_);
    }
    for (const auto& [k, depth] : tree_) {
      free_[k] = t0 + depth * hop_ns_ + dur;
      busy_ns_ += dur;
      if (tracing_ && *tracing_) {
        const auto sig = link_sigs_.find(k);
        if (sig == link_sigs_.end()) continue;
        long long& carried = link_bytes_[k];
        carried += bytes;
        sig->second->write(static_cast<int>(std::min<long long>(carried, 1LL << 30)));
      }
    }
    // A byte crosses a router once per link leaving one: every link of the tree but the
    // injection.
    router_bytes_ += static_cast<double>(bytes) * static_cast<double>(tree_.size() - 1);
    contention_ns_ += t0 - now;
    bytes_ += bytes;
    ++transfers_;
    const double arrival = t0 + deepest * hop_ns_ + dur;
    delay += sim_delay(arrival - now, delay);
    p.set_response_status(tlm::TLM_OK_RESPONSE);
  }

  MeshGeometry geo_;
  double bytes_per_ns_, hop_ns_;
  std::unordered_map<long long, double> free_;  ///< per link booked (MeshGeometry::link_index): when it is free again (ns)
  std::vector<std::pair<long long, int>> tree_;                  ///< scratch: a multicast tree
  std::vector<std::pair<MeshGeometry::Link, int>> path_;         ///< scratch: one path
  long long bytes_ = 0, transfers_ = 0;
  double router_bytes_ = 0, busy_ns_ = 0, contention_ns_ = 0;
  const bool* tracing_ = nullptr;
  std::unordered_map<long long, std::unique_ptr<sc_core::sc_signal<int, sc_core::SC_UNCHECKED_WRITERS>>>
      link_sigs_;  ///< the traced links'
  std::unordered_map<long long, long long> link_bytes_;  ///< bytes each traced link carried
};

}  // namespace xbarsim
