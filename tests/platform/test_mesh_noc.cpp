// The mesh network on chip against hand-computed XY routes and latencies: a 2 x 2 mesh of one
// tile per router, links of 10 bytes/ns, 1 ns per router. Transfers are booked at given times
// through the annotated delay (loosely timed), without running the simulation.
#include <gtest/gtest.h>

#include <sys/resource.h>
#include <tlm_utils/simple_initiator_socket.h>

#include "platform/MeshNoc.h"
#include "platform/Transfer.h"

using namespace xbarsim;

namespace {

bool g_elaborated = false;

/// A mesh and one initiator bound to it, elaborated (a multi-socket completes its binding at
/// the end of elaboration). SystemC elaborates once per process: ctest runs each case alone.
/// Never destroyed: SystemC objects live as long as the simulation context.
struct Mesh : sc_core::sc_module {
  Mesh(sc_core::sc_module_name name, int rows, int cols, int tiles_per_router)
      : sc_module(name), noc("noc", rows, cols, tiles_per_router, 10.0, 1.0) {
    out.bind(noc.tile2noc);
  }
  static Mesh* make(int rows, int cols, int tiles_per_router) {
    if (g_elaborated) return nullptr;
    g_elaborated = true;
    Mesh* m = new Mesh("mesh", rows, cols, tiles_per_router);
    sc_core::sc_start(sc_core::SC_ZERO_TIME);
    return m;
  }
  /// Arrival time (ns) of `bytes` from tile `from` to `to` (several: a multicast) sent at `at`;
  /// `wire` >= 0: the bytes it puts on the wire (platform/Transfer.h).
  double send(int from, std::vector<int> to, unsigned bytes, double at, long long wire = -1) {
    std::vector<unsigned char> data(bytes);
    tlm::tlm_generic_payload p;
    p.set_command(tlm::TLM_WRITE_COMMAND);
    p.set_data_ptr(data.data());
    p.set_data_length(bytes);
    p.set_streaming_width(bytes);
    auto* route = new Route;  // the payload owns it
    route->source = from;
    route->destinations = std::move(to);
    p.set_extension(route);
    if (wire >= 0) p.set_extension(new WireBytes(wire));
    sc_core::sc_time delay(at, sc_core::SC_NS);
    out->b_transport(p, delay);
    EXPECT_EQ(p.get_response_status(), tlm::TLM_OK_RESPONSE);
    return delay.to_seconds() * 1e9;
  }
  MeshNoc noc;
  tlm_utils::simple_initiator_socket<Mesh> out{"out"};
};

}  // namespace

TEST(MeshNoc, XyHopsAndUnloadedLatencies) {
  Mesh* made = Mesh::make(2, 2, 1);
  if (!made) GTEST_SKIP() << "SystemC elaborates once per process; ctest runs each case alone";
  Mesh& m = *made;
  MeshNoc& noc = m.noc;
  // Tiles 0..3 at routers (0,0) (1,0) (0,1) (1,1).
  EXPECT_EQ(noc.hops(0, 1), 1);
  EXPECT_EQ(noc.hops(0, 3), 2);
  EXPECT_EQ(noc.hops(2, 1), 2);
  // 100 bytes: 10 ns on every link; 0 -> 3 passes injection, +x, +y, ejection: depth 3.
  EXPECT_DOUBLE_EQ(m.send(0, {3}, 100, 0), 13.0);
  // Later, on free links: 2 -> 1 (-... +x then -y): depth 3 again, from t = 100.
  EXPECT_DOUBLE_EQ(m.send(2, {1}, 100, 100), 113.0);
  EXPECT_EQ(noc.transfers(), 2);
  EXPECT_DOUBLE_EQ(noc.contention_ns(), 0.0);
}

TEST(MeshNoc, OneContendedLinkDelaysTheSecondTransfer) {
  Mesh* made = Mesh::make(2, 2, 1);
  if (!made) GTEST_SKIP() << "SystemC elaborates once per process; ctest runs each case alone";
  Mesh& m = *made;
  MeshNoc& noc = m.noc;
  EXPECT_DOUBLE_EQ(m.send(0, {3}, 100, 0), 13.0);  // books R1 -> R3 until 12, tile 3's port until 13
  // 1 -> 3 at t = 0 needs R1's +y link (its depth 1: free from t0 + 1 >= 12) and tile 3's
  // ejection (depth 2: t0 + 2 >= 13): t0 = 11, arrival 11 + 2 + 10 = 23.
  EXPECT_DOUBLE_EQ(m.send(1, {3}, 100, 0), 23.0);
  EXPECT_DOUBLE_EQ(noc.contention_ns(), 11.0);
  // 2 -> 0 shares no link with either: unloaded, depth 2.
  EXPECT_DOUBLE_EQ(m.send(2, {0}, 100, 0), 12.0);
}

TEST(MeshNoc, AMulticastCarriesItsBytesOncePerLink) {
  Mesh* made = Mesh::make(2, 2, 1);
  if (!made) GTEST_SKIP() << "SystemC elaborates once per process; ctest runs each case alone";
  Mesh& m = *made;
  MeshNoc& noc = m.noc;
  // 0 -> {1, 3}: injection, R0 +x, then R1 into tile 1 and R1 +y, R3 into tile 3: five links,
  // the deepest destination at depth 3.
  EXPECT_DOUBLE_EQ(m.send(0, {1, 3}, 100, 0), 13.0);
  EXPECT_DOUBLE_EQ(noc.link_busy_ns(), 5 * 10.0);
  EXPECT_DOUBLE_EQ(noc.router_bytes(), 4 * 100.0);  // every link but the injection leaves a router
  EXPECT_EQ(noc.bytes(), 100);
}

TEST(MeshNoc, TilesSharingARouterMeetAtItsPorts) {
  Mesh* made = Mesh::make(1, 2, 4);
  if (!made) GTEST_SKIP() << "SystemC elaborates once per process; ctest runs each case alone";
  Mesh& m = *made;  // tiles 0..3 on router 0, 4..7 on router 1
  MeshNoc& noc = m.noc;
  EXPECT_EQ(noc.hops(1, 2), 0);
  EXPECT_EQ(noc.hops(3, 4), 1);
  EXPECT_DOUBLE_EQ(m.send(1, {2}, 50, 0), 6.0);  // injection, ejection: depth 1, 5 ns
  // Into tile 2 again at once: its ejection port is busy until 6 (depth 1: t0 = 5).
  EXPECT_DOUBLE_EQ(m.send(0, {2}, 50, 0), 11.0);
}

// A payload carries the simulator's values (floats) of the rows it moves; the mesh times and
// counts the bytes they take on the wire (its WireBytes), not the data length.
TEST(MeshNoc, ATransferMovesItsWireBytesNotItsDataLength) {
  Mesh* made = Mesh::make(2, 2, 1);
  if (!made) GTEST_SKIP() << "SystemC elaborates once per process; ctest runs each case alone";
  EXPECT_DOUBLE_EQ(made->send(0, {3}, 400, 0, 100), 13.0);  // as 100 bytes: 10 ns per link, depth 3
  EXPECT_EQ(made->noc.bytes(), 100);
}

// Issue 38 item 2: the mesh's memory follows the links transfers use, not the mesh's size. A
// 20000 x 20000 mesh of 4 tiles per router (1.6e9 tiles, 2.4e9 link slots, 19 GB as a table
// of doubles; before, the count wrapped in 32 bits and a 3.8 GiB table was indexed past its
// end) times a transfer across it by hand: tile 0 to the last tile crosses 19999 + 19999
// mesh links, depth 39999 at 1 ns per router, plus 10 ns for 100 bytes.
TEST(MeshNoc, AHugeMeshTakesMemoryForTheLinksItUses) {
  Mesh* made = Mesh::make(20000, 20000, 4);
  if (!made) GTEST_SKIP() << "SystemC elaborates once per process; ctest runs each case alone";
  const int last = 20000 * 20000 * 4 - 1;
  EXPECT_EQ(made->noc.geometry().tiles(), 1600000000LL);
  EXPECT_EQ(made->noc.hops(0, last), 39998);
  EXPECT_DOUBLE_EQ(made->send(0, {last}, 100, 0), 39999 + 10.0);
  EXPECT_EQ(made->noc.links(), 4LL * 20000 * 20000 + 2LL * 1600000000);
  struct rusage ru;
  getrusage(RUSAGE_SELF, &ru);
  EXPECT_LT(ru.ru_maxrss, 512 * 1024) << "KiB resident";  // the process, SystemC and gtest included
}
