#include "sw/study/overhead_study.h"

#include "sw/nn/network.h"

namespace xbarsim {

nlohmann::json MappingOverhead::to_json() const {
  // Power and area in the paper's scope: arrays, ADCs, DACs and accumulators.
  return {{"rows", inv.rows},
          {"cols", inv.cols},
          {"crossbars", inv.crossbars},
          {"adcs", inv.adcs},
          {"dacs", inv.dacs},
          {"cells_used", inv.cells_used},
          {"cells_present", inv.cells_present},
          {"utilization", inv.utilization()},
          {"xbar_power_mw", peak_power_mw.crossbar},
          {"xbar_area_mm2", area_mm2.crossbar},
          {"total_power_mw", peak_power_mw.arrays_and_converters()},
          {"total_area_mm2", area_mm2.arrays_and_converters()},
          {"power_breakdown_mw", peak_power_mw.to_json()},
          {"area_breakdown_mm2", area_mm2.to_json()},
          {"iterations", inv.iterations}};
}

nlohmann::json OverheadReport::to_json() const {
  nlohmann::json j;
  j["layers"] = nlohmann::json::array();
  for (const auto& l : layers)
    j["layers"].push_back({{"name", l.name},
                           {"kernel", {l.k_h, l.k_w, l.c_in, l.c_out}},
                           {"input", {l.input.h, l.input.w}},
                           {"dense", l.dense.to_json()},
                           {"sparse", l.sparse.to_json()}});
  j["totals"] = {{"dense", dense_total.to_json()}, {"sparse", sparse_total.to_json()}};
  if (machine) j["machine"] = machine->to_json();
  return j;
}

OverheadReport overhead_study(const Model& m, const HardwareContext& hw) {
  OverheadReport r;
  auto priced = [&](const LayerInventory& v) {
    return MappingOverhead{v, hw.arch.core().layer_area_mm2(hw, v), hw.arch.core().layer_peak_power_mw(hw, v)};
  };
  const std::vector<bool> signed_inputs = linear_inputs_signed(m), reads_image = linear_reads_image(m);
  for (size_t l = 0; l < m.linear.size(); ++l) {
    const LinearLayer& L = m.linear[l];
    LayerOverhead o;
    static_cast<LayerShape&>(o) = LayerShape::of(L);
    o.dense = priced(hw.inventory(L, MappingScheme::Dense, signed_inputs[l], reads_image[l]));
    o.sparse = priced(hw.inventory(L, MappingScheme::Sparse, signed_inputs[l], reads_image[l]));
    for (auto [total, part] : {std::pair{&r.dense_total, &o.dense}, std::pair{&r.sparse_total, &o.sparse}}) {
      total->inv += part->inv;
      total->area_mm2 += part->area_mm2;
      total->peak_power_mw += part->peak_power_mw;
    }
    r.layers.push_back(std::move(o));
  }
  if (hw.arch.machine) {
    r.machine = machine_report(m, hw, signed_inputs);
    require_fit(r.machine->mapping, hw.arch);  // as every command: the network must fit the machine
  }
  return r;
}

}  // namespace xbarsim
