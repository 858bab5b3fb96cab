// A tile's schedule derived by hand: the time of its transactions (the tile's annotated delay,
// the platform's only source of a linear stage's time) against schedules written out here
// from the units' latencies, for one crossbar read bit-serially through 1, 2 and 8 columns per
// ADC, and for a row group shared by copies of the tile.
#include <gtest/gtest.h>

#include <memory>
#include <systemc>
#include <vector>

#include "platform/Tile.h"
#include "sw/analog/analog_layer.h"

using namespace xbarsim;

namespace {

bool g_elaborated = false;
#define ONE_SIMULATION_PER_PROCESS()                                                                   \
  if (g_elaborated) GTEST_SKIP() << "SystemC elaborates once per process; ctest runs each case alone"; \
  g_elaborated = true

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

/// Sends its jobs to a tile one after the other (timing only) and keeps each annotated delay.
struct Driver : sc_core::sc_module {
  tlm_utils::simple_initiator_socket<Driver> out{"out"};
  std::vector<LayerJob> jobs;
  std::vector<double> delay_ns;
  std::vector<tlm::tlm_response_status> status;
  SC_HAS_PROCESS(Driver);
  explicit Driver(sc_core::sc_module_name n) : sc_module(n) { SC_THREAD(run); }
  void run() {
    for (LayerJob& job : jobs) {
      tlm::tlm_generic_payload p;
      attach(p, job, 0);
      sc_core::sc_time delay = sc_core::SC_ZERO_TIME;
      out->b_transport(p, delay);
      delay_ns.push_back(to_ns(delay));
      status.push_back(p.get_response_status());
    }
  }
};

PlatformConfig hand_platform() {
  PlatformConfig pc;  // 100 MHz: 10 ns a cycle
  pc.dac_latency_ns = 2;
  pc.crossbar_settle_ns = 10;
  pc.adc_rate_gsps = 0.1;  // 10 ns a conversion
  pc.accumulator_latency_ns = 10;
  pc.shift_entries_per_cycle = 16;
  return pc;
}

}  // namespace

// One crossbar of 16 rows x 8 columns (a 1x1 convolution, 4 x 4 outputs: 16 iterations, each
// reloading its 16 entries in one cycle), inputs read bit-serially one bit a read, an ADC for
// every 1, 2 or 8 columns. Per iteration of b reads: DAC 2b ns, crossbar 10b ns, ADC
// b x cpa x 10 ns (cpa conversions a read), shift 10 ns, accumulate 10 ns. The ADC bounds every
// iteration (cpa >= 1), so the 16 iterations take the fill, all stages of the first iteration
// rounded up to whole cycles, and 15 intervals of the ADC's time.
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
      AnalogConfig ac;
      ac.mapping.negative = NegativeWeights::Differential;  // no reference column: 8 weight columns = 16 physical
      ac.mapping.max_cols = 16;
      ac.converters.input_bits = b;
      ac.converters.dac_bits = 1;
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
      LayerJob job;
      job.layer = &L;
      job.analog = analog.back().get();
      job.timing_only = true;
      drivers.back()->jobs.push_back(job);
      // By hand: 16 physical columns, cpa of them per ADC: cpa conversions a read.
      const double adc = b * cpa * 10.0, first = 10 + 2.0 * b + 10.0 * b + adc + 10;
      const double fill = std::ceil(first / 10 - 1e-9) * 10;
      expect.push_back(fill + 15 * adc);
    }
  sc_core::sc_start();
  for (size_t i = 0; i < drivers.size(); ++i) {
    ASSERT_EQ(drivers[i]->status.at(0), tlm::TLM_OK_RESPONSE);
    EXPECT_DOUBLE_EQ(drivers[i]->delay_ns.at(0), expect[i]) << "case " << i;
  }
  // Two of them written out: 1 column per ADC at 1 bit: fill 10+2+10+10+10 = 42 -> 50 ns,
  // then 15 x 10; 8 columns per ADC at 8 bits: 10+16+80+640+10 = 756 -> 760 ns, then 15 x 640.
  EXPECT_DOUBLE_EQ(drivers[0]->delay_ns[0], 50 + 150);
  EXPECT_DOUBLE_EQ(drivers[8]->delay_ns[0], 760 + 15 * 640);
}

// Row groups of a 3x3 convolution on 8 x 8 (6 x 6 outputs, 36 iterations), as the platform sends
// them: a transaction of output rows 1..2 (iterations 6..17) on 3 copies takes the slowest
// copy's contiguous share of 4 iterations, without the fill (only the image's first iteration
// fills the datapath); the image's first group takes it. The shift register bounds the
// iterations that start a row (36 entries at 4 a cycle: 90 ns), the crossbar the others (20 ns).
TEST(TileSchedule, ARowGroupOnCopiesTakesTheSlowestShareAndOnlyTheFirstGroupFills) {
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
  Tile tile("tile", pc);
  Driver driver("driver");
  driver.out.bind(tile.noc2tile);
  LayerJob job;
  job.layer = &L;
  job.analog = &analog;
  job.timing_only = true;
  job.replication = 3;
  job.first_iteration = 6;
  job.count = 12;
  driver.jobs.push_back(job);  // rows 1..2 on 3 copies
  job.first_iteration = 0;
  job.count = 6;
  job.replication = 1;
  driver.jobs.push_back(job);  // row 0 on one copy
  job.count = -1;
  job.timing_only = false;
  job.first_iteration = 6;
  driver.jobs.push_back(job);  // values of a part of the pass: refused
  sc_core::sc_start();
  ASSERT_EQ(driver.status.size(), 3u);
  ASSERT_EQ(driver.status[0], tlm::TLM_OK_RESPONSE);
  ASSERT_EQ(driver.status[1], tlm::TLM_OK_RESPONSE);
  EXPECT_EQ(driver.status[2], tlm::TLM_COMMAND_ERROR_RESPONSE);
  // Shares: iterations 6-9 (6 starts row 1: 90 + 3 x 30), 10-13 (12 starts row 2: 30+30+90+30),
  // 14-17 (4 x 30): the shift of 12 entries takes 3 cycles = 30 ns > the crossbar's 20.
  EXPECT_DOUBLE_EQ(driver.delay_ns[0], 180);
  // Row 0 alone: the fill (90 + 2 + 20 + ADC + 10 = 122.x -> 130 ns), then 5 x 30.
  EXPECT_DOUBLE_EQ(driver.delay_ns[1], 130 + 5 * 30);
  // The counters hold the two timed parts only: 18 iterations, 3 refills.
  EXPECT_EQ(tile.iterations(), 18);
  EXPECT_EQ(tile.shift_register().refills(), 3);
  EXPECT_EQ(tile.shift_register().shifted_entries(), 3 * 36 + 15 * 12);
}
