// configs/components/isaac.yaml against ISAAC's published IMA (Shafiee et al., ISCA 2016,
// Table 6): the counting rule's units of one IMA (8 crossbars of 128 x 128 2-bit cells read
// by 1-bit DACs, 8 ADCs of 128 columns) priced by the library's per-unit figures must give the
// table's per-component and total power and area. The published figures are typed here, not
// read from the library.
#include <gtest/gtest.h>

#include "sw/common/config.h"
#include "sw/hw/cost.h"
#include "sw/hw/inventory.h"

using namespace xbarsim;

namespace {
struct Published {
  double power_mw, area_mm2;
};
// ISAAC Table 6, one IMA.
constexpr Published kAdc{16, 0.0096}, kDac{4, 0.00017}, kSampleHold{0.01, 0.00004}, kArrays{2.4, 0.0002},
    kShiftAdd{0.2, 0.00024}, kInputRegister{1.24, 0.0021}, kOutputRegister{0.23, 0.00077};
constexpr Published kIma{24.08, 0.0131};

/// One IMA as the inventory counts it: a layer of 1024 rows (8 row blocks of 128) and 16
/// weight columns of 16-bit weights on 2-bit cells (8 cells each: 128 physical columns),
/// 16-bit inputs streamed through 1-bit DACs.
LayerInventory ima() {
  MappingSpec m;
  m.max_rows = 128;
  m.max_cols = 128;
  m.cell_bits = 2;
  m.weight_bits = 16;
  LayerInventory v = matrix_inventory(1024, 16, 1, m, 128);
  ConvertersSpec c;
  c.input_bits = 16;
  c.dac_bits = 1;
  c.adc_bits = 8;
  stream_inputs(v, c, false);
  v.shift_register_entries = v.rows;  // the IMA's input register: one entry per row
  return v;
}

CostModel isaac_cost() {
  ConfigTree cfg;
  cfg.set("components.library", "isaac");
  CostModel cm;
  cm.lib = load_component_library(cfg);
  cm.dac_bits = 1;
  cm.adc_bits = 8;
  cm.clock_mhz = 10;  // one crossbar read per 100 ns cycle
  return cm;
}
}  // namespace

TEST(IsaacLibrary, InventoryOfOneImaCountsIsaacsUnits) {
  const LayerInventory v = ima();
  EXPECT_EQ(v.crossbars, 8);
  EXPECT_EQ(v.adcs, 8);
  EXPECT_EQ(v.dacs, 8 * 128);
  EXPECT_EQ(v.sample_holds, 8 * 128);
  EXPECT_EQ(v.cells_present, 8 * 128 * 128);
  EXPECT_EQ(v.input_slices, 16);
  EXPECT_EQ(v.input_bytes, 2);
  EXPECT_EQ(v.output_register_bytes, 256);
  EXPECT_EQ(isaac_cost().shift_add_units(v), 4);
}

TEST(IsaacLibrary, OneImaMatchesThePublishedFigures) {
  const LayerInventory v = ima();
  const CostModel cm = isaac_cost();
  const ComponentBreakdown p = cm.peak_power_mw(v), a = cm.area_mm2(v);
  const std::pair<const char*, std::tuple<double, double, Published>> parts[] = {
      {"ADC", {p.adc, a.adc, kAdc}},
      {"DAC", {p.dac, a.dac, kDac}},
      {"S+H", {p.sample_hold, a.sample_hold, kSampleHold}},
      {"arrays", {p.crossbar, a.crossbar, kArrays}},
      {"shift-and-add", {p.shift_add + p.accumulator, a.shift_add + a.accumulator, kShiftAdd}},
      {"input register", {p.shift_register, a.shift_register, kInputRegister}},
      {"output register", {p.output_register, a.output_register, kOutputRegister}},
  };
  for (const auto& [name, t] : parts) {
    const auto& [power, area, pub] = t;
    EXPECT_NEAR(power, pub.power_mw, 0.01 * pub.power_mw) << name;
    EXPECT_NEAR(area, pub.area_mm2, 0.01 * pub.area_mm2) << name;
  }
  EXPECT_NEAR(p.total(), kIma.power_mw, 0.01 * kIma.power_mw);
  EXPECT_NEAR(a.total(), kIma.area_mm2, 0.01 * kIma.area_mm2);
  EXPECT_EQ(p.buffer + p.interconnect + p.digital + p.memory, 0.0);
  ::testing::Test::RecordProperty("ima_power_mw", std::to_string(p.total()));
  ::testing::Test::RecordProperty("ima_area_mm2", std::to_string(a.total()));
}

// Actions of one image follow the hand formula: reads = iterations x input slices; per read
// every DAC, used cell and physical column acts once; each conversion is shifted and added.
TEST(IsaacLibrary, BitSerialActionCounts) {
  MappingSpec m;
  m.max_rows = 128;
  m.max_cols = 128;
  m.cell_bits = 2;
  m.weight_bits = 8;
  LayerInventory v = matrix_inventory(288, 32, 256, m, 128);  // ResNet-20 layer2 conv: 3 x 1 crossbars
  ConvertersSpec c;
  c.input_bits = 8;
  c.dac_bits = 1;
  stream_inputs(v, c, false);
  ASSERT_EQ(v.row_blocks, 3);
  ASSERT_EQ(v.physical_cols, 128);  // 32 weights x 4 cells
  const ActionCounts a = layer_actions_per_image(v, 0);
  const double reads = 256.0 * 8;
  EXPECT_EQ(a.dac_conversions, reads * 288);
  EXPECT_EQ(a.cell_reads, reads * 288 * 128);
  EXPECT_EQ(a.adc_conversions, reads * 3 * 128);
  EXPECT_EQ(a.samples, reads * 3 * 128);
  EXPECT_EQ(a.shift_adds, reads * 3 * 128);
  EXPECT_EQ(a.accumulates, 256.0 * 3 * 32);
}
