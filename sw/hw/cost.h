#pragma once
/// Cost of an inventory from the component library (Accelergy style), by the one pricing
/// function, price() (sw/hw/components.h): the library's components by name, the inventory's
/// unit counts as their instances (area, leakage), action counts as their ledger (energy, plus
/// leakage x time); peak power with every unit busy at its highest action rate. The crossbar
/// read energy is the library's energy per cell read (cell's read) for every used cell of
/// every iteration, not V*I*t of the solved currents.
#include <nlohmann/json.hpp>

#include <map>
#include <string>

#include "sw/hw/component_library.h"
#include "sw/hw/components.h"
#include "sw/hw/inventory.h"

namespace xbarsim {

/// One figure per component class (mm2, mW, pJ, ... as the name of the variable says).
struct ComponentBreakdown {
  double crossbar = 0, adc = 0, dac = 0, accumulator = 0, shift_register = 0, buffer = 0;
  double sample_hold = 0, shift_add = 0, output_register = 0;
  double interconnect = 0, digital = 0, memory = 0;  ///< platform-level components
  /// Parts of cores priced by named components (sw/hw/components.h: a neuron core's neuron,
  /// wordline, input_pulses, rram, drivers, other), by part name.
  std::map<std::string, double> parts;
  double total() const {
    double t = crossbar + adc + dac + accumulator + shift_register + buffer + sample_hold + shift_add + output_register +
               interconnect + digital + memory;
    for (const auto& [name, v] : parts) t += v;
    return t;
  }
  /// The paper's scope (Table "Overhead comparison"): arrays, converters, accumulators.
  double arrays_and_converters() const { return crossbar + adc + dac + accumulator; }
  ComponentBreakdown& operator+=(const ComponentBreakdown& o);
  ComponentBreakdown operator*(double k) const;
  ComponentBreakdown operator+(const ComponentBreakdown& o) const {
    ComponentBreakdown r = *this;
    return r += o;
  }
  nlohmann::json to_json() const;
  /// The inverse of to_json (its "total" is derived, every key not a field is a part).
  static ComponentBreakdown from_json(const nlohmann::json& j);
};

/// Actions of the units of one layer (or a network), counted by a command or a simulation.
struct ActionCounts {
  double dac_conversions = 0, adc_conversions = 0, cell_reads = 0, accumulates = 0, shifts = 0;
  double samples = 0;     ///< sample-and-hold captures (one per converted column read)
  double shift_adds = 0;  ///< converted values shifted and added (sliced reads), each written to the output register
  double buffer_read_bytes = 0, buffer_write_bytes = 0;
  double bus_bytes = 0, digital_ops = 0, memory_bytes = 0;  ///< platform-level actions
  /// Per-column weight scales (ranging.weight_scale: column): one digital multiply per
  /// accumulated crossbar output, priced as a digital unit's operation.
  double scale_multiplies = 0;
  ActionCounts& operator+=(const ActionCounts& o);
  ActionCounts& operator/=(double n);  ///< every count (a run's counts per image)
};

/// What prices an inventory: the library, the converters' resolutions (0 = ideal, priced at
/// the library's reference bits) and the clock (MHz) that sets the peak action rates.
struct CostModel {
  ComponentLibrary lib;
  int dac_bits = 8, adc_bits = 8;
  double clock_mhz = 100;
  /// Every DAC has an input pre-distortion lookup table (converters.dac_predistortion with a
  /// nonlinear memristor): the library's dac_lut figures are added to each DAC's.
  bool dac_lut = false;
  int dac_bits_priced() const { return dac_bits > 0 ? dac_bits : lib.reference_bits("dac"); }
  int adc_bits_priced() const { return adc_bits > 0 ? adc_bits : lib.reference_bits("adc"); }

  /// Shift-and-add units of a layer with sliced reads: ceil(ADCs / shift_add's adcs_per_unit).
  long long shift_add_units(const LayerInventory& v) const;
  /// The inventory's units as instances of the library's components, each named as its part
  /// of ComponentBreakdown (the cells as crossbar, a DAC's table under dac), the converters at
  /// these resolutions; every count is `v`'s (null: 0, the performers of actions only).
  /// (Crossbar cores' parts: a machine of neuron cores prices its own, sw/hw/core_kind.h.)
  std::vector<Instance> instances(const LayerInventory* v) const;
  ComponentBreakdown area_mm2(const LayerInventory& v) const;
  ComponentBreakdown leakage_mw(const LayerInventory& v) const;
  /// Every unit at its highest action rate: the ADCs at the library's sample rate.
  ComponentBreakdown peak_power_mw(const LayerInventory& v) const;
  /// The same with the ADCs converting `conversions_per_ns` in all (what the reads need, when
  /// that is less than they could: the idle ones only leak); each conversion is shifted, added
  /// and written to the output register when reads are sliced.
  ComponentBreakdown peak_power_mw(const LayerInventory& v, double conversions_per_ns) const;
  /// Area and leakage of the platform-level units: one interconnect, `digital_units` units.
  Bill platform_bill(int digital_units) const;
  ComponentBreakdown platform_area_mm2(int digital_units) const;
  ComponentBreakdown platform_leakage_mw(int digital_units) const;
  /// Dynamic energy of the actions (pJ), without leakage.
  ComponentBreakdown dynamic_energy_pj(const ActionCounts& a) const;
  /// Dynamic energy plus the inventory's leakage over `time_ns` (pJ).
  ComponentBreakdown energy_pj(const ActionCounts& a, const LayerInventory& v, double time_ns) const {
    return dynamic_energy_pj(a) + leakage_mw(v) * time_ns;  // mW x ns = pJ
  }
};

/// Actions of one image through a layer, counted from its inventory: every read (input slices
/// x iterations) converts on every DAC (each fed by an input register entry), reads every used
/// cell, samples and converts every physical column (and shifts and adds each when reads are
/// sliced); every iteration accumulates every crossbar's outputs; a dense layer shifts
/// `shifted_entries` inputs in from its buffer.
ActionCounts layer_actions_per_image(const LayerInventory& v, long long shifted_entries);

/// Bytes of one row (C x W values) of an activation at `activation_bytes` per value.
long long activation_row_bytes(const Shape& s, int activation_bytes);
/// Operations a digital unit performs for one output row of `op` (0 for linear layers and for
/// padding, slicing and flattening, which only move data).
long long digital_row_ops(const Op& op, const Shape& out, const Shape& in0);

/// What the platform around the layers does for one image, in closed form, as the layer-sized
/// pipeline does it: every value crosses the shared bus once per consumer (the input from
/// memory, the logits to memory), the memory port reads the input and writes the logits, and
/// a digital unit per operation that computes performs its operations.
struct PlatformActions {
  ActionCounts actions;   ///< bus_bytes, memory_bytes, digital_ops
  int digital_units = 0;  ///< operations with a digital unit (those that compute)
};
PlatformActions platform_actions(const Model& m, int activation_bytes);

}  // namespace xbarsim
