#pragma once
/// The geometry of a machine's mesh (architecture chip.mesh): routers row-major on a
/// rows x cols grid, each serving `tiles_per_router` tiles (tile t at router
/// t / tiles_per_router; the off-chip port, tile -1, at router 0), dimension-ordered XY
/// routes, and a multicast as the union of its XY paths (each link once). Shared by the
/// simulated network on chip (platform/MeshNoc.h), which times transfers over these links,
/// and the closed-form traffic of a mapped network (machine_traffic), which counts them.
#include <algorithm>
#include <cstdlib>
#include <utility>
#include <vector>

namespace xbarsim {

struct MeshGeometry {
  int rows = 1, cols = 1, tiles_per_router = 1;

  /// A directed link: from a router to a neighbour (router, 0..3: +x, -x, +y, -y), or a tile's
  /// injection (tile, 4) or ejection (tile, 5) port.
  using Link = std::pair<int, int>;

  /// Counts of the mesh in 64 bits (a mesh of 2^30 routers has 2^32 links).
  long long routers() const { return static_cast<long long>(rows) * cols; }
  long long tiles() const { return routers() * tiles_per_router; }
  int router_of(int tile) const { return tile < 0 ? 0 : tile / tiles_per_router; }
  int x_of(int router) const { return router % cols; }
  int y_of(int router) const { return router / cols; }
  /// Mesh links between the routers of two tiles (XY: |dx| + |dy|).
  int hops(int from_tile, int to_tile) const {
    const int a = router_of(from_tile), b = router_of(to_tile);
    return std::abs(x_of(a) - x_of(b)) + std::abs(y_of(a) - y_of(b));
  }
  /// The directed links of the mesh and of the tiles' ports (the off-chip port's not counted).
  long long links() const { return 4 * routers() + 2 * tiles(); }
  /// Slots for link_index(): every link and the off-chip port's two.
  long long link_slots() const { return 4 * routers() + 2 * (tiles() + 1); }
  /// A link's index: the routers' mesh links first, then the two ports of the off-chip port
  /// (tile -1) and of every tile.
  long long link_index(const Link& l) const {
    return l.second < 4 ? 4LL * l.first + l.second : 4 * routers() + 2 * (l.first + 1LL) + (l.second - 4);
  }

  /// The links of the XY path from tile a to tile b, with the number of routers passed before
  /// each (its depth), appended to `out`.
  void xy_path(int a, int b, std::vector<std::pair<Link, int>>& out) const {
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
      r += south ? cols : -cols;
    }
    out.push_back({{b, 5}, depth});  // ejection: the last router into tile b
  }

  /// The multicast tree from `source` to `destinations` into `tree` as (link_index, depth),
  /// every link once (the XY paths from one source share their common links at one depth);
  /// returns the depth of the deepest destination. `path` is scratch.
  int multicast_tree(int source, const std::vector<int>& destinations, std::vector<std::pair<long long, int>>& tree,
                     std::vector<std::pair<Link, int>>& path) const {
    tree.clear();
    int deepest = 0;
    for (int d : destinations) {
      path.clear();
      xy_path(source, d, path);
      const bool first = tree.empty();  // one XY path passes a link once
      for (const auto& [link, depth] : path) {
        const long long k = link_index(link);
        if (first ||
            std::none_of(tree.begin(), tree.end(), [&](const std::pair<long long, int>& e) { return e.first == k; }))
          tree.push_back({k, depth});
      }
      deepest = std::max(deepest, path.back().second);
    }
    return deepest;
  }
};

}  // namespace xbarsim
