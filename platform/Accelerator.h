#pragma once
/// The accelerator: a controller (TLM initiator with a quantum keeper), an interconnect,
/// an input/output buffer and one tile per linear layer of the network (its crossbars
/// programmed once). The controller runs the network image by image: digital layers
/// (ReLU, pooling, Add, padding) in the controller, Conv/Gemm as tile transactions.
#include <functional>
#include <memory>
#include <string>
#include <systemc>
#include <tlm>
#include <tlm_utils/simple_initiator_socket.h>
#include <tlm_utils/tlm_quantumkeeper.h>
#include <vector>

#include "platform/Interconnect.h"
#include "platform/IoBuffer.h"
#include "sw/hw/platform_spec.h"
#include "platform/Tile.h"
#include "sw/inference/crossbar_backend.h"

namespace xbarsim {

/// What a simulation measured.
struct SimulationResult {
  std::vector<Eigen::VectorXf> logits;                ///< per image
  std::vector<double> image_latency_ns;               ///< per image, input transfer to logits
  std::vector<std::vector<double>> layer_latency_ns;  ///< per image, per linear layer
};

class Accelerator : public sc_core::sc_module {
 public:
  /// `image(k, x)` writes the k-th preprocessed image (C x H x W floats) into x.
  /// `vcd_path` non-empty: trace the controller's layer/busy signals of the first image.
  Accelerator(sc_core::sc_module_name name, const Model& model, const CrossbarBackend& programmed,
              const PlatformConfig& cfg, std::function<void(int, float*)> image, const std::string& vcd_path = "",
              std::function<void(int)> progress = nullptr);
  ~Accelerator() override;

  const SimulationResult& result() const { return result_; }
  const Tile& tile(int l) const { return *tiles_.at(l); }
  int tiles() const { return static_cast<int>(tiles_.size()); }
  const IoBuffer& io() const { return io_; }

 private:
  class PlatformBackend;
  void controller();
  void transport(tlm::tlm_generic_payload& p);

  const Model& model_;
  const CrossbarBackend& programmed_;
  PlatformConfig cfg_;
  std::function<void(int, float*)> image_;
  std::function<void(int)> progress_;
  tlm_utils::simple_initiator_socket<Accelerator> ctrl2noc{"ctrl2noc"};
  Interconnect noc_{"noc"};
  IoBuffer io_;
  std::vector<std::unique_ptr<Tile>> tiles_;
  tlm_utils::tlm_quantumkeeper qk_;
  SimulationResult result_;
  sc_core::sc_signal<int> layer_sig_{"layer"};
  sc_core::sc_signal<bool> busy_sig_{"busy"};
  sc_core::sc_trace_file* vcd_ = nullptr;
  bool tracing_ = false;
};

}  // namespace xbarsim
