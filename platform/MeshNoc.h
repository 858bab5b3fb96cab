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
#include <algorithm>
#include <cmath>
#include <map>
#include <set>
#include <string>
#include <systemc>
#include <tlm>
#include <tlm_utils/multi_passthrough_target_socket.h>
#include <vector>

#include "modules/sim_time.h"
#include "platform/Transfer.h"

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
        rows_(mesh_rows),
        cols_(mesh_cols),
        per_router_(tiles_per_router),
        bytes_per_ns_(bytes_per_ns),
        hop_ns_(hop_ns) {
    tile2noc.register_b_transport(this, &MeshNoc::b_transport);
  }

  /// Router (x, y) of tile t: router index t / tiles_per_router, row-major over the mesh.
  int router_of(int tile) const { return tile / per_router_; }
  int x_of(int router) const { return router % cols_; }
  int y_of(int router) const { return router / cols_; }
  /// Mesh links between the routers of two tiles (XY: |dx| + |dy|).
  int hops(int from_tile, int to_tile) const {
    const int a = router_of(from_tile), b = router_of(to_tile);
    return std::abs(x_of(a) - x_of(b)) + std::abs(y_of(a) - y_of(b));
  }

  long long bytes() const { return bytes_; }
  long long transfers() const { return transfers_; }
  /// Bytes times the routers each byte passed (for the routers' energy per byte).
  double router_bytes() const { return router_bytes_; }
  /// Sum over links of the time they carried data (ns), and their count.
  double link_busy_ns() const { return busy_ns_; }
  int links() const { return 4 * rows_ * cols_ + 2 * rows_ * cols_ * per_router_; }
  /// Time transfers waited for a busy link beyond their unloaded latency (ns).
  double contention_ns() const { return contention_ns_; }

 private:
  /// A directed link: from a router to a neighbour (dir 0..3: +x, -x, +y, -y), or a tile's
  /// injection (dir 4) or ejection (dir 5) port.
  using Link = std::pair<int, int>;  // (router or tile, direction)

  /// The links of the XY path from tile a to tile b, with the number of routers passed
  /// before each (its depth).
  void path(int a, int b, std::vector<std::pair<Link, int>>& out) const {
    int r = router_of(a);
    const int target = router_of(b);
    int depth = 0;
    out.push_back({{a, 4}, depth++});  // injection: tile a into its router
    while (x_of(r) != x_of(target)) {
      const bool east = x_of(target) > x_of(r);
      out.push_back({{r, east ? 0 : 1}, depth++});
      r += east ? 1 : -1;
    }
    while (y_of(r) != y_of(target)) {
      const bool south = y_of(target) > y_of(r);
      out.push_back({{r, south ? 2 : 3}, depth++});
      r += south ? cols_ : -cols_;
    }
    out.push_back({{b, 5}, depth});  // ejection: the last router into tile b
  }

  void b_transport(int, tlm::tlm_generic_payload& p, sc_core::sc_time& delay) {
    Route* route = nullptr;
    p.get_extension(route);
    if (!route || route->destinations.empty()) {
      p.set_response_status(tlm::TLM_GENERIC_ERROR_RESPONSE);
      return;
    }
    const double now = (sc_core::sc_time_stamp() + delay).to_seconds() * 1e9;
    const long long bytes = wire_bytes(p);
    const double dur = static_cast<double>(bytes) / bytes_per_ns_;
    // The multicast tree: every link once, at its depth.
    std::map<Link, int> tree;
    std::vector<std::pair<Link, int>> hops;
    int deepest = 0;
    for (int d : route->destinations) {
      hops.clear();
      path(route->source, d, hops);
      for (const auto& [link, depth] : hops) tree.emplace(link, depth);
      deepest = std::max(deepest, hops.back().second);
    }
    double t0 = now;
    for (const auto& [link, depth] : tree) t0 = std::max(t0, free_at(link) - depth * hop_ns_);
    for (const auto& [link, depth] : tree) {
      free_[link] = t0 + depth * hop_ns_ + dur;
      busy_ns_ += dur;
    }
    // A byte crosses a router once per link leaving one: every link of the tree but the
    // injection.
    router_bytes_ += static_cast<double>(bytes) * static_cast<double>(tree.size() - 1);
    contention_ns_ += t0 - now;
    bytes_ += bytes;
    ++transfers_;
    const double arrival = t0 + deepest * hop_ns_ + dur;
    delay += sim_delay(arrival - now, delay);
    p.set_response_status(tlm::TLM_OK_RESPONSE);
  }

  double free_at(const Link& l) const {
    const auto it = free_.find(l);
    return it == free_.end() ? 0.0 : it->second;
  }

  int rows_, cols_, per_router_;
  double bytes_per_ns_, hop_ns_;
  std::map<Link, double> free_;  ///< per link: when it is free again (ns)
  long long bytes_ = 0, transfers_ = 0;
  double router_bytes_ = 0, busy_ns_ = 0, contention_ns_ = 0;
};

}  // namespace xbarsim
