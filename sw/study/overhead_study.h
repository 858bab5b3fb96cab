#pragma once
/// Dense vs sparse (Toeplitz) mapping of every Conv/Gemm layer: counts from the inventory,
/// area and peak power (every unit busy, the paper's Table "Overhead comparison") from the
/// component library.
#include <optional>
#include <string>
#include <vector>

#include "sw/study/hardware.h"

namespace xbarsim {

struct MappingOverhead {
  LayerInventory inv;
  ComponentBreakdown area_mm2, peak_power_mw;
  nlohmann::json to_json() const;
};

struct LayerOverhead : LayerShape {
  MappingOverhead dense, sparse;
};

struct OverheadReport {
  std::vector<LayerOverhead> layers;
  MappingOverhead dense_total, sparse_total;
  std::optional<MachineReport> machine;  ///< architecture.machine is a machine: it priced, the network on it
  nlohmann::json to_json() const;
};

OverheadReport overhead_study(const Model& m, const HardwareContext& hw);

}  // namespace xbarsim
