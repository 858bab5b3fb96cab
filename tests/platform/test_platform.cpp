// SystemC modules and platform: values, delays and counters through the sockets, iteration
// counts against the closed form, ideal timing, and equivalence with the batch engine.
#include <gtest/gtest.h>

#include <random>
#include <systemc>

#include "platform/Accelerator.h"
#include "sw/nn/presets.h"

using namespace xbarsim;

namespace {

bool g_elaborated = false;
#define ONE_SIMULATION_PER_PROCESS()                                                                   \
  if (g_elaborated) GTEST_SKIP() << "SystemC elaborates once per process; ctest runs each case alone"; \
  g_elaborated = true

LinearLayer conv_layer(int c_in, int c_out, int k, int stride, int pad, int h, int w) {
  LinearLayer L;
  L.c_in = c_in;
  L.c_out = c_out;
  L.k_h = L.k_w = k;
  L.stride_h = L.stride_w = stride;
  L.pad_t = L.pad_l = L.pad_b = L.pad_r = pad;
  L.in = {c_in, h, w};
  L.out = {c_out, (h + 2 * pad - k) / stride + 1, (w + 2 * pad - k) / stride + 1};
  L.weight = Eigen::MatrixXf::Random(L.rows(), c_out);
  L.bias = Eigen::VectorXf::Zero(c_out);
  return L;
}

std::vector<float> random_activation(const Shape& s, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0, 1);
  std::vector<float> v(s.size());
  for (auto& x : v) x = u(rng);
  return v;
}

AnalogConfig quantized_partitioned() {
  AnalogConfig c;
  c.mapping.max_rows = 64;
  c.mapping.max_cols = 32;
  c.converters.dac_bits = 8;
  c.converters.adc_bits = 8;
  c.set_method("conversion+calibration", "test");
  return c;
}

}  // namespace

TEST(ShiftRegisterBuffer, ContentsEqualIm2colAndShiftsAreCounted) {
  struct Case {
    int c, k, stride, pad, h, w;
  } cases[] = {{4, 3, 1, 1, 8, 8}, {3, 3, 2, 1, 9, 7}, {2, 5, 1, 0, 12, 12}, {5, 1, 1, 0, 4, 4}, {3, 2, 3, 0, 9, 9}};
  for (const auto& cs : cases) {
    const LinearLayer L = conv_layer(cs.c, 4, cs.k, cs.stride, cs.pad, cs.h, cs.w);
    const auto act = random_activation(L.in, 3);
    LayerJob job;
    job.layer = &L;
    job.activation = act.data();
    ShiftRegisterBuffer::fill(job);
    RowMatrixXf ref;
    im2col(L, act.data(), ref);
    EXPECT_EQ(job.xq, ref) << cs.k << " stride " << cs.stride;
    // Closed form: each output row refills K entries, then shifts stride*k*c per step.
    const bool shifts = cs.stride < cs.k;
    const long long per_row = shifts ? L.rows() + static_cast<long long>(L.out.w - 1) * cs.stride * cs.k * cs.c
                                     : static_cast<long long>(L.out.w) * L.rows();
    EXPECT_EQ(job.shifted_entries, per_row * L.out.h);
    EXPECT_EQ(job.refills, shifts ? L.out.h : L.out.h * L.out.w);
  }
}

TEST(Tile, ModulesComputeTheAnalogLayerAndAnnotateDelays) {
  ONE_SIMULATION_PER_PROCESS();
  const LinearLayer L = conv_layer(8, 40, 3, 1, 1, 6, 6);  // 72 rows x 40 cols
  AnalogConfig ac = quantized_partitioned();
  AnalogLayer analog(ac, L.weight.cast<double>(), 1.0, false, 1);
  analog.program(Eigen::MatrixXd());
  PlatformConfig pc;
  pc.adc_columns_per_unit = 10;  // 2 ADCs shared by a crossbar's 20 columns
  struct Driver : sc_core::sc_module {
    tlm_utils::simple_initiator_socket<Driver> out{"out"};
    LayerJob* job = nullptr;
    sc_core::sc_time delay = sc_core::SC_ZERO_TIME;
    tlm::tlm_response_status status = tlm::TLM_INCOMPLETE_RESPONSE;
    SC_HAS_PROCESS(Driver);
    explicit Driver(sc_core::sc_module_name n) : sc_module(n) { SC_THREAD(run); }
    void run() {
      tlm::tlm_generic_payload p;
      attach(p, *job, 0);
      out->b_transport(p, delay);
      status = p.get_response_status();
    }
  } driver("driver");
  Tile tile("tile", pc);
  driver.out.bind(tile.noc2tile);
  const auto act = random_activation(L.in, 5);
  LayerJob job;
  job.layer = &L;
  job.analog = &analog;
  job.activation = act.data();
  driver.job = &job;
  sc_core::sc_start();
  ASSERT_EQ(driver.status, tlm::TLM_OK_RESPONSE);
  // Values: exactly the analog layer's forward pass on the im2col rows.
  RowMatrixXf cols;
  im2col(L, act.data(), cols);
  Eigen::MatrixXf expect;
  analog.forward<float>(cols, expect);
  EXPECT_EQ(job.y, expect);
  // Counters.
  const int n = L.out.h * L.out.w;
  EXPECT_EQ(tile.iterations(), n);
  // Each of the 2 column blocks has its own row DACs: every row converts twice per iteration.
  EXPECT_EQ(tile.dac().conversions(), static_cast<long long>(n) * L.rows() * 2);
  EXPECT_EQ(tile.crossbars().cell_reads(), static_cast<long long>(n) * 72 * 40);
  EXPECT_EQ(tile.accumulator().accumulations(), static_cast<long long>(n) * 40 * 2);  // 2 row blocks
  // The counted actions are the inventory's closed form (the energy both price).
  const LayerInventory inv = layer_inventory(L, MappingScheme::Dense, ac.mapping, pc.adc_columns_per_unit);
  const ActionCounts closed = layer_actions_per_image(inv, dense_shifted_entries(L)), counted = tile.actions();
  EXPECT_EQ(counted.dac_conversions, closed.dac_conversions);
  EXPECT_EQ(counted.adc_conversions, closed.adc_conversions);
  EXPECT_EQ(counted.cell_reads, closed.cell_reads);
  EXPECT_EQ(counted.accumulates, closed.accumulates);
  EXPECT_EQ(counted.shifts, closed.shifts);
  EXPECT_EQ(counted.buffer_write_bytes, closed.buffer_write_bytes);
  EXPECT_EQ(inv.crossbars, analog.crossbars());
  EXPECT_EQ(inv.adcs, 2 * 2 * 2);  // 2 ADCs for each crossbar's 20 columns
  EXPECT_EQ(tile.adc().conversions(), static_cast<long long>(n) * 40 * analog.crossbars() / 2);  // 2 column blocks
  EXPECT_EQ(analog.crossbars(), 2 * 2);
  // Delay: fill = first-iteration stage latencies; then the slowest stage per iteration.
  const double clk = pc.clock_ns();
  const double adc_ns = std::ceil(20.0 / 2) / pc.adc_rate_gsps;  // 20 columns per crossbar, 2 ADCs
  const double refill_ns = std::ceil(72.0 / pc.shift_entries_per_cycle) * clk;
  const double shift_ns = std::ceil(24.0 / pc.shift_entries_per_cycle) * clk;
  const double fill =
      std::ceil((refill_ns + pc.dac_latency_ns + pc.crossbar_settle_ns + adc_ns + pc.accumulator_latency_ns) / clk -
                1e-9) *
      clk;
  double steady = 0;
  for (int k = 1; k < n; ++k) {
    const double sr = (k % L.out.w == 0) ? refill_ns : shift_ns;
    const double worst = std::max({sr, pc.dac_latency_ns, pc.crossbar_settle_ns, adc_ns, pc.accumulator_latency_ns});
    steady += std::ceil(worst / clk - 1e-9) * clk;
  }
  EXPECT_NEAR(driver.delay.to_seconds() * 1e9, fill + steady, 1e-6);
}

TEST(Platform, MatchesTheBatchEngineExactlyAndCountsIterations) {
  ONE_SIMULATION_PER_PROCESS();
  const Model m = make_preset("resnet20", 3);
  CrossbarBackend xb(m, quantized_partitioned());
  xb.program(random_dataset(m.input, 8, 1), 512);
  const Dataset images = random_dataset(m.input, 3, 2);
  PlatformConfig pc;
  pc.images = images.count();
  pc.detailed = false;  // ideal timing: one clock cycle per iteration
  Accelerator acc("acc", m, xb, pc, [&](int k, float* x) { images.preprocess(k, m.pre, x); });
  sc_core::sc_start();
  const SimulationResult& r = acc.result();
  ASSERT_EQ(static_cast<int>(r.logits.size()), images.count());
  std::vector<float> x(m.input.size());
  for (int k = 0; k < images.count(); ++k) {
    images.preprocess(k, m.pre, x.data());
    const Eigen::VectorXf batch = run_image(m, x.data(), xb);
    EXPECT_EQ(r.logits[k], batch) << "image " << k;  // bit-identical
  }
  long long total = 0;
  for (size_t l = 0; l < m.linear.size(); ++l) {
    const LinearLayer& L = m.linear[l];
    const long long pixels = static_cast<long long>(L.out.h) * L.out.w;
    EXPECT_EQ(acc.tile(static_cast<int>(l)).iterations(), pixels * images.count());
    EXPECT_EQ(acc.tile(static_cast<int>(l)).cycles(), pixels * images.count());  // ideal: iterations x clock
    EXPECT_NEAR(r.layer_latency_ns[0][l], pixels * pc.clock_ns(), 1e-6);
    total += pixels;
  }
  EXPECT_EQ(total, 9089);
}
