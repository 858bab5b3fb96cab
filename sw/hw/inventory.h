#pragma once
/// The hardware inventory of a mapped network: per layer the logical matrix, its partition
/// into crossbars and the physical columns (differential pairs, sum(X) column), and the
/// units that serve it (DACs, ADCs, accumulators, shift register, buffer). This is the only
/// counting rule: overhead, eval, xbar-study, simulate and the SystemC Adc module use it.
#include <string>
#include <vector>

#include "sw/analog/analog_spec.h"
#include "sw/nn/model.h"

namespace xbarsim {

/// Counting rules: crossbars = ceil(rows / R) x ceil(cols / C') with balanced blocks, where
/// C' is the weight columns one array of max_cols physical columns holds (a weight's slices
/// and polarities stay on one array); one DAC per used row of every crossbar;
/// ceil(physical columns / columns_per_adc) ADCs per crossbar; one sample-and-hold per physical
/// column; one accumulator per crossbar; cells present = R x C physical arrays (rows x
/// physical columns when unbounded); one shift register (input register) of `rows` entries of
/// input_bytes per dense layer; with sliced reads (input slices or weight slices > 1) an
/// output register of 2 bytes per weight column of every crossbar.
/// A linear layer as every report names it: its name, kernel and input and output shapes.
struct LayerShape {
  std::string name;
  int k_h = 1, k_w = 1, c_in = 0, c_out = 0;
  Shape input, output;
  static LayerShape of(const LinearLayer& L) { return {L.name, L.k_h, L.k_w, L.c_in, L.c_out, L.in, L.out}; }
  /// "KhxKwxCinxCout", as the commands' tables print a kernel.
  std::string kernel_text() const {
    return std::to_string(k_h) + "x" + std::to_string(k_w) + "x" + std::to_string(c_in) + "x" + std::to_string(c_out);
  }
};

struct LayerInventory : LayerShape {
  MappingScheme scheme = MappingScheme::Dense;
  long long rows = 0, cols = 0;  ///< logical matrix (inputs x weight columns)
  long long row_blocks = 0, col_blocks = 0;
  long long physical_cols = 0;               ///< physical columns of one row of crossbars (all column blocks)
  long long array_rows = 0, array_cols = 0;  ///< one physical array
  long long crossbars = 0, dacs = 0, adcs = 0, accumulators = 0;
  long long cells_present = 0, cells_used = 0;
  long long iterations = 0;              ///< input vectors per image (dense: output pixels)
  int input_slices = 1;                  ///< crossbar reads per iteration (bit-serial inputs)
  /// Reads the network's input at converters.image_bits (set only with image_bits): on neuron
  /// cores a read then takes PlatformConfig::image_read_cycles cycles and image_read_steps.
  bool reads_image = false;
  int weight_slices = 1;                 ///< cells of one polarity of a weight (adjacent columns)
  int input_bytes = 1;                   ///< bytes of one input register entry (activation bits / 8)
  long long sample_holds = 0;            ///< one per physical column of every crossbar
  long long output_register_bytes = 0;   ///< sliced reads: 2 bytes per weight column of every crossbar
  long long shift_register_entries = 0;  ///< dense: the unrolled window; sparse: none
  long long buffer_bytes = 0;            ///< the layer's input activations (one byte per value)
  int columns_per_adc = 128;
  /// ranging.weight_scale: column: every crossbar output is multiplied by its column's digital
  /// gain before it is accumulated.
  bool column_scales = false;
  /// Reads are combined by shift-and-add (input or weight slices).
  bool sliced() const { return input_slices > 1 || weight_slices > 1; }
  long long reads() const { return iterations * input_slices; }  ///< crossbar reads per image
  double utilization() const { return cells_present ? static_cast<double>(cells_used) / cells_present : 0.0; }
  /// Sums the counts of `o` (names and shapes are kept).
  LayerInventory& operator+=(const LayerInventory& o);
};

/// ADC sharing: converters.adc_columns_per_adc, or the component library's columns_per_unit.
int resolve_columns_per_adc(int configured, int library_columns_per_unit);

/// Inventory of a rows x cols weight matrix read `iterations` times per image.
LayerInventory matrix_inventory(long long rows, long long cols, long long iterations, const MappingSpec& mapping,
                                int columns_per_adc);

/// ADCs serving one crossbar of `physical_cols` columns.
inline long long adcs_for_columns(long long physical_cols, int columns_per_adc) {
  return (physical_cols + columns_per_adc - 1) / columns_per_adc;
}

/// Inventory of a Conv/Gemm layer under `scheme` (dense: the unrolled kernels, one iteration
/// per output pixel; sparse: the valid-convolution Toeplitz matrix, one iteration per image).
LayerInventory layer_inventory(const LinearLayer& L, MappingScheme scheme, const MappingSpec& mapping,
                               int columns_per_adc);

/// Sets the input streaming of `v`: reads per iteration (InputSlicing of the converters for
/// signed or unsigned inputs), the input register's entry bytes, and the output register.
LayerInventory& stream_inputs(LayerInventory& v, const ConvertersSpec& converters, bool signed_inputs);

/// Entries shifted into a dense layer's input register per image: a whole window (K entries)
/// at the start of each output row, then stride x k_h x c_in per step (K when the stride is
/// not smaller than the kernel), as ShiftRegisterBuffer does.
long long dense_shifted_entries(const LinearLayer& L);

}  // namespace xbarsim
