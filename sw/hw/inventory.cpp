#include "sw/hw/inventory.h"

#include <algorithm>

#include "sw/analog/input_slicing.h"
#include "sw/common/errors.h"

namespace xbarsim {

namespace {
long long ceil_div(long long a, long long b) { return (a + b - 1) / b; }
/// a * b, or InputError when the count does not fit in 64 bits.
long long mul(long long a, long long b) {
  long long r = 0;
  if (__builtin_mul_overflow(a, b, &r)) throw InputError("the mapping is too large to count (over 9.2e18)");
  return r;
}
/// The output register of sliced reads: 2 bytes per weight column of every crossbar.
long long output_register_bytes(const LayerInventory& v) {
  return v.sliced() ? mul(mul(v.row_blocks, v.cols), 2) : 0;
}
long long add(long long a, long long b) {
  long long r = 0;
  if (__builtin_add_overflow(a, b, &r)) throw InputError("the mapping is too large to count (a total exceeds 9.2e18)");
  return r;
}
}  // namespace

LayerInventory& LayerInventory::operator+=(const LayerInventory& o) {
  for (auto f : {&LayerInventory::rows, &LayerInventory::cols, &LayerInventory::row_blocks, &LayerInventory::col_blocks,
                 &LayerInventory::physical_cols, &LayerInventory::crossbars, &LayerInventory::dacs,
                 &LayerInventory::adcs, &LayerInventory::accumulators, &LayerInventory::cells_present,
                 &LayerInventory::cells_used, &LayerInventory::iterations, &LayerInventory::shift_register_entries,
                 &LayerInventory::buffer_bytes, &LayerInventory::sample_holds, &LayerInventory::output_register_bytes})
    this->*f = add(this->*f, o.*f);
  column_scales = column_scales || o.column_scales;
  return *this;
}

int resolve_columns_per_adc(int configured, int library_columns_per_unit) {
  return configured > 0 ? configured : library_columns_per_unit;
}

LayerInventory matrix_inventory(long long rows, long long cols, long long iterations, const MappingSpec& mapping,
                                int columns_per_adc) {
  if (rows < 1 || cols < 1)
    throw InputError("cannot map a " + std::to_string(rows) + " x " + std::to_string(cols) + " matrix onto crossbars");
  if (columns_per_adc < 1) throw InputError("columns per ADC must be >= 1");
  LayerInventory v;
  v.rows = rows;
  v.cols = cols;
  v.iterations = iterations;
  v.columns_per_adc = columns_per_adc;
  const long long logical_max = mapping.logical_columns_per_crossbar();
  v.row_blocks = mapping.max_rows ? ceil_div(rows, mapping.max_rows) : 1;
  v.col_blocks = logical_max ? ceil_div(cols, logical_max) : 1;
  v.crossbars = mul(v.row_blocks, v.col_blocks);
  // Balanced column blocks: (cols % pc) blocks of cb + 1 weight columns, the rest cb.
  const long long pc = v.col_blocks, big = cols % pc, small = pc - big, cb = cols / pc;
  // Every crossbar's mapped columns and its spare columns (device.spare_columns).
  const long long spares = mapping.spare_columns;
  const long long phys_big = mapping.physical_columns(static_cast<int>(std::min(cb + 1, cols))) + spares;
  const long long phys_small = cb > 0 ? mapping.physical_columns(static_cast<int>(cb)) + spares : 0;
  v.physical_cols = add(mul(big, phys_big), mul(small, phys_small));
  const long long adcs_per_row_block = add(mul(big, adcs_for_columns(phys_big, columns_per_adc)),
                                           mul(small, cb > 0 ? adcs_for_columns(phys_small, columns_per_adc) : 0));
  v.adcs = mul(v.row_blocks, adcs_per_row_block);
  v.dacs = mul(rows, pc);
  v.accumulators = v.crossbars;
  v.array_rows = mapping.max_rows ? mapping.max_rows : rows;
  v.array_cols = mapping.max_cols ? mapping.max_cols + spares : v.physical_cols;
  v.cells_present = mul(mul(v.crossbars, v.array_rows), v.array_cols);
  v.cells_used = mul(rows, v.physical_cols);
  v.sample_holds = mul(v.row_blocks, v.physical_cols);
  v.weight_slices = mapping.weight_slices();
  v.output_register_bytes = output_register_bytes(v);
  return v;
}

long long dense_shifted_entries(const LinearLayer& L) {
  const long long K = L.rows(), step = L.stride_w < L.k_w ? static_cast<long long>(L.stride_w) * L.k_h * L.c_in : K;
  return static_cast<long long>(L.out.h) * (K + (L.out.w - 1) * step);
}

LayerInventory layer_inventory(const LinearLayer& L, MappingScheme scheme, const MappingSpec& mapping,
                               int columns_per_adc) {
  LayerInventory v;
  if (scheme == MappingScheme::Dense) {
    // A grouped convolution: each group on crossbars of its own (its K / group rows by its
    // c_out / group columns, as AnalogLayer programs it); the groups' counts add up, and a
    // column's crossbars are still one group's row blocks.
    const long long g = L.group;
    v = matrix_inventory(L.rows() / g, L.c_out / g, L.iterations(), mapping, columns_per_adc);
    if (g > 1)
      for (auto f : {&LayerInventory::rows, &LayerInventory::cols, &LayerInventory::col_blocks,
                     &LayerInventory::physical_cols, &LayerInventory::crossbars, &LayerInventory::dacs,
                     &LayerInventory::adcs, &LayerInventory::accumulators, &LayerInventory::cells_present,
                     &LayerInventory::cells_used, &LayerInventory::sample_holds, &LayerInventory::output_register_bytes})
        v.*f = mul(v.*f, g);
    v.shift_register_entries = L.rows();
  } else {
    // Toeplitz of the valid convolution on the layer's input: every output (pixel, channel)
    // is one column holding the K weights of its window. An input smaller than the kernel
    // has no valid output: its Toeplitz is then the convolution's on the zero-padded input.
    long long ih = L.in.h, iw = L.in.w;
    if (L.is_conv && (ih < L.k_h || iw < L.k_w)) {
      ih += L.pad_t + L.pad_b;
      iw += L.pad_l + L.pad_r;
      if (ih < L.k_h || iw < L.k_w)
        throw InputError("layer '" + L.name + "': its " + std::to_string(L.in.h) + "x" + std::to_string(L.in.w) +
                         " input, even padded, is smaller than its " + std::to_string(L.k_h) + "x" +
                         std::to_string(L.k_w) + " kernel: the sparse (Toeplitz) mapping has no outputs");
    }
    const long long oh = L.is_conv ? (ih - L.k_h) / L.stride_h + 1 : 1;
    const long long ow = L.is_conv ? (iw - L.k_w) / L.stride_w + 1 : 1;
    v = matrix_inventory(mul(mul(ih, iw), L.c_in), mul(mul(oh, ow), L.c_out), 1, mapping, columns_per_adc);
    // Only the K weights of each column's window are programmed (the rest are zeros).
    v.cells_used = add(mul(mul(v.cols, L.rows() / L.group), mapping.columns_per_weight()),
                       mapping.analog_sum() ? mul(v.rows, v.col_blocks) : 0);
  }
  static_cast<LayerShape&>(v) = LayerShape::of(L);
  v.scheme = scheme;
  v.buffer_bytes = L.in.size();
  return v;
}

LayerInventory& stream_inputs(LayerInventory& v, const ConvertersSpec& converters, bool signed_inputs) {
  const int bits = converters.activation_bits();
  v.input_slices = make_input_slicing(bits, converters.dac_bits, signed_inputs, 1.0).slices;
  v.input_bytes = std::max(1, (bits + 7) / 8);
  v.output_register_bytes = output_register_bytes(v);
  return v;
}

}  // namespace xbarsim
