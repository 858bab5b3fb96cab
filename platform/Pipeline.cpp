#include "platform/Pipeline.h"

#include "platform/Transfer.h"

#include <tlm_utils/tlm_quantumkeeper.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <map>

#include "sw/hw/inventory.h"
#include "sw/nn/ops.h"
#include "modules/sim_time.h"
#include "sw/common/output_file.h"

namespace xbarsim {

double PipelineResult::throughput_per_s() const {
  const size_t n = image_out_ns.size();
  if (n == 0) return 0;
  if (n == 1) return 1e9 / std::max(latency_ns(), 1e-9);
  // Steady state: the spacing of the outputs between the first and the last quarter of the
  // run, where as many images are in flight at both ends (the first outputs also reflect the
  // pipeline filling, the last ones its draining).
  const size_t a = n >= 8 ? n / 4 : 0, b = n >= 8 ? n - 1 - n / 4 : n - 1;
  return 1e9 * static_cast<double>(b - a) / std::max(image_out_ns[b] - image_out_ns[a], 1e-9);
}

/// The activations of the images in flight: one vector per value of the network, allocated
/// (at its size) when the image enters, so that the worker tasks write into storage no other
/// thread resizes, with the task that produces each value. Timing only: one vector per value
/// shared by every image (the transfers' data pointers; nothing is computed into it).
class Pipeline::Values {
 public:
  struct Image {
    std::vector<std::vector<float>> v;
    std::vector<TaskGraph::Id> producer;  ///< per value: the task that computes it (-1: none)
  };
  Values(const Model& m, bool shared) : model_(m), shared_(shared) {
    if (shared_) shared_image_ = make();
  }
  /// Image `image` enters the machine.
  Image& add(int image) {
    if (shared_) return *shared_image_;
    std::unique_ptr<Image> im;
    if (free_.empty()) {
      im = make();
    } else {  // a left image's storage: every value is written whole by its producer
      im = std::move(free_.back());
      free_.pop_back();
      im->producer.assign(model_.values.size(), -1);
    }
    return *images_.emplace(image, std::move(im)).first->second;
  }
  Image& at(int image) {
    if (shared_) return *shared_image_;
    return *images_.at(image);
  }
  void drop(int image) {
    auto it = images_.find(image);
    if (it == images_.end()) return;
    free_.push_back(std::move(it->second));
    images_.erase(it);
  }

 private:
  std::unique_ptr<Image> make() const {
    auto im = std::make_unique<Image>();
    for (const Shape& sh : model_.values) im->v.emplace_back(sh.size(), 0.0f);
    im->producer.assign(model_.values.size(), -1);
    return im;
  }
  const Model& model_;
  bool shared_;
  std::unique_ptr<Image> shared_image_;
  std::map<int, std::unique_ptr<Image>> images_;
  std::vector<std::unique_ptr<Image>> free_;
};

/// An (image, row) token on a stage's output register.
struct RowId {
  int image = 0, row = 0, count = 1;  ///< rows [row, row + count) of the image
};
inline std::ostream& operator<<(std::ostream& os, const RowId& r) {
  return os << r.image << ":" << r.row << "+" << r.count;
}

void ProcessFailure::guard(const std::function<void()>& body) {
  try {
    body();
  } catch (const sc_core::sc_unwind_exception&) {
    throw;  // SystemC's own (a process being killed or reset): it must pass
  } catch (...) {
    if (first_) return;
    first_ = std::current_exception();
    // Stopping is how the run ends here, not news for the user ("Simulation stopped by user.").
    sc_core::sc_report_handler::set_actions("/OSCI/SystemC", sc_core::SC_INFO, sc_core::SC_DO_NOTHING);
    sc_core::sc_stop();
  }
}

void ProcessFailure::rethrow() const {
  if (first_) std::rethrow_exception(first_);
}

struct Pipeline::Stage : public sc_core::sc_module {
  tlm_utils::simple_initiator_socket<Stage> stage2bus{"stage2bus"};
  std::unique_ptr<tlm_utils::simple_initiator_socket<Stage>> stage2tile;  ///< linear layers only
  Pipeline* owner = nullptr;
  const Op* op = nullptr;
  std::vector<RowBuffer*> in;
  std::vector<Shape> in_shape;
  Shape out_shape;
  long long out_row_bytes = 0;
  std::unique_ptr<Tile> tile;  ///< linear layers: the datapath that computes and times each iteration
  /// The tile's work item, kept across images so that its buffers (codes, currents) are
  /// allocated once: every image's transaction starts from reset() counters.
  LayerJob job;
  tlm_utils::tlm_quantumkeeper qk;  ///< platform.quantum_ns: the stage's time ahead of the kernel
  const SparseIterationNs* sparse = nullptr;  ///< a sparse (Toeplitz) layer's single iteration
  /// A linear layer: its time is its tile's (the stage feeds it row groups and the tile's
  /// accumulator hands the finished ones to the output register).
  bool tiled() const { return tile != nullptr; }
  StageStats stats;
  /// Where its process is (for a run that stops in a deadlock): the image, and what it waits for.
  int at_image = 0;
  std::string waiting = "not started";
  sc_core::sc_signal<bool> busy_sig{"busy"}, stall_sig{"stall"};
  sc_core::sc_signal<int> image_sig{"image", -1};  ///< the image it computes, -1 when not busy
  /// Output register: the stage hands a finished row to its sender process (which waits for
  /// buffer space and the bus) and goes on with the next row; it stalls when the register is
  /// still occupied.
  sc_core::sc_fifo<RowId> out_rows{1};

  Stage(sc_core::sc_module_name name, Pipeline* p) : sc_module(name), owner(p) {
    SC_HAS_PROCESS(Stage);
    SC_THREAD(run);
    SC_THREAD(send);
  }
  void run() {
    owner->failure_.guard([&] { owner->stage_process(*this); });
  }
  void send() {
    owner->failure_.guard([&] {
      for (;;) {
        const RowId row = out_rows.read();
        owner->send_rows(this, stats.tile, row.image, row.row, row.count, op->out, out_row_bytes);
      }
    });
  }
  /// Input rows [first, last] the output row `r` needs from input `i` (last < 0: none).
  std::pair<int, int> window(int i, int r) const;
};

std::pair<int, int> Pipeline::Stage::window(int i, int r) const {
  const int h = in_shape[i].h;
  auto clamp = [&](int first, int last) { return std::make_pair(std::clamp(first, 0, h), std::min(last, h - 1)); };
  switch (op_info(op->kind).rows) {
    case RowRule::Layer: {
      const LinearLayer& L = owner->model_.linear[op->linear];
      if (sparse) return {0, h - 1};  // a Toeplitz layer reads the whole input at once
      if (!L.is_conv || h == 1) return {0, 0};
      return clamp(r * L.stride_h - L.pad_t, r * L.stride_h - L.pad_t + L.k_h - 1);
    }
    case RowRule::Window:
      return clamp(r * op->s_h - op->p_t, r * op->s_h - op->p_t + op->k_h - 1);
    case RowRule::Whole:
      return {0, h - 1};
    case RowRule::Pad: {
      const int y = r - op->pad_lo[1];
      if (y < 0) return {0, -1};
      if (y >= h) return {h, -1};
      return {y, y};
    }
    case RowRule::Slice: {
      const int y = op->start[1] + r * op->step[1];
      return {y, y};
    }
    case RowRule::Elementwise:
      return h == 1 ? std::make_pair(0, 0) : std::make_pair(r, r);  // one row: broadcast to every row
    case RowRule::RowWise:
    case RowRule::Channels:
      return {r, r};
  }
  return {r, r};
}

namespace {

/// Rows of its input a stage's buffer holds when sized automatically: the window plus one
/// stride for convolutions and pooling, two rows for row-wise units, the whole map where the
/// consumer needs it (global pooling, flatten, vectors) or waits for another branch (Add).
int auto_buffer_rows(const Model& m, const Op& op, const Shape& in, bool sequential, int grain) {
  if (sequential) return in.h;  // a stage starts an image only when its whole input is present
  // A group of `grain` output rows reads (grain - 1) strides plus the kernel; the producer
  // delivers `grain` rows at a time.
  switch (op_info(op.kind).rows) {
    case RowRule::Layer: {
      const LinearLayer& L = m.linear[op.linear];
      return L.is_conv ? std::min(in.h, L.k_h + L.stride_h * grain + grain) : in.h;
    }
    case RowRule::Window:
      return std::min(in.h, op.k_h + op.s_h * grain + grain);
    case RowRule::Elementwise:
    case RowRule::Channels:
    case RowRule::Whole:
      return in.h;
    case RowRule::RowWise:
    case RowRule::Slice:
    case RowRule::Pad:
      return std::min(in.h, 2 * grain);
  }
  return in.h;
}

/// A write of rows [row, row + count) of an activation of `rows` rows (platform/Transfer.h):
/// its values as data, at their byte offset in the activation, and `wire` bytes on the wire.
void fill_payload(tlm::tlm_generic_payload& p, float* v, size_t size, int rows, int row, int count, long long wire) {
  const size_t per_row = size / static_cast<size_t>(rows), at = static_cast<size_t>(row) * per_row;
  p.set_command(tlm::TLM_WRITE_COMMAND);
  p.set_address(static_cast<sc_dt::uint64>(at * sizeof(float)));
  p.set_data_ptr(reinterpret_cast<unsigned char*>(v + at));
  p.set_data_length(static_cast<unsigned>(static_cast<size_t>(count) * per_row * sizeof(float)));
  p.set_streaming_width(p.get_data_length());
  p.set_byte_enable_ptr(nullptr);
  p.set_dmi_allowed(false);
  p.set_response_status(tlm::TLM_INCOMPLETE_RESPONSE);
  p.set_extension(new WireBytes(wire));  // owned by the payload
}

}  // namespace

Pipeline::Pipeline(sc_core::sc_module_name name, const Model& model, const CrossbarBackend& programmed,
                   const PlatformConfig& cfg, std::vector<int> replication, std::function<void(int, float*)> image,
                   std::function<void(int)> progress, std::vector<SparseIterationNs> sparse, const MachinePlan* machine)
    : sc_module(name),
      model_(model),
      programmed_(programmed),
      cfg_(machine ? machine_platform(cfg, machine->arch) : cfg),
      sparse_(std::move(sparse)),
      image_(std::move(image)),
      progress_(std::move(progress)),
      machine_(machine),
      consumers_of_(model.values.size()),
      values_(std::make_unique<Values>(model, cfg.timing_only)) {
  if (!cfg_.timing_only) {
    // The values are computed by worker tasks in the order the processes reach them, at most
    // `window_` images ahead of the last whose values are done (their activations are kept).
    const int workers = std::max(1, cfg_.threads);
    scratch_.resize(static_cast<size_t>(workers));
    for (auto& per_worker : scratch_)
      for (size_t l = 0; l < model.linear.size(); ++l) per_worker.push_back(std::make_unique<LayerJob>());
    window_ = std::max(4, 4 * workers);
    tasks_ = std::make_unique<TaskGraph>(workers);
  }
  tlm_utils::tlm_quantumkeeper::set_global_quantum(sc_core::sc_time(cfg_.quantum_ns, sc_core::SC_NS));
  if (machine_) {
    const Architecture& a = machine_->arch;
    // Cores without a mesh (no chip.router): one node holds every tile, and every transfer is
    // relayed through the chip's off-chip port at its links' rate (send_rows).
    const double rate = a.chip.transfer_bytes_per_ns();
    if (!(rate > 0))
      throw InputError("architecture.machine " + a.name + ": a network needs a way between its cores: chip.router, or "
                       "chip.offchip for cores without a mesh");
    noc_ = std::make_unique<MeshNoc>("noc", a.chip.mesh_rows, a.chip.mesh_cols, a.chip.tiles_per_router, rate,
                                     a.chip.hop_ns);
  } else {
    bus_ = std::make_unique<Bus>("bus", cfg_.clock_ns(), cfg_.link_bytes_per_cycle, cfg_.hop_cycles, cfg_.bus_lanes);
  }
  // An initiator bound to a target, through a base-protocol checker when asked.
  auto bind = [&](auto& initiator, auto& target, const std::string& what) {
    if (!cfg_.check_protocol) {
      initiator.bind(target);
      return;
    }
    checkers_.push_back(std::make_unique<ProtocolChecker>(("check_" + what).c_str()));
    initiator.bind(checkers_.back()->in);
    checkers_.back()->out.bind(target);
  };
  auto bind_interconnect = [&](auto& initiator, const std::string& what) {
    if (machine_)
      bind(initiator, noc_->tile2noc, what);
    else
      bind(initiator, bus_->stage2bus, what);
  };
  // On a machine: the tiles every operation sits on (its input buffers'; its outputs leave from the first).
  const std::vector<std::vector<int>> placed =
      machine_ ? place_operations(model, machine_->mapping) : std::vector<std::vector<int>>();
  for (size_t k = 0; k < model.ops.size(); ++k) {
    const Op& op = model.ops[k];
    auto s = std::make_unique<Stage>(("stage_" + std::to_string(k)).c_str(), this);
    s->op = &op;
    s->out_shape = model.values[op.out];
    s->out_row_bytes = activation_row_bytes(s->out_shape, cfg_.activation_bytes);
    s->stats.name = op.name;
    s->stats.kind = op.kind;
    s->stats.linear = op.linear;
    std::vector<int> tiles;  // on a machine: the tiles the stage's input buffers live on
    if (machine_) {
      tiles = placed[k];
      const char* kind = digital_op_name(op.kind);
      if (*kind && machine_->arch.ops_per_ns(kind) <= 0)
        throw InputError("architecture.machine " + machine_->arch.name + " has no tile unit for '" + kind +
                         "' (operation '" + op.name + "'): list it in a unit's ops (tile.units.<unit>.ops)");
      s->stats.tile = tiles.front();
    }
    const bool sparse_layer = op.kind == OpKind::Linear && op.linear < static_cast<int>(sparse_.size());
    for (int v : op.in) {
      const Shape in = model.values[v];
      const long long rb = activation_row_bytes(in, cfg_.activation_bytes);
      const long long cap = cfg_.buffer_bytes > 0
                                ? cfg_.buffer_bytes
                                : rb * auto_buffer_rows(model, op, in, !cfg_.pipelined || sparse_layer, cfg_.grain_rows);
      if (cap < rb * std::min(cfg_.grain_rows, in.h))
        throw InputError("platform.buffer_bytes = " + std::to_string(cap) + " cannot hold one transaction (" +
                         std::to_string(std::min(cfg_.grain_rows, in.h)) + " rows of " + std::to_string(rb) +
                         " bytes) of the input of '" + op.name + "'");
      buffers_.push_back(std::make_unique<RowBuffer>(op.name + ".in", cap, rb, in.h));
      tiles_of_[buffers_.back().get()] = tiles;
      s->in.push_back(buffers_.back().get());
      s->in_shape.push_back(in);
      consumers_of_[v].push_back(buffers_.back().get());
      s->stats.buffer_bytes += cap;
    }
    if (op.kind == OpKind::Linear) {
      if (sparse_layer) s->sparse = &sparse_[static_cast<size_t>(op.linear)];
      const int r = sparse_layer ? 1 : replication.at(op.linear);
      s->stats.replication = r;
      s->tile = std::make_unique<Tile>(("tile_" + std::to_string(op.linear)).c_str(), cfg_, r);
      s->stage2tile = std::make_unique<tlm_utils::simple_initiator_socket<Stage>>(
          ("stage2tile_" + std::to_string(op.linear)).c_str());
      bind(*s->stage2tile, s->tile->noc2tile, "tile_" + std::to_string(op.linear));
      // The tile's accumulator hands its finished row groups to the stage's output register.
      Stage* st = s.get();
      s->tile->set_output(
          [st](const TileToken& t) { return st->out_rows.nb_write(RowId{t.image, t.row, t.rows}); },
          &s->out_rows.data_read_event());
    }
    bind_interconnect(s->stage2bus, "stage_" + std::to_string(k));
    stages_.push_back(std::move(s));
  }
  const Shape out = model.values[model.output];
  const long long ob = activation_row_bytes(out, cfg_.activation_bytes);
  buffers_.push_back(std::make_unique<RowBuffer>("memory.out", ob * out.h, ob, out.h));
  tiles_of_[buffers_.back().get()] = {-1};  // off-chip: out through router 0
  output_ = buffers_.back().get();
  consumers_of_[model.output].push_back(output_);
  bind_interconnect(mem2bus, "memory");
  SC_HAS_PROCESS(Pipeline);
  SC_THREAD(source_process);
  SC_THREAD(sink_process);
}

Pipeline::~Pipeline() {
  if (vcd_) sc_core::sc_close_vcd_trace_file(vcd_);  // (then vcd_file_ removes the unfinished trace)
}

void Pipeline::finish_trace() {
  if (!vcd_) return;
  sc_core::sc_close_vcd_trace_file(vcd_);
  vcd_ = nullptr;
  vcd_file_->commit();
}

const Tile& Pipeline::tile(int l) const {
  for (const auto& s : stages_)
    if (s->op->linear == l) return *s->tile;
  throw std::out_of_range("no tile for linear layer " + std::to_string(l));
}

void Pipeline::trace(const std::string& vcd_path, int images) {
  // SystemC opens the file only when the simulation starts, and a trace file that failed to
  // open divides by zero when it is closed: the file must be creatable before it is made.
  // SystemC writes the trace as the simulation runs: into a temporary file beside the target,
  // which finish_trace() renames onto it, so a run that fails or is killed leaves the target as
  // it was (and removes the temporary file).
  check_output_path(vcd_path, "the trace file");
  vcd_file_ = std::make_unique<StagedOutput>(vcd_path, ".vcd");
  vcd_ = sc_core::sc_create_vcd_trace_file(vcd_file_->base().c_str());
  vcd_images_ = images;
  tracing_ = true;
  // Scopes follow the machine, in network order: chip.tile_T.NN_name (a machine) or
  // accelerator.NN_name, with the operation's ONNX name made a VCD identifier (its dots and
  // slashes would open scopes), each input buffer its own scope (an Add's two inputs).
  auto identifier = [](const std::string& name) {
    std::string id;
    for (char c : name) {
      const char d = std::isalnum(static_cast<unsigned char>(c)) ? c : '_';
      if (d != '_' || (!id.empty() && id.back() != '_')) id += d;
    }
    while (!id.empty() && id.back() == '_') id.pop_back();
    return id.empty() ? std::string("op") : id;
  };
  auto padded = [](long long v, long long count) {  // so that names sort in network order
    const size_t width = std::to_string(std::max(count - 1, 0LL)).size();
    const std::string s = std::to_string(v);
    return s.size() < width ? std::string(width - s.size(), '0') + s : s;
  };
  const std::string top = machine_ ? "chip" : "accelerator";
  auto trace_buffer = [&](RowBuffer* b, const std::string& name) {
    occupancy_sigs_.push_back(std::make_unique<sc_core::sc_signal<int, sc_core::SC_UNCHECKED_WRITERS>>());
    b->trace_to(occupancy_sigs_.back().get(), &tracing_);
    sc_core::sc_trace(vcd_, *occupancy_sigs_.back(), name);
  };
  for (size_t k = 0; k < stages_.size(); ++k) {
    Stage& s = *stages_[k];
    std::string scope = top + ".";
    if (machine_) scope += "tile_" + padded(s.stats.tile, machine_->arch.chip.tiles) + ".";
    scope += padded(static_cast<long long>(k), static_cast<long long>(stages_.size())) + "_" + identifier(s.stats.name);
    sc_core::sc_trace(vcd_, s.busy_sig, scope + ".busy");
    sc_core::sc_trace(vcd_, s.stall_sig, scope + ".stall");
    sc_core::sc_trace(vcd_, s.image_sig, scope + ".image");
    for (size_t i = 0; i < s.in.size(); ++i) trace_buffer(s.in[i], scope + ".in" + std::to_string(i) + ".bytes");
    if (s.tiled()) s.tile->trace(vcd_, scope + ".tile", &tracing_, &vcd_images_);
  }
  trace_buffer(output_, top + ".memory_out.bytes");
  sc_core::sc_trace(vcd_, bus_bytes_sig_, top + (machine_ ? ".noc.bytes_carried" : ".bus.bytes_carried"));
  // Every link's bytes (its utilization) where the network's tiles can send.
  if (noc_) noc_->trace(vcd_, top + ".noc", &tracing_, machine_->mapping.tiles_used);
}

void Pipeline::traced(Stage& s, int image, bool busy, bool stall) {
  if (!tracing_ || image >= vcd_images_) return;
  s.busy_sig.write(busy);
  s.stall_sig.write(stall);
  s.image_sig.write(busy ? image : -1);
}

void Pipeline::send_rows(Stage* s, int source, int image, int row, int count, int value, long long row_bytes) {
  tlm_utils::simple_initiator_socket<Stage>* stage_socket = s ? &s->stage2bus : nullptr;
  auto transport = [&](tlm::tlm_generic_payload& p, sc_core::sc_time& delay) {
    if (stage_socket)
      (*stage_socket)->b_transport(p, delay);
    else
      mem2bus->b_transport(p, delay);
    if (p.get_response_status() != tlm::TLM_OK_RESPONSE) throw std::runtime_error("interconnect transfer failed");
  };
  const long long bytes = row_bytes * count;
  float* v = values_->at(image).v[value].data();
  const size_t size = model_.values[value].size();
  const std::vector<RowBuffer*>& consumers = consumers_of_[value];
  if (!machine_) {
    // One shared bus: a transfer per consumer.
    for (RowBuffer* b : consumers) {
      const sc_core::sc_time t0 = sc_core::sc_time_stamp();
      for (int q = 0; q < count; ++q) b->reserve();
      if (!s) result_.memory_stall_ns += (sc_core::sc_time_stamp() - t0).to_seconds() * 1e9;  // the input port waited
      tlm::tlm_generic_payload p;
      fill_payload(p, v, size, b->rows_per_image(), row, count, bytes);
      sc_core::sc_time delay = sc_core::SC_ZERO_TIME;
      transport(p, delay);
      sc_core::wait(delay);
      b->commit(image, row + count - 1);
      if (tracing_) bus_bytes_sig_.write(static_cast<int>(std::min<long long>(bus_->bytes(), 1LL << 30)));
    }
    return;
  }
  // A machine: space in every consumer's buffer, then one multicast over the mesh to the tiles
  // that are not the source's (a consumer on the source's tile reads the rows from its eDRAM).
  std::vector<int> remote;
  const sc_core::sc_time t0 = sc_core::sc_time_stamp();
  for (RowBuffer* b : consumers) {
    for (int q = 0; q < count; ++q) b->reserve();
    for (int t : tiles_of_.at(b))
      if (t != source && std::find(remote.begin(), remote.end(), t) == remote.end()) remote.push_back(t);
  }
  if (!s) result_.memory_stall_ns += (sc_core::sc_time_stamp() - t0).to_seconds() * 1e9;  // the input port waited
  const Architecture& arch = machine_->arch;
  auto send = [&](int from, const std::vector<int>& to) {
    tlm::tlm_generic_payload p;
    fill_payload(p, v, size, consumers.front()->rows_per_image(), row, count, bytes);
    auto* route = new Route;  // owned by the payload
    route->source = from;
    route->destinations = to;
    p.set_extension(route);
    sc_core::sc_time delay = sc_core::SC_ZERO_TIME;
    transport(p, delay);
    sc_core::wait(delay);
    if (tracing_) bus_bytes_sig_.write(static_cast<int>(std::min<long long>(noc_->bytes(), 1LL << 30)));
  };
  if (remote.empty()) {
    local_bytes_ += bytes;
    // A tile's own buffer; a core without one keeps the rows in its registers.
    if (arch.tile.edram_bytes_per_ns > 0)
      sc_core::wait(sim_delay(static_cast<double>(bytes) / arch.tile.edram_bytes_per_ns));
  } else if (!arch.chip.has_router() && source >= 0) {
    // Cores without a mesh: out through the chip's port to what routes them (NeuRRAM's test
    // FPGA), and back in to the consumers; the port's links are shared by every transfer.
    send(source, {-1});
    send(-1, remote);
  } else {
    send(source, remote);
  }
  for (RowBuffer* b : consumers) b->commit(image, row + count - 1);
}

void Pipeline::transact(Stage& s, int image, int first, int count, sc_core::sc_time& delay) {
  // The tile's transaction times the part and counts its actions, which do not depend on the
  // values (timing_only); the values are the task's.
  const Op& op = *s.op;
  const LinearLayer& L = model_.linear[op.linear];
  LayerJob& job = s.job;
  job.reset_counters();
  job.layer = &L;
  job.analog = &programmed_.layer(op.linear);
  job.activation = values_->at(image).v[op.in[0]].data();
  job.read_cycles = cfg_.read_cycles(reads_image(op));  // 1 without converters.image_bits
  job.detailed = cfg_.detailed;
  job.timing_only = true;
  job.replication = s.stats.replication;
  job.first_iteration = first;
  job.count = count;
  job.image = static_cast<uint64_t>(image);
  job.sparse = s.sparse != nullptr;
  if (s.sparse) {  // its single iteration on the group of its first row
    const SparseIterationNs& t = *s.sparse;
    const double on = first == 0 ? 1.0 : 0.0;
    job.stage_ns[kShift].assign(1, t.shift * on);
    job.stage_ns[kDac].assign(1, t.dac * on);
    job.stage_ns[kCrossbar].assign(1, t.crossbar * on);
    job.stage_ns[kAdc].assign(1, t.adc * on);
    job.stage_ns[kAccumulate].assign(1, t.accumulate * on);
  }
  tlm::tlm_generic_payload p;
  attach(p, job, 0);
  (*s.stage2tile)->b_transport(p, delay);
  if (p.get_response_status() != tlm::TLM_OK_RESPONSE) throw std::runtime_error("tile transaction failed");
}

void Pipeline::submit_values(Stage& s, int image) {
  const Op& op = *s.op;
  Values::Image& im = values_->at(image);
  std::vector<TaskGraph::Id> after;
  for (int v : op.in) after.push_back(im.producer[v]);
  std::vector<const std::vector<float>*> xs;
  for (int v : op.in) xs.push_back(&im.v[v]);
  std::vector<float>* y = &im.v[op.out];
  TaskGraph::Task task;
  if (op.kind == OpKind::Linear) {
    // The tile's datapath, by its modules' functions, on this worker's copy of the job.
    task = [this, &op, x0 = xs.front(), y, image](int worker) {
      const LinearLayer& L = model_.linear[op.linear];
      LayerJob& job = *scratch_[static_cast<size_t>(worker)][static_cast<size_t>(op.linear)];
      job.reset_counters();
      job.layer = &L;
      job.analog = &programmed_.layer(op.linear);
      job.activation = x0->data();
      job.image = static_cast<uint64_t>(image);
      job.detailed = true;
      Tile::compute_values(job);
      const int pixels = L.out.h * L.out.w;
      float* out = y->data();
      for (int c = 0; c < L.c_out; ++c)
        for (int q = 0; q < pixels; ++q) out[static_cast<size_t>(c) * pixels + q] = job.y(q, c) + L.bias(c);
    };
  } else {
    task = [this, &op, xs, y](int) { digital_op(op, model_.values, xs, *y); };
  }
  im.producer[op.out] = tasks_->submit(std::move(task), after);
}

void Pipeline::reap() {
  while (reaped_ < images_left_) {
    Values::Image& im = values_->at(reaped_);
    if (tasks_) {
      for (TaskGraph::Id id : im.producer)
        if (!tasks_->finished(id)) return;
      const std::vector<float>& y = im.v[model_.output];
      result_.logits.push_back(Eigen::Map<const Eigen::VectorXf>(y.data(), static_cast<Eigen::Index>(y.size())));
    }
    values_->drop(reaped_);
    ++reaped_;
    if (progress_) progress_(reaped_);
  }
}

void Pipeline::throttle(int image) {
  // The processes run ahead of the values by at most window_ images: the oldest image that has
  // left the machine is waited for (in wall-clock time; simulated time does not move).
  while (tasks_ && image - reaped_ >= window_ && reaped_ < images_left_) {
    for (TaskGraph::Id id : values_->at(reaped_).producer)
      if (id >= 0) tasks_->wait(id);
    reap();
  }
}

long long Pipeline::row_ops(const Stage& s) const { return digital_row_ops(*s.op, s.out_shape, s.in_shape[0]); }

void Pipeline::stage_process(Stage& s) {
  const int rows = s.out_shape.h;
  s.qk.reset();
  // Waits for row `row` of input i, having waited the stage's local time if it must block.
  auto need = [&](size_t i, int img, int row) {
    if (s.in[i]->has(img, row)) return;
    before_blocking(s);
    s.waiting = "waiting for row " + std::to_string(row) + " of " + s.in[i]->name();
    const sc_core::sc_time t0 = sc_core::sc_time_stamp();
    s.in[i]->wait_for(img, row);
    s.stats.starved_ns += (sc_core::sc_time_stamp() - t0).to_seconds() * 1e9;
  };
  for (int img = 0; img < cfg_.images; ++img) {
    s.at_image = img;
    if (!cfg_.pipelined)
      for (size_t i = 0; i < s.in.size(); ++i) need(i, img, s.in_shape[i].h - 1);
    // Transactions of grain_rows output rows: wait for the group's windows, compute, hand over.
    for (int r0 = 0; r0 < rows; r0 += cfg_.grain_rows) {
      const int r1 = std::min(rows, r0 + cfg_.grain_rows);
      for (size_t i = 0; i < s.in.size(); ++i) need(i, img, s.window(static_cast<int>(i), r1 - 1).second);
      if (r0 == 0 && tasks_) submit_values(s, img);
      traced(s, img, true, false);
      s.stats.rows += r1 - r0;
      if (s.tiled()) {
        // Into the tile: back once its shift register has read the group's inputs.
        before_blocking(s);
        s.waiting = "feeding its tile row " + std::to_string(r0);
        sc_core::sc_time delay = sc_core::SC_ZERO_TIME;
        transact(s, img, r0 * s.out_shape.w, (r1 - r0) * s.out_shape.w, delay);
      } else {
        s.stats.busy_ns += busy_time(s, r0, r1);
      }
      traced(s, img, false, false);
      for (size_t i = 0; i < s.in.size(); ++i)
        s.in[i]->release_before(img, r1 < rows ? s.window(static_cast<int>(i), r1).first : s.in_shape[i].h);
      if (s.tiled()) continue;  // the tile's accumulator hands the rows over
      if (s.out_rows.num_free() == 0) before_blocking(s);
      s.waiting = "waiting for its output register (its consumers' buffers full)";
      const sc_core::sc_time t0 = sc_core::sc_time_stamp();
      traced(s, img, false, true);
      s.out_rows.write(RowId{img, r0, r1 - r0});  // stalls while the previous group still waits for space or the bus
      s.stats.stall_ns += (sc_core::sc_time_stamp() - t0).to_seconds() * 1e9;
      traced(s, img, false, false);
    }
  }
  s.at_image = cfg_.images;
  s.waiting.clear();
}

double Pipeline::busy_time(Stage& s, int r0, int r1) {
  const long long ops = row_ops(s) * (r1 - r0);
  double t = 0;
  if (machine_) {  // the tile's units that perform this operation
    const char* kind = digital_op_name(s.op->kind);
    t = *kind ? static_cast<double>(ops) / machine_->arch.ops_per_ns(kind) : 0.0;
  } else {
    t = std::ceil(static_cast<double>(ops) / cfg_.digital_ops_per_cycle) * cfg_.clock_ns();
  }
  s.stats.digital_ops += ops;
  advance(s, t);
  return t;
}

void Pipeline::advance(Stage& s, double ns) {
  if (!(ns > 0)) return;
  s.qk.inc(sim_delay(ns, s.qk.get_local_time()));
  if (s.qk.need_sync()) s.qk.sync();
}

void Pipeline::before_blocking(Stage& s) {
  // (Nothing to wait: no delta cycle either, so the processes' order stays as without a quantum.)
  if (s.qk.get_local_time() > sc_core::SC_ZERO_TIME) s.qk.sync();
}

void Pipeline::source_process() {
  failure_.guard([&] { source(); });
}

void Pipeline::sink_process() {
  failure_.guard([&] { sink(); });
}

void Pipeline::source() {
  const Shape in = model_.input;
  const long long rb = activation_row_bytes(in, cfg_.activation_bytes);
  for (int img = 0; img < cfg_.images; ++img) {
    if (!cfg_.pipelined)
      while (images_left_ < img) sc_core::wait(image_left_);
    throttle(img);
    result_.image_in_ns.push_back(sc_core::sc_time_stamp().to_seconds() * 1e9);
    Values::Image& im = values_->add(img);
    if (tasks_) {
      float* x = im.v[0].data();
      im.producer[0] = tasks_->submit([this, img, x](int) { image_(img, x); });
    }
    for (int r = 0; r < in.h; ++r) {
      sc_core::wait(sim_delay((r == 0 ? cfg_.memory_latency_ns : 0.0) + offchip_ns(rb)));
      result_.memory_bytes += rb;
      send_rows(nullptr, -1, img, r, 1, 0, rb);  // over the bus, or into the chip at router 0
    }
  }
}

double Pipeline::offchip_ns(long long bytes) const {
  if (machine_) {
    return static_cast<double>(bytes) / machine_->arch.chip.offchip_bytes_per_ns();
  }
  return std::ceil(static_cast<double>(bytes) / cfg_.memory_bytes_per_cycle) * cfg_.clock_ns();
}

void Pipeline::sink() {
  const Shape out = model_.values[model_.output];
  const long long bytes = activation_row_bytes(out, cfg_.activation_bytes) * out.h;
  for (int img = 0; img < cfg_.images; ++img) {
    output_->wait_for(img, out.h - 1);
    sc_core::wait(sim_delay(cfg_.memory_latency_ns + offchip_ns(bytes)));
    output_->release_before(img, out.h);
    result_.memory_bytes += bytes;
    result_.image_out_ns.push_back(sc_core::sc_time_stamp().to_seconds() * 1e9);
    ++images_left_;
    if (images_left_ >= vcd_images_) tracing_ = false;
    image_left_.notify(sc_core::SC_ZERO_TIME);
    reap();
  }
}

const PipelineResult& Pipeline::result() {
  failure_.rethrow();
  if (tasks_) tasks_->wait_all();  // the values of the images that left; rethrows a task's failure
  reap();
  result_.completed = images_left_ == cfg_.images;
  result_.blocked.clear();
  if (!result_.completed) {  // the stages first, then the tile units that hold a row group
    for (const auto& s : stages_)
      if (!s->waiting.empty())
        result_.blocked.push_back(s->stats.name + " (image " + std::to_string(s->at_image) + "): " + s->waiting);
    for (const auto& s : stages_)
      if (s->tile)
        for (const TileUnit* u : s->tile->units())
          if (u->holding())
            result_.blocked.push_back(s->stats.name + "'s " + unit_name(u->stage()) +
                                      " holds a row group its next unit (or the output register) cannot take");
  }
  result_.stages.clear();
  for (const auto& s : stages_) {
    StageStats st = s->stats;
    if (s->tiled()) {  // its tile's busiest unit's time
      st.busy_ns = to_ns(sc_core::sc_time::from_value(s->tile->busy_ps()));
      st.stall_ns = to_ns(sc_core::sc_time::from_value(s->tile->stall_ps()));
      st.starved_ns = to_ns(sc_core::sc_time::from_value(s->tile->starved_ps()));
      st.bound_by = s->tile->bound_by();
      for (int u = 0; u < kStages; ++u)
        st.unit_busy_ns[u] = to_ns(sc_core::sc_time::from_value(s->tile->units()[u]->busy_ps()));
    }
    for (const RowBuffer* b : s->in) st.buffer_peak_bytes += b->peak_bytes();
    result_.stages.push_back(st);
  }
  result_.protocol_transactions = 0;
  result_.protocol_violations.clear();
  for (const auto& c : checkers_) {
    result_.protocol_transactions += c->transactions();
    result_.protocol_violations.insert(result_.protocol_violations.end(), c->violations().begin(),
                                       c->violations().end());
  }
  if (machine_) {
    result_.bus_bytes = noc_->bytes();
    result_.bus_transfers = noc_->transfers();
    result_.bus_busy_ns = noc_->link_busy_ns();
    result_.router_bytes = noc_->router_bytes();
    result_.noc_links = noc_->links();
    result_.noc_contention_ns = noc_->contention_ns();
    result_.local_bytes = local_bytes_;
  } else {
    result_.bus_bytes = bus_->bytes();
    result_.bus_transfers = bus_->transfers();
    result_.bus_busy_ns = bus_->busy_ns();
  }
  return result_;
}

std::vector<int> resolve_replication(const Model& m, const CrossbarBackend& programmed, const PlatformConfig& cfg) {
  const int L = static_cast<int>(m.linear.size());
  const bool per_layer = !cfg.replication_per_layer.empty();
  if (per_layer && static_cast<int>(cfg.replication_per_layer.size()) != L)
    throw InputError("platform.replication_per_layer lists " + std::to_string(cfg.replication_per_layer.size()) +
                     " values for " + std::to_string(L) + " linear layers");
  std::vector<int> r = per_layer ? cfg.replication_per_layer : std::vector<int>(L, cfg.replication);
  const bool automatic = cfg.auto_replication && !per_layer;
  long long base = 0, needed = 0;
  for (int l = 0; l < L; ++l) {
    base += programmed.layer(l).crossbars();
    needed += programmed.layer(l).crossbars() * (automatic ? 1 : r[l]);
  }
  // A budget the network does not fit is an error, not a setting to ignore.
  if (cfg.crossbar_budget > 0 && needed > cfg.crossbar_budget)
    throw InputError("platform.crossbar_budget = " + std::to_string(cfg.crossbar_budget) + " is below the " +
                     std::to_string(needed) + " crossbars the network needs" +
                     (needed == base ? " without replication" : " with its replication"));
  if (!automatic) return r;
  // Greedy, as ISAAC balances its pipeline: copy the slowest layer (iterations / copies)
  // while the crossbars fit the budget.
  const long long budget = cfg.crossbar_budget > 0 ? cfg.crossbar_budget : 2 * base;
  long long used = base;
  for (;;) {
    int slow = 0;
    for (int l = 1; l < L; ++l)
      if (static_cast<double>(m.linear[l].iterations()) / r[l] >
          static_cast<double>(m.linear[slow].iterations()) / r[slow])
        slow = l;
    const long long extra = programmed.layer(slow).crossbars();
    if (used + extra > budget || r[slow] >= m.linear[slow].out.w) break;
    ++r[slow];
    used += extra;
  }
  return r;
}

}  // namespace xbarsim
