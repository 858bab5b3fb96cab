#include "platform/Accelerator.h"

#include <algorithm>

namespace xbarsim {

/// The network's linear layers as tile transactions (shift registers build the input
/// vectors from the activation, so the im2col scratch is not used).
class Accelerator::PlatformBackend : public LinearBackend {
 public:
  explicit PlatformBackend(Accelerator& a, std::vector<double>& layer_ns) : a_(a), layer_ns_(layer_ns) {}
  void multiply(int, const RowMatrixXf&, Eigen::MatrixXf&) const override {
    throw std::logic_error("the platform consumes activations, not im2col matrices");
  }
  void multiply_activation(int layer, const LinearLayer& L, const float* chw, RowMatrixXf&,
                           Eigen::MatrixXf& out) const override {
    LayerJob job;
    job.layer = &L;
    job.analog = &a_.programmed_.layer(layer);
    job.activation = chw;
    job.detailed = a_.cfg_.detailed;
    job.replication = a_.cfg_.replication;
    tlm::tlm_generic_payload p;
    attach(p, job, Interconnect::tile_address(layer));
    const sc_core::sc_time before = a_.qk_.get_current_time();
    if (a_.tracing_) {
      a_.qk_.sync();
      a_.layer_sig_.write(layer);
      a_.busy_sig_.write(true);
    }
    a_.transport(p);
    if (a_.tracing_) {
      a_.qk_.sync();
      a_.busy_sig_.write(false);
    }
    layer_ns_[layer] = (a_.qk_.get_current_time() - before).to_seconds() * 1e9;
    out = std::move(job.y);
  }

 private:
  Accelerator& a_;
  std::vector<double>& layer_ns_;
};

Accelerator::Accelerator(sc_core::sc_module_name name, const Model& model, const CrossbarBackend& programmed,
                         const PlatformConfig& cfg, std::function<void(int, float*)> image, const std::string& vcd_path,
                         std::function<void(int)> progress)
    : sc_module(name),
      model_(model),
      programmed_(programmed),
      cfg_(cfg),
      image_(std::move(image)),
      progress_(std::move(progress)),
      io_("io", 4 * static_cast<size_t>(std::max(model.input.size(), 4096)), cfg.clock_ns(), cfg.io_words_per_cycle) {
  ctrl2noc.bind(noc_.ctrl2noc);
  noc_.noc2io.bind(io_.noc2io);
  for (size_t l = 0; l < model.linear.size(); ++l) {
    tiles_.push_back(std::make_unique<Tile>(("tile_" + std::to_string(l)).c_str(), cfg));
    noc_.noc2tile.bind(tiles_.back()->noc2tile);
  }
  if (!vcd_path.empty()) {
    std::string base = vcd_path;
    if (base.size() > 4 && base.substr(base.size() - 4) == ".vcd") base.resize(base.size() - 4);
    vcd_ = sc_core::sc_create_vcd_trace_file(base.c_str());
    sc_core::sc_trace(vcd_, layer_sig_, "layer");
    sc_core::sc_trace(vcd_, busy_sig_, "tile_busy");
  }
  SC_HAS_PROCESS(Accelerator);
  SC_THREAD(controller);
}

Accelerator::~Accelerator() {
  if (vcd_) sc_core::sc_close_vcd_trace_file(vcd_);
}

void Accelerator::transport(tlm::tlm_generic_payload& p) {
  sc_core::sc_time delay = qk_.get_local_time();
  ctrl2noc->b_transport(p, delay);
  if (p.get_response_status() != tlm::TLM_OK_RESPONSE)
    throw std::runtime_error("platform transaction failed: " + p.get_response_string());
  qk_.set(delay);
  if (qk_.need_sync()) qk_.sync();
}

void Accelerator::controller() {
  tlm_utils::tlm_quantumkeeper::set_global_quantum(sc_core::sc_time(cfg_.quantum_ns, sc_core::SC_NS));
  qk_.reset();
  std::vector<float> x(model_.input.size());
  for (int k = 0; k < cfg_.images; ++k) {
    tracing_ = vcd_ && k == 0;
    image_(k, x.data());
    const sc_core::sc_time start = qk_.get_current_time();
    tlm::tlm_generic_payload p;
    p.set_command(tlm::TLM_WRITE_COMMAND);
    p.set_address(0);
    p.set_data_ptr(reinterpret_cast<unsigned char*>(x.data()));
    p.set_data_length(static_cast<unsigned>(x.size() * sizeof(float)));
    p.set_streaming_width(p.get_data_length());
    transport(p);
    std::vector<double> layer_ns(model_.linear.size(), 0.0);
    PlatformBackend backend(*this, layer_ns);
    Eigen::VectorXf logits = run_image(model_, x.data(), backend);
    // Results leave through the output buffer.
    std::vector<float> out(logits.data(), logits.data() + logits.size());
    p.set_command(tlm::TLM_WRITE_COMMAND);
    p.set_data_ptr(reinterpret_cast<unsigned char*>(out.data()));
    p.set_data_length(static_cast<unsigned>(out.size() * sizeof(float)));
    p.set_streaming_width(p.get_data_length());
    transport(p);
    p.set_command(tlm::TLM_READ_COMMAND);
    transport(p);
    result_.logits.push_back(Eigen::Map<Eigen::VectorXf>(out.data(), static_cast<Eigen::Index>(out.size())));
    result_.image_latency_ns.push_back((qk_.get_current_time() - start).to_seconds() * 1e9);
    result_.layer_latency_ns.push_back(layer_ns);
    if (progress_) progress_(k + 1);
  }
  tracing_ = false;
  qk_.sync();
}

}  // namespace xbarsim
