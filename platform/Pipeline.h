#pragma once
/// The accelerator as concurrent SystemC processes: one stage per operation of the network
/// (a tile with its replicas for every Conv/Gemm, a digital unit for ReLU, Add, pooling,
/// global pooling, padding, slicing), each an SC_THREAD that works through its output rows
/// (the transaction grain), waits in its input line buffers for the rows its window needs,
/// computes, and sends each output row over the shared TLM-2.0 bus into the consumers'
/// buffers, stalling while they are full. Images enter from and leave to an off-chip memory
/// port. `sequential`: a stage starts an image only when its whole input is present and the
/// next image enters only when the previous one has left; `pipelined`: line-buffered layers
/// overlap and several images are in flight. Timing, stalls and throughput emerge from the
/// processes. The values do not set the timing (a tile's transaction times and counts its pass
/// from the layer's geometry): they are computed beside the simulation, by the tile modules'
/// own functions (Tile::compute_values) in tasks on platform.threads worker threads, each task
/// submitted when its stage starts the image and run once its inputs' tasks are done. They are
/// the functions `eval` runs, so the logits are bit-identical, on any number of threads.
#include <exception>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <systemc>
#include <tlm>
#include <tlm_utils/simple_initiator_socket.h>
#include <vector>

#include "platform/Bus.h"
#include "platform/MeshNoc.h"
#include "platform/ProtocolChecker.h"
#include "platform/RowBuffer.h"
#include "platform/Tile.h"
#include "sw/hw/mapper.h"
#include "sw/common/output_file.h"
#include "sw/common/task_graph.h"
#include "sw/hw/platform_spec.h"
#include "sw/inference/crossbar_backend.h"

namespace xbarsim {

/// What one stage did over the run.
struct StageStats {
  std::string name;
  OpKind kind = OpKind::Relu;
  int linear = -1;  ///< index of the linear layer, or -1
  int replication = 1;
  int tile = -1;        ///< on a machine: the tile its outputs leave from
  double busy_ns = 0;   ///< computing (the slowest replica per row)
  double stall_ns = 0;  ///< waiting for space in a consumer's buffer
  /// Starved: waiting for input rows (its producer, the interconnect or the memory port was
  /// later than it; the first image's wait is the pipeline filling).
  double starved_ns = 0;
  long long rows = 0, digital_ops = 0;
  /// A dense linear stage: its tile's units that bound it (busy, stall and starved are the
  /// first's), joined by '+' on a tie ("crossbar+adc"; empty: not a tile's), and each unit's
  /// busy time summed over the copies.
  std::string bound_by;
  double unit_busy_ns[kStages] = {};
  long long buffer_bytes = 0, buffer_peak_bytes = 0;  ///< its input buffers: capacity and peak occupancy
};

struct PipelineResult {
  std::vector<Eigen::VectorXf> logits;            ///< per image
  std::vector<double> image_in_ns, image_out_ns;  ///< input starts leaving memory; logits stored
  std::vector<StageStats> stages;
  long long bus_bytes = 0, bus_transfers = 0, memory_bytes = 0;
  double memory_stall_ns = 0;  ///< the input port waiting for space in the first stages' buffers
  double bus_busy_ns = 0;      ///< the bus's lanes, or a machine's mesh links, carrying data (summed)
  /// On a machine: bytes times the routers they crossed, the time transfers waited for busy
  /// links, and the bytes that stayed on their tile (written to its eDRAM without the mesh).
  double router_bytes = 0, noc_contention_ns = 0;
  long long noc_links = 0;  ///< the mesh's directed links (bus_busy_ns is summed over them)
  long long local_bytes = 0;
  /// platform.check_protocol: transactions checked and the base-protocol rules they broke.
  long long protocol_transactions = 0;
  std::vector<std::string> protocol_violations;
  bool completed = false;  ///< false: the run stopped with images still in flight (deadlock)
  /// Not completed: what every unfinished stage and every tile unit holding a row group was
  /// blocked on when the simulation ran out of events.
  std::vector<std::string> blocked;
  double makespan_ns() const { return image_out_ns.empty() ? 0 : image_out_ns.back(); }
  double latency_ns() const { return image_out_ns.empty() ? 0 : image_out_ns.front() - image_in_ns.front(); }
  /// Images per second in steady state: from the spacing of the outputs between the first
  /// and the last quarter of the run.
  double throughput_per_s() const;
};

/// The first exception a process of the simulation threw (a solver that did not converge, a
/// time sc_time cannot hold). SystemC would turn it into an sc_report, an internal error that
/// has lost its kind; here the process ends the run (sc_stop) and the exception is rethrown,
/// with its type, once sc_start() has returned.
class ProcessFailure {
 public:
  /// Runs a process's body; an exception ends the simulation and is kept (the first one).
  void guard(const std::function<void()>& body);
  /// After sc_start(): rethrows the kept exception, if any.
  void rethrow() const;

 private:
  std::exception_ptr first_;
};

/// A machine the pipeline runs on (architecture.machine): its architecture and the network's
/// mapping. Every operation sits on a tile: a linear layer on the tiles of its IMAs (its inputs
/// are sent to all of them, its outputs leave from the first), a digital operation on the tile
/// its first input comes from (the network's input enters at router 0).
struct MachinePlan {
  Architecture arch;
  Mapping mapping;
};


/// Copies of every linear layer's tile: per-layer list, one value for all, or `auto`
/// (the slowest stage is replicated while the crossbar budget allows, as ISAAC does).
std::vector<int> resolve_replication(const Model& m, const CrossbarBackend& programmed, const PlatformConfig& cfg);

class Pipeline : public sc_core::sc_module {
 public:
  /// `image(k, x)` writes the k-th preprocessed image (C x H x W floats) into x;
  /// `replication[l]` tiles for linear layer l; `sparse` (one per linear layer, or empty: every
  /// layer dense) makes every layer a sparse (Toeplitz) layer: one iteration per image through
  /// its tile's units, at those latencies, once its whole input is present (its values are
  /// computed by the dense datapath).
  /// `machine`: the machine and mapping to run on (null: layer-sized, one shared bus); its
  /// mapping's replication is used instead of `replication`.
  Pipeline(sc_core::sc_module_name name, const Model& model, const CrossbarBackend& programmed,
           const PlatformConfig& cfg, std::vector<int> replication, std::function<void(int, float*)> image,
           std::function<void(int)> progress = nullptr, std::vector<SparseIterationNs> sparse = {},
           const MachinePlan* machine = nullptr);
  ~Pipeline() override;

  /// Result after sc_start() returned; rethrows the exception a process ended the run with.
  const PipelineResult& result();
  /// The datapath of linear layer l (its modules' action counters).
  const Tile& tile(int l) const;
  /// Traces busy/stall of every stage, every buffer's occupancy (bytes) and the bytes the bus
  /// has carried (its slope is the utilisation) for the first `images` images into
  /// `vcd_path` (before sc_start).
  void trace(const std::string& vcd_path, int images);
  /// Closes the trace and puts it in place of `vcd_path` (after a successful run; without it the
  /// trace is discarded and an existing file of that name left as it was).
  void finish_trace();

 private:
  struct Stage;
  class Values;
  void source_process();
  void sink_process();
  void source();
  void sink();
  void stage_process(Stage& s);
  /// Linear stage s's tile transaction for iterations [first, first + count) of `image`: back
  /// once the tile's shift register has read them (its units time the rest).
  void transact(Stage& s, int image, int first, int count, sc_core::sc_time& delay);
  /// The task that computes stage s's output values for `image` once its inputs' are done.
  void submit_values(Stage& s, int image);
  /// Stores the logits of the images that have left and whose values are done, in order, and
  /// frees their activations.
  void reap();
  /// Before image `image` enters: waits (wall clock) while the values lag window_ images behind.
  void throttle(int image);
  /// Time of `bytes` over the off-chip port (a machine's off-chip links).
  double offchip_ns(long long bytes) const;
  /// Operations a digital unit performs for one output row.
  long long row_ops(const Stage& s) const;
  /// Rows [row, row + count) of `value` into every consumer's buffer over the interconnect,
  /// sent by stage `s` (from tile `source` on a machine), or by the memory port (s null,
  /// source -1: its waits for buffer space are the memory stall).
  void send_rows(Stage* s, int source, int image, int row, int count, int value, long long row_bytes);
  /// Computes output rows [r0, r1) of a digital stage (its time is its units' operations);
  /// returns the busy time.
  double busy_time(Stage& s, int r0, int r1);
  /// `ns` of a stage's busy time: added to its quantum keeper's local time and waited when
  /// platform.quantum_ns is used up (at or below the clock period: every delay).
  void advance(Stage& s, double ns);
  /// Before a stage blocks (an input row missing, its output register full): its local time
  /// is waited first, so that what it waits for is measured from its own time.
  void before_blocking(Stage& s);
  void traced(Stage& s, int image, bool busy, bool stall);

  const Model& model_;
  const CrossbarBackend& programmed_;
  PlatformConfig cfg_;
  std::vector<SparseIterationNs> sparse_;
  std::function<void(int, float*)> image_;
  std::function<void(int)> progress_;
  tlm_utils::simple_initiator_socket<Pipeline> mem2bus{"mem2bus"};  ///< the memory port's transfers
  const MachinePlan* machine_ = nullptr;
  std::unique_ptr<Bus> bus_;      ///< layer-sized
  std::unique_ptr<MeshNoc> noc_;  ///< on a machine
  std::map<const RowBuffer*, std::vector<int>> tiles_of_;
  std::vector<std::unique_ptr<ProtocolChecker>>
      checkers_;  ///< platform.check_protocol  ///< on a machine: the tiles a buffer lives on
  long long local_bytes_ = 0;
  std::vector<std::unique_ptr<Stage>> stages_;
  std::vector<std::vector<RowBuffer*>> consumers_of_;  ///< value id -> buffers fed by it
  std::vector<std::unique_ptr<RowBuffer>> buffers_;
  std::unique_ptr<Values> values_;
  std::vector<std::vector<std::unique_ptr<LayerJob>>> scratch_;  ///< per worker, per linear layer
  int window_ = 0, reaped_ = 0;
  /// The value tasks' workers (null when timing only); after the values and scratch jobs, so
  /// that it is stopped (its running tasks joined) before what they use is destroyed.
  std::unique_ptr<TaskGraph> tasks_;
  RowBuffer* output_ = nullptr;  ///< the logits on their way to memory
  sc_core::sc_event image_left_;
  int images_left_ = 0;
  PipelineResult result_;
  ProcessFailure failure_;
  std::unique_ptr<StagedOutput> vcd_file_;  ///< the trace's temporary file until finish_trace()
  sc_core::sc_trace_file* vcd_ = nullptr;
  int vcd_images_ = 0;
  bool tracing_ = false;  ///< true until the first vcd_images_ images have left
  std::vector<std::unique_ptr<sc_core::sc_signal<int, sc_core::SC_UNCHECKED_WRITERS>>> occupancy_sigs_;
  sc_core::sc_signal<int, sc_core::SC_UNCHECKED_WRITERS> bus_bytes_sig_{"bus_bytes"};
};

}  // namespace xbarsim
