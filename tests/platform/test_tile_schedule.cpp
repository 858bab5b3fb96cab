// A tile's schedule derived by hand: when its units' processes (modules/TileUnit.h) hand a
// row group's output rows over, against schedules written out here from the units'
// latencies, for one crossbar read bit-serially through 1, 2 and 8 columns per ADC, and for
// row groups shared by copies of the tile.
#include <gtest/gtest.h>

#include <memory>
#include <systemc>
#include <vector>

#include "platform/Tile.h"
#include "sw/analog/analog_layer.h"

#include "tests/platform/one_simulation.h"

using namespace xbarsim;

namespace {

/// A c_in -> c_out convolution of k x k on an h x w input (stride 1, no padding).
LinearLayer conv(int c_in, int c_out, int k, int h, int w) {
  LinearLayer L;
  L.c_in = c_in;
  L.c_out = c_out;
  L.k_h = L.k_w = k;
  L.in = {c_in, h, w};
  L.out = {c_out, h - k + 1, w - k + 1};
  L.weight = Eigen::MatrixXf::Random(L.rows(), c_out) * 0.5f;
  L.bias = Eigen::VectorXf::Zero(c_out);
  return L;
}

/// Sends its jobs to a tile one after the other (timing only), each as soon as the tile has
/// taken the previous one, and keeps when each was taken.
struct Driver : sc_core::sc_module {
  tlm_utils::simple_initiator_socket<Driver> out{"out"};
  std::vector<LayerJob> jobs;
  std::vector<double> taken_ns;
  std::vector<tlm::tlm_response_status> status;
  SC_HAS_PROCESS(Driver);
  explicit Driver(sc_core::sc_module_name n) : sc_module(n) { SC_THREAD(run); }
  void run() {
    for (LayerJob& job : jobs) {
      tlm::tlm_generic_payload p;
      attach(p, job, 0);
      sc_core::sc_time delay = sc_core::SC_ZERO_TIME;
      out->b_transport(p, delay);
      taken_ns.push_back(to_ns(sc_core::sc_time_stamp() + delay));
      status.push_back(p.get_response_status());
    }
  }
};

/// A timing-only job of layer `L` on `analog` (the whole pass; the tests set its part).
LayerJob timing_job(const LinearLayer& L, const AnalogLayer& analog) {
  LayerJob job;
  job.layer = &L;
  job.analog = &analog;
  job.timing_only = true;
  return job;
}

/// When each group left the tile (ns).
std::vector<double> completions(const Tile& tile) {
  std::vector<double> ns;
  for (const sc_core::sc_time& t : tile.completions()) ns.push_back(to_ns(t));
  return ns;
}

/// conv(16, 8, 1, ...)'s weights on one crossbar of 16 rows x 16 columns (a differential pair
/// a weight: no reference column), inputs read bit-serially one bit a read.
AnalogConfig one_crossbar(int input_bits) {
  AnalogConfig ac;
  ac.mapping.negative = NegativeWeights::Differential;
  ac.mapping.max_cols = 16;
  ac.converters.input_bits = input_bits;
  ac.converters.dac_bits = 1;
  return ac;
}

PlatformConfig hand_platform() {
  PlatformConfig pc;  // 100 MHz: 10 ns a cycle
  pc.dac_latency_ns = 2;
  pc.crossbar_settle_ns = 10;
  pc.adc_rate_gsps = 0.1;  // 10 ns a conversion
  pc.accumulator_latency_ns = 10;
  pc.shift_entries_per_cycle = 16;
  return pc;
}

/// one_crossbar(1)'s tile with every unit one 10-ns cycle an iteration (one conversion a read)
/// and FIFOs of one group.
PlatformConfig one_cycle_platform() {
  PlatformConfig pc = hand_platform();
  pc.adc_columns_per_unit = 1;
  pc.fifo_depth = 1;
  return pc;
}

}  // namespace

// One crossbar of 16 rows x 8 columns (a 1x1 convolution, 4 x 4 outputs: 16 iterations, each
// reloading its 16 entries in one cycle), inputs read bit-serially one bit a read, an ADC for
// every 1, 2 or 8 columns. Every unit holds an iteration for whole 10-ns cycles: shift 10 ns,
// DAC 2b ns -> ceil to cycles, crossbar 10b ns, ADC b x cpa x 10 ns (cpa conversions a read),
// accumulate 2 ns -> 10. The ADC is the slowest unit (cpa >= 1), so the first iteration
// reaches it after the shift register, the DACs and the crossbars, the ADC then converts the
// 16 iterations back to back, and the last one leaves after the accumulator.
TEST(TileSchedule, OneCrossbarAtOneTwoAndEightColumnsPerAdcAndOneFourAndEightBitInputs) {
  ONE_SIMULATION_PER_PROCESS();
  const LinearLayer L = conv(16, 8, 1, 4, 4);
  const int cpas[] = {1, 2, 8}, bits[] = {1, 4, 8};
  std::vector<std::unique_ptr<AnalogLayer>> analog;
  std::vector<std::unique_ptr<Driver>> drivers;
  std::vector<std::unique_ptr<Tile>> tiles;
  std::vector<double> expect;
  for (int cpa : cpas)
    for (int b : bits) {
      const AnalogConfig ac = one_crossbar(b);  // 8 weight columns = 16 physical
      analog.push_back(std::make_unique<AnalogLayer>(ac, L.weight.cast<double>(), 1.0, false, 1));
      ASSERT_EQ(analog.back()->crossbars(), 1);
      ASSERT_EQ(ac.mapping.physical_columns(analog.back()->block(0).cols), 16);
      ASSERT_EQ(analog.back()->input_slicing().slices, b);
      PlatformConfig pc = hand_platform();
      pc.adc_columns_per_unit = cpa;
      const std::string id = std::to_string(cpa) + "_" + std::to_string(b);
      tiles.push_back(std::make_unique<Tile>(("tile_" + id).c_str(), pc));
      drivers.push_back(std::make_unique<Driver>(("driver_" + id).c_str()));
      drivers.back()->out.bind(tiles.back()->noc2tile);
      LayerJob job = timing_job(L, *analog.back());
      drivers.back()->jobs.push_back(job);
      // By hand: 16 physical columns, cpa of them per ADC: cpa conversions a read.
      const double dac = std::ceil(2.0 * b / 10 - 1e-9) * 10, adc = b * cpa * 10.0;
      expect.push_back(10 + dac + 10.0 * b + 16 * adc + 10);
    }
  sc_core::sc_start();
  for (size_t i = 0; i < drivers.size(); ++i) {
    ASSERT_EQ(drivers[i]->status.at(0), tlm::TLM_OK_RESPONSE);
    ASSERT_EQ(tiles[i]->completions().size(), 1u);
    EXPECT_DOUBLE_EQ(completions(*tiles[i])[0], expect[i]) << "case " << i;
    // Taken when the shift register has read the 16 iterations' inputs.
    EXPECT_DOUBLE_EQ(drivers[i]->taken_ns.at(0), 160) << "case " << i;
  }
  // Two of them written out: 1 column per ADC at 1 bit: 10 + 10 + 10, 16 x 10, + 10; 8 columns
  // per ADC at 8 bits: 10 + 20 (16 ns of DAC) + 80, 16 x 640, + 10.
  EXPECT_DOUBLE_EQ(completions(*tiles[0])[0], 30 + 160 + 10);
  EXPECT_DOUBLE_EQ(completions(*tiles[8])[0], 110 + 16 * 640 + 10);
  // The ADC worked 16 x 640 ns and was the only unit never idle once it had started.
  EXPECT_EQ(tiles[8]->units()[kAdc]->busy_ps(), 16u * 640000u);
}

// Row groups of a 3x3 convolution on 8 x 8 (6 x 6 outputs, 36 iterations), as the platform sends
// them. Units: shift register 90 ns for an iteration that starts a row (36 entries at 4 a
// cycle), 30 ns otherwise (12 entries); DAC 2 ns -> 10; crossbar 20; ADC 0.01 ns -> 10;
// accumulator 10. On 3 copies, output rows 1..2 (iterations 6..17) go in shares of 4 to the
// copies' lanes; each lane's shift register is its slowest unit, and its last iteration then
// passes the other four units (10 + 20 + 10 + 10 = 50 ns).
TEST(TileSchedule, ARowGroupOnCopiesTakesTheSlowestShareThenTheRestOfTheDatapath) {
  ONE_SIMULATION_PER_PROCESS();
  const LinearLayer L = conv(4, 8, 3, 8, 8);  // 36 rows; a shift brings 3 x 4 = 12 entries
  AnalogConfig ac;
  AnalogLayer analog(ac, L.weight.cast<double>(), 1.0, false, 1);
  PlatformConfig pc = hand_platform();
  pc.shift_entries_per_cycle = 4;  // refill 36 / 4 = 9 cycles, shift 12 / 4 = 3 cycles
  pc.crossbar_settle_ns = 20;
  pc.adc_rate_gsps = 100;  // a conversion far below a cycle
  pc.adc_columns_per_unit = 1;
  ASSERT_EQ(analog.input_slicing().slices, 1);
  Tile tile("tile", pc, 3);
  Driver driver("driver");
  driver.out.bind(tile.noc2tile);
  LayerJob job = timing_job(L, analog);
  job.replication = 3;
  job.first_iteration = 6;
  job.count = 12;
  driver.jobs.push_back(job);  // rows 1..2 on 3 copies
  job.first_iteration = 0;
  job.count = 6;
  job.replication = 1;
  driver.jobs.push_back(job);  // then row 0 on the first copy
  job.count = -1;
  job.timing_only = false;
  job.first_iteration = 6;
  driver.jobs.push_back(job);  // values of a part of the pass: refused
  job.timing_only = true;
  job.replication = 4;
  driver.jobs.push_back(job);  // more copies than the tile has: refused
  sc_core::sc_start();
  ASSERT_EQ(driver.status.size(), 4u);
  ASSERT_EQ(driver.status[0], tlm::TLM_OK_RESPONSE);
  ASSERT_EQ(driver.status[1], tlm::TLM_OK_RESPONSE);
  EXPECT_EQ(driver.status[2], tlm::TLM_COMMAND_ERROR_RESPONSE);
  EXPECT_EQ(driver.status[3], tlm::TLM_COMMAND_ERROR_RESPONSE);
  // Shares' shift registers: iterations 6-9 (6 starts row 1: 90 + 3 x 30 = 180), 10-13 (12
  // starts row 2: 30 + 30 + 90 + 30 = 180), 14-17 (4 x 30 = 120); taken at 180.
  EXPECT_DOUBLE_EQ(driver.taken_ns[0], 180);
  const std::vector<double> done = completions(tile);
  ASSERT_EQ(done.size(), 2u);
  EXPECT_DOUBLE_EQ(done[0], 180 + 50);
  // Row 0 on the first lane from 180, when its shift register is free: 90 + 5 x 30, then 50.
  EXPECT_DOUBLE_EQ(driver.taken_ns[1], 180 + 240);
  EXPECT_DOUBLE_EQ(done[1], 180 + 240 + 50);
  // The counters hold the two timed parts only: 18 iterations, 3 refills.
  EXPECT_EQ(tile.iterations(), 18);
  EXPECT_EQ(tile.shift_register().refills(), 3);
  EXPECT_EQ(tile.shift_register().shifted_entries(), 3 * 36 + 15 * 12);
  // Busy: the busiest unit's busiest lane, the first lane's shift register: 180 + 240 ns.
  EXPECT_EQ(tile.bottleneck(), kShift);
  EXPECT_EQ(tile.busy_ps(), 420000u);
}

namespace {

/// The next stage's side of a tile's output: takes a finished group, then is busy 1000 ns with
/// it before it takes the next (its register: an sc_fifo of one group).
struct SlowConsumer : sc_core::sc_module {
  sc_core::sc_fifo<int> in{"in", 1};
  std::vector<double> taken_ns;
  SC_HAS_PROCESS(SlowConsumer);
  explicit SlowConsumer(sc_core::sc_module_name n) : sc_module(n) { SC_THREAD(run); }
  void run() {
    for (;;) {
      in.read();
      taken_ns.push_back(to_ns(sc_core::sc_time_stamp()));
      sc_core::wait(1000, sc_core::SC_NS);
    }
  }
};

}  // namespace

// Four one-iteration groups through a tile whose every unit takes a 10-ns cycle (FIFOs of one
// group), into a consumer that holds each group 1000 ns. By hand: group 0 leaves at 50 and is
// taken at once; group 1 leaves at 60 into the empty register; group 2 is done at 70 and the
// accumulator holds it (stalled) until the consumer takes group 1 at 1050; group 3, done at
// the ADC at 70, waits in the accumulator's FIFO, is accumulated 1050-1060 and held until
// 2050. The consumer takes them at 50, 1050, 2050, 3050; the accumulator stalled
// (1050 - 70) + (2050 - 1060) ns.
TEST(TileSchedule, AFullOutputRegisterStallsTheAccumulatorAndHoldsTheGroupsBack) {
  ONE_SIMULATION_PER_PROCESS();
  const LinearLayer L = conv(16, 8, 1, 4, 4);
  AnalogLayer analog(one_crossbar(1), L.weight.cast<double>(), 1.0, false, 1);
  Tile tile("tile", one_cycle_platform());
  Driver driver("driver");
  SlowConsumer consumer("consumer");
  driver.out.bind(tile.noc2tile);
  tile.set_output([&](const TileToken& t) { return consumer.in.nb_write(t.row); }, &consumer.in.data_read_event());
  for (int g = 0; g < 4; ++g) {
    LayerJob job = timing_job(L, analog);
    job.first_iteration = g;
    job.count = 1;
    driver.jobs.push_back(job);
  }
  sc_core::sc_start(10, sc_core::SC_US);
  ASSERT_EQ(driver.taken_ns, (std::vector<double>{10, 20, 30, 40}));
  EXPECT_EQ(consumer.taken_ns, (std::vector<double>{50, 1050, 2050, 3050}));
  EXPECT_EQ(tile.units()[kAccumulate]->stall_ps(), (980u + 990u) * 1000u);
  for (int u = kShift; u < kAccumulate; ++u) EXPECT_EQ(tile.units()[u]->stall_ps(), 0u) << unit_name(static_cast<Stage>(u));
}

namespace {

/// Feeds tile B with every group tile A delivers (through a register of one group).
struct Relay : sc_core::sc_module {
  tlm_utils::simple_initiator_socket<Relay> out{"out"};
  sc_core::sc_fifo<int> in{"in", 1};
  LayerJob job;
  SC_HAS_PROCESS(Relay);
  explicit Relay(sc_core::sc_module_name n) : sc_module(n) { SC_THREAD(run); }
  void run() {
    for (int g = 0;; ++g) {
      in.read();
      job.first_iteration = g;  // the groups arrive in order
      tlm::tlm_generic_payload p;
      attach(p, job, 0);
      sc_core::sc_time delay = sc_core::SC_ZERO_TIME;
      out->b_transport(p, delay);
    }
  }
};

}  // namespace

// Two tiles in a row: A (every unit 10 ns) hands its one-iteration groups through a one-group
// register to B, whose crossbars take 100 ns, every FIFO one group deep. By hand: A delivers at
// 50, 60, 70, 80 and B's shift register takes them at once; B's crossbars work 70-170, 170-270,
// 270-370, 370-470; its DAC, done with group 2 at 90 and group 3 at 180, holds each until the
// crossbars' FIFO has room (170, 270): stalled 80 + 90 ns. B's groups leave at 190, 290, 390, 490,
// and the crossbars bound B (busy 400 ns).
TEST(TileSchedule, TwoTilesAFullFifoInTheSecondStallsItsDac) {
  ONE_SIMULATION_PER_PROCESS();
  const LinearLayer L = conv(16, 8, 1, 4, 4);
  AnalogLayer analog(one_crossbar(1), L.weight.cast<double>(), 1.0, false, 1);
  const PlatformConfig pa = one_cycle_platform();
  PlatformConfig pb = pa;
  pb.crossbar_settle_ns = 100;
  Tile a("a", pa), b("b", pb);
  Driver driver("driver");
  Relay relay("relay");
  driver.out.bind(a.noc2tile);
  relay.out.bind(b.noc2tile);
  a.set_output([&](const TileToken& t) { return relay.in.nb_write(t.row); }, &relay.in.data_read_event());
  LayerJob job = timing_job(L, analog);
  job.count = 1;
  relay.job = job;
  for (int g = 0; g < 4; ++g) {
    job.first_iteration = g;
    driver.jobs.push_back(job);
  }
  sc_core::sc_start(10, sc_core::SC_US);
  EXPECT_EQ(completions(b), (std::vector<double>{190, 290, 390, 490}));
  EXPECT_EQ(b.units()[kDac]->stall_ps(), (80u + 90u) * 1000u);
  EXPECT_EQ(b.bottleneck(), kCrossbar);
  EXPECT_EQ(b.busy_ps(), 400000u);
  for (const TileUnit* u : a.units()) EXPECT_EQ(u->stall_ps(), 0u) << unit_name(u->stage());
}

// A sparse (Toeplitz) layer: one iteration per image yields every output row, its latencies
// given by the initiator (sparse_iteration_ns), the later row groups of the image nothing.
// Here shift 10, DAC 2 -> 10, crossbars 30, ADC 200, accumulator 2 -> 10 ns, two groups an
// image, FIFOs of two groups. Image 0's iteration: shift 0-10, DAC 10-20, crossbars 20-50,
// ADC 50-250, accumulator 250-260; its second group follows at no cost: both leave at 260.
// Image 1's iteration enters at 10 (the driver's next transaction once the shift register has
// read the previous group): shift 10-20, DAC 20-30, crossbars 50-80 (after image 0's), ADC
// 250-450, accumulator 450-460. The DACs, done with image 1's empty second group at 30, hold it
// until the crossbars' FIFO has room at 50 (20 ns stalled). The images leave every 200 ns
// (the ADC bounds the tile: 400 ns busy), where one closed-form iteration per image (260 ns,
// nothing overlapped) would give 260 and 520.
TEST(TileSchedule, ASparseLayersIterationPerImageGoesThroughTheUnitsAndImagesOverlap) {
  ONE_SIMULATION_PER_PROCESS();
  const LinearLayer L = conv(16, 8, 1, 4, 4);
  AnalogLayer analog(one_crossbar(1), L.weight.cast<double>(), 1.0, false, 1);
  PlatformConfig pc = hand_platform();
  ASSERT_EQ(pc.fifo_depth, 2);
  Tile tile("tile", pc);
  Driver driver("driver");
  driver.out.bind(tile.noc2tile);
  LayerJob job = timing_job(L, analog);
  job.sparse = true;
  job.count = 8;  // two rows of four
  const double given[kStages] = {10, 2, 30, 200, 2};
  for (int image = 0; image < 2; ++image)
    for (int g = 0; g < 2; ++g) {
      job.image = static_cast<uint64_t>(image);
      job.first_iteration = 8 * g;
      for (int s = 0; s < kStages; ++s) job.stage_ns[s].assign(1, g == 0 ? given[s] : 0.0);
      driver.jobs.push_back(job);
    }
  LayerJob two_latencies = job;  // a sparse job gives one latency per unit
  two_latencies.stage_ns[kAdc].assign(2, 0.0);
  driver.jobs.push_back(two_latencies);
  sc_core::sc_start(10, sc_core::SC_US);
  EXPECT_EQ(completions(tile), (std::vector<double>{260, 260, 460, 460}));
  EXPECT_EQ(driver.taken_ns, (std::vector<double>{10, 10, 20, 20, 20}));
  EXPECT_EQ(driver.status.back(), tlm::TLM_COMMAND_ERROR_RESPONSE);
  EXPECT_EQ(tile.units()[kDac]->stall_ps(), 20000u);
  EXPECT_EQ(tile.bound_by(), "adc");
  EXPECT_EQ(tile.busy_ps(), 400000u);
  EXPECT_EQ(tile.iterations(), 2);
}
