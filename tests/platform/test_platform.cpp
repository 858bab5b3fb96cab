// SystemC modules and platform: values, delays and counters through the sockets, iteration
// counts against the closed form, ideal timing, and equivalence with the batch engine.
#include <gtest/gtest.h>

#include <random>
#include <systemc>

#include "platform/Pipeline.h"
#include "sw/analog/analog_layer.h"
#include "sw/nn/network.h"
#include "sw/nn/presets.h"
#include "sw/study/hardware.h"
#include "tests/onnx_builder.h"

#include "tests/platform/one_simulation.h"

using namespace xbarsim;

namespace {

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

/// Sends one job to a tile and keeps the annotated delay and the response.
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
};

/// One job of layer L on `analog` through a tile, simulated.
struct TileRun {
  TileRun(const LinearLayer& L, const AnalogLayer& analog, const PlatformConfig& pc, const std::vector<float>& act,
          bool detailed)
      : driver("driver"), tile("tile", pc) {
    driver.out.bind(tile.noc2tile);
    job.layer = &L;
    job.analog = &analog;
    job.activation = act.data();
    job.detailed = detailed;
    driver.job = &job;
    sc_core::sc_start();
  }
  /// Values: exactly the analog layer's forward pass on the im2col rows.
  void expect_forward_of(const AnalogLayer& analog) const {
    RowMatrixXf cols;
    im2col(*job.layer, job.activation, cols);
    Eigen::MatrixXf expect;
    analog.forward<float>(cols, expect);
    EXPECT_EQ(job.y, expect);
  }
  /// When the pass's output left the tile (ns).
  double done_ns() const {
    EXPECT_EQ(tile.completions().size(), 1u);
    return tile.completions().empty() ? -1.0 : to_ns(tile.completions().back());
  }
  Driver driver;
  Tile tile;
  LayerJob job;
};

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
  const auto act = random_activation(L.in, 5);
  TileRun run(L, analog, pc, act, true);
  Driver& driver = run.driver;
  Tile& tile = run.tile;
  ASSERT_EQ(driver.status, tlm::TLM_OK_RESPONSE);
  run.expect_forward_of(analog);
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
  // Time: every unit holds an iteration for whole 10-ns cycles: the DAC (1 ns), the crossbars
  // (5 ns), the ADCs (ceil(20 / 2) = 10 conversions at 1.28 GS/s: 7.8 ns) and the accumulator
  // (2 ns) one cycle each, the shift register 2 cycles to refill 72 entries at a row's start
  // and one to shift in 24: it is the slowest unit, and the last iteration leaves 4 cycles
  // after it.
  const double clk = pc.clock_ns();
  ASSERT_EQ(pc.shift_entries_per_cycle, 64);
  ASSERT_LE(std::ceil(20.0 / 2) / pc.adc_rate_gsps, clk);
  double shifts = 0;
  for (int k = 0; k < n; ++k) shifts += (k % L.out.w == 0) ? 2 * clk : clk;
  EXPECT_NEAR(run.done_ns(), shifts + 4 * clk, 1e-6);
  EXPECT_NEAR(to_ns(driver.delay), 0, 1e-9);  // nothing annotated: the units' processes take the time
}

// A grouped layer through the modules: the DAC hands the crossbars their inputs group by group
// (as AnalogLayer::forward arranges them), and the tile counts the inventory's groups.
TEST(Tile, GroupedLayerReadsItsGroupsCrossbars) {
  ONE_SIMULATION_PER_PROCESS();
  LinearLayer L = conv_layer(8, 8, 3, 1, 1, 6, 6);  // 4 groups of 2 channels: 18 rows x 2 columns
  L.group = 4;
  for (int r = 0; r < L.rows(); ++r)
    for (int o = 0; o < L.c_out; ++o)
      if ((r % L.c_in) / 2 != o / 2) L.weight(r, o) = 0;  // block-diagonal, input channel innermost
  AnalogConfig ac = quantized_partitioned();
  ac.mapping.max_rows = 16;     // two row blocks per group
  ac.converters.adc_bits = 0;  // (8-bit ranges from ten random calibration vectors would clip)
  AnalogLayer analog(ac, L.weight.cast<double>(), 1.0, false, 1, RowGroups{L.group, L.c_in});
  analog.program(Eigen::MatrixXd());
  PlatformConfig pc;
  const auto act = random_activation(L.in, 9);
  TileRun run(L, analog, pc, act, true);
  ASSERT_EQ(run.driver.status, tlm::TLM_OK_RESPONSE);
  run.expect_forward_of(analog);
  const int n = L.out.h * L.out.w;
  EXPECT_EQ(analog.crossbars(), 4 * 2);
  EXPECT_EQ(run.tile.crossbars().cell_reads(), static_cast<long long>(n) * 72 * 2);  // 18 rows x 2 columns a group
  const LayerInventory inv = layer_inventory(L, MappingScheme::Dense, ac.mapping, pc.adc_columns_per_unit);
  EXPECT_EQ(inv.crossbars, analog.crossbars());
  const ActionCounts closed = layer_actions_per_image(inv, dense_shifted_entries(L)), counted = run.tile.actions();
  EXPECT_EQ(counted.dac_conversions, closed.dac_conversions);
  EXPECT_EQ(counted.adc_conversions, closed.adc_conversions);
  EXPECT_EQ(counted.cell_reads, closed.cell_reads);
  EXPECT_EQ(counted.accumulates, closed.accumulates);
  // The values against the software product, up to the DAC's steps and the wires' residue.
  RowMatrixXf cols;
  im2col(L, act.data(), cols);
  const Eigen::MatrixXf ideal = cols * L.weight;
  EXPECT_LT((run.job.y - ideal).cwiseAbs().maxCoeff(), 0.01 * ideal.cwiseAbs().maxCoeff());
}

// Bit-serial inputs on bit-sliced weights: the modules stream every read and the tile counts
// what the inventory's closed form says.
TEST(Tile, BitSerialReadsOfSlicedWeights) {
  ONE_SIMULATION_PER_PROCESS();
  const LinearLayer L = conv_layer(4, 6, 3, 1, 1, 5, 5);  // 36 rows x 6 weight columns
  AnalogConfig ac = quantized_partitioned();
  ac.converters.input_bits = 8;
  ac.converters.dac_bits = 2;  // 4 reads per iteration
  ac.mapping.cell_bits = 2;
  ac.mapping.weight_bits = 8;  // 4 cells per weight: 24 physical columns, one 32-column crossbar wide
  AnalogLayer analog(ac, L.weight.cast<double>(), 1.0, false, 1);
  analog.program(Eigen::MatrixXd());
  PlatformConfig pc;
  pc.detailed = false;
  const auto act = random_activation(L.in, 7);
  TileRun run(L, analog, pc, act, false);
  Driver& driver = run.driver;
  Tile& tile = run.tile;
  run.expect_forward_of(analog);
  const int n = L.out.h * L.out.w;
  LayerInventory inv = layer_inventory(L, MappingScheme::Dense, ac.mapping, pc.adc_columns_per_unit);
  stream_inputs(inv, ac.converters, false);
  ASSERT_EQ(inv.input_slices, 4);
  const ActionCounts closed = layer_actions_per_image(inv, dense_shifted_entries(L)), counted = tile.actions();
  EXPECT_EQ(counted.dac_conversions, 4.0 * n * 36);
  EXPECT_EQ(counted.dac_conversions, closed.dac_conversions);
  EXPECT_EQ(counted.adc_conversions, 4.0 * n * 24);
  EXPECT_EQ(counted.adc_conversions, closed.adc_conversions);
  EXPECT_EQ(counted.cell_reads, closed.cell_reads);
  EXPECT_EQ(counted.shift_adds, closed.shift_adds);
  EXPECT_EQ(counted.samples, closed.samples);
  EXPECT_EQ(counted.accumulates, closed.accumulates);
  // Ideal timing: one read per cycle.
  EXPECT_NEAR(run.done_ns(), 4.0 * n * pc.clock_ns(), 1e-6);
  (void)driver;
}

namespace {

/// A pipeline over `m` with `images` random images; returns its result after the run.
struct PipelineRun {
  /// `machine`: run on it (its mapping's replication), else layer-sized.
  PipelineRun(const Model& m, const PlatformConfig& pc, std::vector<int> replication = {},
              const MachinePlan* machine = nullptr, const AnalogConfig& ac = quantized_partitioned())
      : model(m), xb(m, ac) {
    xb.program(random_dataset(m.input, 8, 1), 512);
    images = random_dataset(m.input, pc.images, 2);
    if (machine)
      for (const LayerPlacement& p : machine->mapping.layers) replication.push_back(p.replication);
    if (replication.empty()) replication.assign(m.linear.size(), 1);
    pipe = std::make_unique<Pipeline>(
        "acc", m, xb, pc, replication, [this](int k, float* x) { images.preprocess(k, model.pre, x); }, nullptr,
        std::vector<SparseIterationNs>{}, machine);
    sc_core::sc_start();
  }
  /// Logits bit-identical to the batch engine (the functions eval uses).
  void expect_logits_of_the_batch_engine() {
    const PipelineResult& r = pipe->result();
    ASSERT_TRUE(r.completed);
    ASSERT_EQ(static_cast<int>(r.logits.size()), images.count());
    std::vector<float> x(model.input.size());
    for (int k = 0; k < images.count(); ++k) {
      images.preprocess(k, model.pre, x.data());
      EXPECT_EQ(r.logits[k], run_image(model, x.data(), xb)) << "image " << k;
    }
  }
  const Model& model;
  CrossbarBackend xb;
  Dataset images;
  std::unique_ptr<Pipeline> pipe;
};

/// Ideal timing, a wide zero-latency interconnect, fast memory and digital units.
PlatformConfig fast_platform(int images, bool pipelined) {
  PlatformConfig pc;
  pc.images = images;
  pc.pipelined = pipelined;
  pc.detailed = false;
  pc.link_bytes_per_cycle = 1 << 20;
  pc.hop_cycles = 0;
  pc.memory_bytes_per_cycle = 1 << 20;
  pc.memory_latency_ns = 0;
  pc.digital_ops_per_cycle = 1 << 20;
  pc.buffer_bytes = 1 << 20;
  return pc;
}

}  // namespace

TEST(Platform, SequentialIdealResnet20IsThePapersIterationCount) {
  ONE_SIMULATION_PER_PROCESS();
  const Model m = make_preset("resnet20", 3);
  PlatformConfig pc;
  pc.images = 2;
  pc.detailed = false;  // ideal timing: one clock cycle per iteration
  PipelineRun run(m, pc);
  run.expect_logits_of_the_batch_engine();
  const PipelineResult& r = run.pipe->result();
  double busy = 0;
  long long total = 0;
  for (const StageStats& st : r.stages) {
    if (st.linear < 0) continue;
    const LinearLayer& L = m.linear[st.linear];
    EXPECT_NEAR(st.busy_ns, 2.0 * L.iterations() * pc.clock_ns(), 1e-6) << L.name;
    EXPECT_EQ(run.pipe->tile(st.linear).iterations(), 2LL * L.iterations());
    busy += st.busy_ns / 2;
    total += L.iterations();
  }
  EXPECT_EQ(total, 9089);
  EXPECT_NEAR(busy, 90890.0, 1e-6);  // 9089 iterations x 10 ns (the paper)
  // Sequential: the second image enters when the first has left.
  EXPECT_GE(r.image_in_ns[1], r.image_out_ns[0]);
}

TEST(Platform, PipelinedThroughputIsTheSlowestStage) {
  ONE_SIMULATION_PER_PROCESS();
  const Model m = make_preset("lenet", 3);  // conv1: 24 x 24 = 576 iterations, the slowest stage
  const int n = 12;
  PlatformConfig pc = fast_platform(n, true);
  pc.check_protocol = true;
  pc.threads = 2;  // values on two workers, at most 8 images ahead of them: the processes wait for image 0's
  PipelineRun run(m, pc);
  run.expect_logits_of_the_batch_engine();
  const PipelineResult& r = run.pipe->result();
  EXPECT_GT(r.protocol_transactions, 0);  // every transfer and tile call kept the base protocol
  EXPECT_TRUE(r.protocol_violations.empty()) << r.protocol_violations.front();
  const double stage_ns = 576 * 10.0;
  EXPECT_NEAR(r.throughput_per_s(), 1e9 / stage_ns, 0.01 * 1e9 / stage_ns);
  // makespan(N) = fill + (N - 1) / throughput, the fill being the first image's latency.
  EXPECT_NEAR(r.makespan_ns(), r.latency_ns() + (n - 1) * stage_ns, 0.01 * r.makespan_ns());
  // Several images were in flight: the second entered before the first left.
  EXPECT_LT(r.image_in_ns[1], r.image_out_ns[0]);
  // A stage's time: busy, stalled on its output, starved of input, or done; the bottleneck is
  // never starved after the first image's rows arrive, the last layer mostly is.
  for (const StageStats& st : r.stages)
    EXPECT_LE(st.busy_ns + st.stall_ns + st.starved_ns, r.makespan_ns() + 1e-6) << st.name;
  const StageStats& conv1 = r.stages.front();
  const StageStats& last = r.stages.back();
  ASSERT_EQ(conv1.name, "conv1");
  EXPECT_LT(conv1.starved_ns, 0.05 * r.makespan_ns());
  EXPECT_GT(last.starved_ns, 0.5 * r.makespan_ns()) << last.name;
}

TEST(Platform, NarrowInterconnectLimitsThroughput) {
  ONE_SIMULATION_PER_PROCESS();
  const Model m = make_preset("lenet", 3);
  PlatformConfig pc = fast_platform(24, true);
  pc.buffer_bytes = 0;          // line buffers: the memory port cannot run far ahead
  pc.link_bytes_per_cycle = 1;  // one byte per cycle: every activation byte takes a cycle
  PipelineRun run(m, pc);
  run.expect_logits_of_the_batch_engine();
  const PipelineResult& r = run.pipe->result();
  // By hand: every value crosses the bus once per consumer (the input from memory too,
  // the logits to memory), one byte per activation.
  std::vector<int> consumers(m.values.size(), 0);
  for (const Op& op : m.ops)
    for (int v : op.in) ++consumers[v];
  ++consumers[m.output];
  long long bytes = 0;
  for (size_t v = 0; v < m.values.size(); ++v) bytes += static_cast<long long>(m.values[v].size()) * consumers[v];
  EXPECT_EQ(r.bus_bytes, bytes * 24);
  ASSERT_GT(bytes, 576);  // the bus, not conv1, is the bottleneck
  EXPECT_NEAR(r.throughput_per_s(), 1e9 / (bytes * 10.0), 0.01 * 1e9 / (bytes * 10.0));
}

TEST(Platform, SmallBuffersStallTheProducerAndTooSmallOnesAreReported) {
  ONE_SIMULATION_PER_PROCESS();
  const Model m = make_preset("lenet", 3);
  PlatformConfig pc = fast_platform(12, true);
  pc.buffer_bytes = 1200;  // 5 rows of conv2's input window; conv1's input holds 42 of its 28-byte rows
  PipelineRun run(m, pc);
  run.expect_logits_of_the_batch_engine();
  const PipelineResult& r = run.pipe->result();
  // The memory port delivers a 28-byte row per cycle while conv1 consumes one per 24 cycles:
  // it stalls on the full buffer, and the throughput stays that of conv1 (576 cycles).
  EXPECT_GT(r.memory_stall_ns, 0);
  EXPECT_LE(r.throughput_per_s(), 1.001 * 1e9 / 5760.0);
  EXPECT_GE(r.throughput_per_s(), 0.97 * 1e9 / 5760.0);
}

TEST(Platform, CoarserTransactionsKeepValuesAndBusyTime) {
  ONE_SIMULATION_PER_PROCESS();
  const Model m = make_preset("resnet20", 3);
  PlatformConfig pc;
  pc.images = 2;
  pc.detailed = false;
  pc.pipelined = true;
  pc.grain_rows = 4;  // four output rows per transaction
  PipelineRun run(m, pc);
  run.expect_logits_of_the_batch_engine();
  double busy = 0;
  for (const StageStats& st : run.pipe->result().stages)
    if (st.linear >= 0) busy += st.busy_ns / 2;
  EXPECT_NEAR(busy, 90890.0, 1e-6);
}

TEST(Platform, ReplicationDividesTheStageTime) {
  ONE_SIMULATION_PER_PROCESS();
  const Model m = make_preset("lenet", 3);
  PipelineRun run(m, fast_platform(12, true), {4, 1, 1, 1});  // conv1 on 4 tiles: 24 / 4 = 6 iterations per row each
  run.expect_logits_of_the_batch_engine();
  const PipelineResult& r = run.pipe->result();
  const double stage_ns = 576 * 10.0 / 4;  // conv1 / 4 = 1440 ns > conv2's 640 ns
  EXPECT_NEAR(r.throughput_per_s(), 1e9 / stage_ns, 0.01 * 1e9 / stage_ns);
  EXPECT_EQ(r.stages[0].replication, 4);
}

namespace {

/// 3 x 8 x 8 -> Conv 3x3 (4 channels) -> SiLU (Sigmoid, Mul) -> a squeeze-excitation
/// (GlobalAveragePool, Conv 1x1, HardSigmoid, the 4 x 1 x 1 scale times the 4 x 8 x 8 map)
/// -> Sub of the pooled 4 x 1 x 1 -> Div by the sigmoid of the map -> Conv 3x3/2 ->
/// GlobalAveragePool -> Flatten -> Gemm (4 -> 3).
Model squeeze_excitation_model() {
  using namespace onnx_builder;
  onnx::ModelProto m = model("se", "xbarsim tests");
  auto* g = m.mutable_graph();
  io(g->add_input(), "x", {1, 3, 8, 8});
  auto weights = [](size_t i) { return static_cast<float>(static_cast<int>(i * 7 % 11) - 5) * 0.1f; };
  float_init(g, "w1", {4, 3, 3, 3}, weights);
  float_init(g, "w2", {4, 4, 1, 1}, weights);
  float_init(g, "w3", {4, 4, 3, 3}, weights);
  float_init(g, "w4", {3, 4}, weights);
  ints_attr(node(g, "Conv", {"x", "w1"}, "c1"), "pads", {1, 1, 1, 1});
  node(g, "Sigmoid", {"c1"}, "s1");
  node(g, "Mul", {"c1", "s1"}, "silu");
  node(g, "GlobalAveragePool", {"silu"}, "gap");
  node(g, "Conv", {"gap", "w2"}, "fc");
  node(g, "HardSigmoid", {"fc"}, "scale");
  node(g, "Mul", {"scale", "silu"}, "se");
  node(g, "Sub", {"se", "gap"}, "centred");
  node(g, "Sigmoid", {"se"}, "s2");
  node(g, "Div", {"centred", "s2"}, "dv");
  auto* c3 = node(g, "Conv", {"dv", "w3"}, "c3");
  ints_attr(c3, "pads", {1, 1, 1, 1});
  ints_attr(c3, "strides", {2, 2});
  node(g, "GlobalAveragePool", {"c3"}, "gap3");
  node(g, "Flatten", {"gap3"}, "f");
  int_attr(node(g, "Gemm", {"f", "w4"}, "y"), "transB", 1);
  io(g->add_output(), "y", {1, 3});
  return load_onnx_model_from_bytes(m.SerializeAsString(), "se");
}

}  // namespace

// Issue 39, item 2: Mul, Sub and Div of two values whose one input is a single row (a
// squeeze-excitation's C x 1 x 1 scale) run in the pipeline: the row is read once and serves
// every output row (it waited for row r of a one-row input, and the run never completed), the
// buffers sized automatically, and the logits are the batch engine's.
TEST(Platform, ASqueezeExcitationsScaleServesEveryRow) {
  ONE_SIMULATION_PER_PROCESS();
  const Model m = squeeze_excitation_model();
  PlatformConfig pc = fast_platform(3, true);
  pc.buffer_bytes = 0;  // sized automatically
  pc.threads = 2;
  PipelineRun run(m, pc);
  run.expect_logits_of_the_batch_engine();
  long long ops = 0;
  for (const StageStats& st : run.pipe->result().stages)
    if (st.kind == OpKind::Mul || st.kind == OpKind::Sub || st.kind == OpKind::Div) ops += st.digital_ops;
  EXPECT_EQ(ops, 3LL * 4 * 4 * 8 * 8);  // one operation per output element: 3 images x 4 ops of 4 x 8 x 8
}

TEST(Platform, AutoReplicationUnderTwiceTheCrossbarsRaisesThroughput) {
  ONE_SIMULATION_PER_PROCESS();
  const Model m = make_preset("resnet20", 3);
  CrossbarBackend xb(m, quantized_partitioned());
  xb.program(random_dataset(m.input, 8, 1), 512);
  PlatformConfig pc = fast_platform(1, true);
  pc.auto_replication = true;
  const std::vector<int> r = resolve_replication(m, xb, pc);
  long long base = 0, used = 0;
  double slowest_before = 0, slowest_after = 0;
  for (size_t l = 0; l < m.linear.size(); ++l) {
    base += xb.layer(static_cast<int>(l)).crossbars();
    used += static_cast<long long>(r[l]) * xb.layer(static_cast<int>(l)).crossbars();
    slowest_before = std::max(slowest_before, static_cast<double>(m.linear[l].iterations()));
    slowest_after = std::max(slowest_after, static_cast<double>(m.linear[l].iterations()) / r[l]);
  }
  EXPECT_LE(used, 2 * base);
  EXPECT_GT(r[0], 1);  // the first layers (32 x 32 outputs) are copied, as in ISAAC
  EXPECT_LT(slowest_after, slowest_before / 2);
}

// A machine's ADC shared by k crossbars converts k crossbars' columns per read: an ADC-bound
// tile takes k times as long per iteration (the hand factor).
TEST(Tile, AnAdcSharedByThreeCrossbarsTripleTheAdcBoundIteration) {
  ONE_SIMULATION_PER_PROCESS();
  const LinearLayer L = conv_layer(8, 40, 3, 1, 1, 6, 6);  // 72 rows x 40 cols: 2 x 2 crossbars of 20 columns
  AnalogConfig ac = quantized_partitioned();
  AnalogLayer analog(ac, L.weight.cast<double>(), 1.0, false, 1);
  analog.program(Eigen::MatrixXd());
  PlatformConfig pc;
  pc.crossbars_per_adc = 3;
  pc.adc_rate_gsps = 0.1;  // 20 columns x 3 crossbars / 0.1 GS/s = 600 ns, far above every other stage
  const auto act = random_activation(L.in, 5);
  TileRun run(L, analog, pc, act, true);
  run.expect_forward_of(analog);
  const int n = L.out.h * L.out.w;
  const double clk = pc.clock_ns(), adc_ns = 20.0 * 3 / 0.1;
  // The first iteration's refill (2 cycles), DAC and crossbars (a cycle each), then the ADC's
  // n conversions back to back, then the accumulator's cycle.
  EXPECT_NEAR(run.done_ns(), 2 * clk + 2 * clk + n * adc_ns + clk, 1e-6);
}

namespace {

/// A machine of 3 tiles on a 3 x 1 mesh (a router each), 64 IMAs of 2 crossbars of 64 x 32 per
/// tile, with a ReLU, pooling and add unit on every tile.
MachinePlan toy_machine(const Model& m, const AnalogConfig& ac) {
  MachinePlan plan;
  Architecture& a = plan.arch;
  a.name = "toy";
  a.machine = true;
  a.crossbar = {64, 32, 0};
  a.ima = {2, 2, 100.0, 1024, 256, {}};
  a.tile.imas = 64;
  a.tile.edram_bytes = 65536;
  a.tile.edram_bytes_per_ns = 32;
  a.tile.units = {{"alu", 1, 1.0, {"relu", "affine", "add", "maxpool", "avgpool", "globalavgpool"}}};
  a.chip.tiles = 3;
  a.chip.tiles_per_router = 1;
  a.chip.mesh_rows = 3;
  a.chip.mesh_cols = 1;
  a.chip.router = {"router", 1, 4.0, {}};
  a.chip.hop_ns = 1;
  a.chip.offchip = {"link", 1, 16.0, {}};
  std::vector<LayerInventory> layers;
  for (const LinearLayer& L : m.linear) layers.push_back(layer_inventory(L, MappingScheme::Dense, ac.mapping, 32));
  PlatformConfig pc;
  plan.mapping = map_network(layers, a, pc);
  return plan;
}

}  // namespace

// On a machine the values are still the batch engine's, rows cross the mesh between tiles, and
// layers that share a tile pass their rows through its eDRAM.
TEST(Platform, OnAMachineTheLogitsAreTheBatchEnginesAndRowsCrossTheMesh) {
  ONE_SIMULATION_PER_PROCESS();
  const Model m = make_preset("lenet", 3);
  const MachinePlan plan = toy_machine(m, quantized_partitioned());
  ASSERT_TRUE(plan.mapping.fits) << plan.mapping.reason;
  ASSERT_GE(plan.mapping.tiles_used, 2);  // so that some rows cross the mesh
  PlatformConfig pc;
  pc.images = 3;
  pc.pipelined = true;
  pc.check_protocol = true;
  pc.threads = 3;  // the values on three workers: the logits do not depend on them
  PipelineRun run(m, pc, {}, &plan);
  run.expect_logits_of_the_batch_engine();
  const PipelineResult& r = run.pipe->result();
  EXPECT_GT(r.protocol_transactions, 0);  // every transfer and tile call kept the base protocol
  EXPECT_TRUE(r.protocol_violations.empty()) << r.protocol_violations.front();
  EXPECT_GT(r.bus_bytes, 0);  // the mesh
  EXPECT_GT(r.router_bytes, 0);
  EXPECT_GT(r.local_bytes, 0);  // a tile's own eDRAM
  for (const StageStats& st : r.stages) EXPECT_GE(st.tile, 0) << st.name;
}

// The mapper's estimate of every stage's busy time is the simulation's where the units follow
// one another without waiting: ResNet-20 on ISAAC-CE (configs/isaac.yaml, auto replication),
// its IMAs with 8 or 4 ADCs, one or two output rows per transaction. Every stage's busy time per
// image (a linear stage: its tile's busiest unit) the mapper predicts is the one the
// simulation measures (to 0.1 %: the simulation's times are whole picoseconds), and so is the
// bottleneck. By hand: layer2.0/conv2 (16 x 16 outputs, 288 rows on 3 crossbars of 128 columns
// in one IMA, 8 bit-serial reads per iteration, one read per 100 ns) with at least 16 copies
// and one row per transaction gives each copy one iteration of each of the 16 rows: its busiest
// unit, the ADCs, works 8 x 128 / 1.28 GS/s = 800 ns an iteration, or with 4 ADCs in the IMA
// (2 crossbars per ADC) 8 x 256 / 1.28 = 1600 ns. Two rows per transaction: layer1.0/add
// performs 16 x 32 x 32 additions on one shift-and-add unit at 1.2 per ns: 13 653 ns.
namespace {
struct MachineCase {
  int adcs, grain_rows;
};
class MapperAgreesWithTheSimulation : public ::testing::TestWithParam<MachineCase> {};
}  // namespace

TEST_P(MapperAgreesWithTheSimulation, PerStageBusyTimeAndBottleneck) {
  ONE_SIMULATION_PER_PROCESS();
  const MachineCase c = GetParam();
  const ConfigTree cfg = ConfigTree::load(std::string(XBARSIM_SOURCE_DIR) + "/configs/isaac.yaml",
                                          {"platform.timing_only=true", "platform.images=1",
                                           "platform.grain_rows=" + std::to_string(c.grain_rows)});
  const AnalogConfig ac = parse_analog_config(cfg);
  HardwareContext hw = make_hardware_context(cfg, ac);
  hw.arch.ima.adcs = c.adcs;
  const Model m = make_preset("resnet20", 3);
  const MachineReport mr = machine_report(m, hw, linear_inputs_signed(m));
  ASSERT_TRUE(mr.mapping.fits) << mr.mapping.reason;
  const MachinePlan plan{hw.arch, mr.mapping};
  CrossbarBackend xb(m, ac);
  xb.structure_only();
  std::vector<int> replication;
  for (const LayerPlacement& p : mr.mapping.layers) replication.push_back(p.replication);
  Pipeline pipe("acc", m, xb, hw.platform, replication, [](int, float*) {}, nullptr, {}, &plan);
  sc_core::sc_start();
  const PipelineResult& r = pipe.result();
  ASSERT_TRUE(r.completed);
  const StageStats* slowest = nullptr;
  size_t digital = 0;
  for (const StageStats& st : r.stages) {
    if (!slowest || st.busy_ns > slowest->busy_ns) slowest = &st;
    const double predicted = st.linear >= 0 ? mr.mapping.layers[st.linear].compute_ns
                                            : mr.mapping.digital.at(digital++).busy_ns;
    EXPECT_NEAR(st.busy_ns, predicted, 1e-3 * predicted + 1e-6) << st.name;
    if (st.name == "layer2.0/conv2" && c.grain_rows == 1 && st.replication >= 16) {
      EXPECT_NEAR(st.busy_ns, 16 * (c.adcs == 4 ? 1600.0 : 800.0), 1e-3) << "by hand";
    }
    if (st.name == "layer1.0/add") {
      EXPECT_NEAR(st.busy_ns, 16 * 32 * 32 / 1.2, 1e-3) << "by hand";
    }
  }
  EXPECT_EQ(digital, mr.mapping.digital.size());
  ASSERT_NE(slowest, nullptr);
  EXPECT_EQ(mr.mapping.bottleneck_stage, slowest->name);
  EXPECT_NEAR(mr.mapping.bottleneck_ns, slowest->busy_ns, 1e-3 * slowest->busy_ns);
}

INSTANTIATE_TEST_SUITE_P(ResNet20OnIsaacCe, MapperAgreesWithTheSimulation,
                         ::testing::Values(MachineCase{8, 1}, MachineCase{4, 1}, MachineCase{8, 2},
                                           MachineCase{4, 2}),
                         [](const ::testing::TestParamInfo<MachineCase>& i) {
                           return "adcs" + std::to_string(i.param.adcs) + "_grain" +
                                  std::to_string(i.param.grain_rows);
                         });
