// Bit-serial reads of an analog layer (input_slicing().serial()): the DAC codes, one crossbar
// read per digit, the ADC per read and the shift-and-add of the reads.
//
// Speed: every read is a matrix product of a digit vector with G_eff (linear devices), and
// 8 reads of 4-cell weights are 32 times the products and conversions of one analog read.
// Digits are mostly zero (bit planes of ReLU outputs), so a read adds the G_eff rows of its
// non-zero digits, in registers; the stages run on a few vectors at a time so that their
// reads stay in cache from the array to the shift-and-add; and every read's input sum is the
// count of its digits, not a sum of values.
#include <algorithm>
#include <cmath>
#include <limits>
#include <type_traits>
#include <vector>
#if defined(__AVX512F__)
#include <immintrin.h>
#endif

#include "sw/analog/analog_layer_impl.h"
#include "sw/common/cancel.h"

namespace xbarsim {

template <typename S>
void AnalogLayer::slice_inputs(const RowMat<S>& xq, Codes& codes) const {
  codes.resize(xq.rows(), xq.cols());
  const int32_t mask = static_cast<int32_t>(slicing_.pattern(-1));
  // DAC values are whole codes times the step, so multiplying by 1 / step rounds the same as
  // dividing.
  const double inv_step = 1.0 / slicing_.step;
  const S* in = xq.data();
  int32_t* out = codes.data();
  Eigen::Index i = 0;
#if defined(__AVX512F__)
  if constexpr (std::is_same_v<S, float>) {
    const __m512d inv = _mm512_set1_pd(inv_step), half = _mm512_set1_pd(0.5);
    const __m256i m = _mm256_set1_epi32(mask);
    for (; i + 8 <= xq.size(); i += 8) {
      const __m512d code = _mm512_roundscale_pd(_mm512_fmadd_pd(_mm512_cvtps_pd(_mm256_loadu_ps(in + i)), inv, half),
                                                _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC);
      _mm256_storeu_si256(reinterpret_cast<__m256i*>(out + i), _mm256_and_si256(_mm512_cvttpd_epi32(code), m));
    }
  }
#endif
  for (; i < xq.size(); ++i)
    out[i] = static_cast<int32_t>(std::floor(std::fma(static_cast<double>(in[i]), inv_step, 0.5))) & mask;
}

template <typename S>
void AnalogLayer::read_values(const Codes& codes, Eigen::Index first, Eigen::Index vectors, int row0, int rows,
                              RowMat<S>& out) const {
  const int slices = slicing_.slices;
  out.resize(vectors * slices, rows);
  for (Eigen::Index v = 0; v < vectors; ++v) {
    const int32_t* p = codes.row(first + v) + row0;
    for (int s = 0; s < slices; ++s) {
      const S unit = static_cast<S>(slicing_.digit_unit(s));
      S* o = out.row(v * slices + s).data();
      for (int k = 0; k < rows; ++k) o[k] = static_cast<S>(slicing_.digit(p[k], s)) * unit;
    }
  }
}

namespace {

/// Read s of one vector, on any scalar type: out (the G_eff row length) = unit * sum over
/// rows of digit * G_eff row; returns the sum of the digits.
template <typename S>
long read_generic(const AnalogLayer::RowMat<S>& g, const int32_t* code, const InputSlicing& sl, int s, S* out) {
  const Eigen::Index cols = g.cols();
  Eigen::Map<Eigen::Array<S, Eigen::Dynamic, 1>> acc(out, cols);
  acc.setZero();
  long total = 0;
  for (Eigen::Index k = 0; k < g.rows(); ++k) {
    const long d = sl.digit(code[k], s);
    if (!d) continue;
    total += d;
    acc += static_cast<S>(d) * g.row(k).transpose().array();
  }
  acc *= static_cast<S>(sl.digit_unit(s));
  return total;
}

#if defined(__AVX512F__)
/// One range of the ADC (Crossbar::AdcTable<float>): per physical column; `on` is null when
/// every column quantizes.
struct AdcLanes {
  const float* __restrict offset;
  const float* __restrict lo;
  const float* __restrict hi;
  const float* __restrict step;
  const float* __restrict inv_step;
  const float* __restrict on;
};

/// The ADC of 16 columns' currents i (from column c, lanes `live`) of a read whose input sum
/// is sx: FastQuantizer::apply on i - offset sx (the code by multiplying with 1 / step), plus
/// offset sx again.
inline __m512 convert16(__m512 i, __m512 sx, const AdcLanes& a, Eigen::Index c, __mmask16 live) {
  const __m512 k = _mm512_maskz_loadu_ps(live, a.offset + c);
  const __m512 v = _mm512_fnmadd_ps(k, sx, i);
  const __m512 l = _mm512_maskz_loadu_ps(live, a.lo + c);
  const __m512 clipped = _mm512_min_ps(_mm512_max_ps(v, l), _mm512_maskz_loadu_ps(live, a.hi + c));
  const __m512 code = _mm512_roundscale_ps(
      _mm512_fmadd_ps(_mm512_sub_ps(clipped, l), _mm512_maskz_loadu_ps(live, a.inv_step + c), _mm512_set1_ps(0.5f)),
      _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC);
  const __m512 q = _mm512_fmadd_ps(code, _mm512_maskz_loadu_ps(live, a.step + c), l);
  if (!a.on) return _mm512_fmadd_ps(k, sx, q);
  const __mmask16 quantizes =
      _mm512_cmp_ps_mask(_mm512_maskz_loadu_ps(live, a.on + c), _mm512_setzero_ps(), _CMP_GT_OQ);
  return _mm512_fmadd_ps(k, sx, _mm512_mask_blend_ps(quantizes, v, q));
}

/// Columns [c0, c0 + 16 NR) of one read (the last register's live lanes `last`): the G_eff
/// rows of its `count` non-zero digits (`row`: their offsets in g) summed in registers (a binary digit adds its row,
/// a wider one its row times the digit), times `unit`, stored to out.
template <int NR, bool Binary>
inline void accumulate_chunk(const float* g, Eigen::Index ld, int c0, __mmask16 last, const int* row,
                             const float* digit, int count, float unit, float* out) {
  __m512 acc[NR];
  for (int k = 0; k < NR; ++k) acc[k] = _mm512_setzero_ps();
  for (int q = 0; q < count; ++q) {
    const float* gr = g + row[q] + c0;
    if constexpr (Binary) {
      for (int k = 0; k < NR - 1; ++k) acc[k] = _mm512_add_ps(acc[k], _mm512_loadu_ps(gr + 16 * k));
      acc[NR - 1] = _mm512_add_ps(acc[NR - 1], _mm512_maskz_loadu_ps(last, gr + 16 * (NR - 1)));
    } else {
      const __m512 d = _mm512_set1_ps(digit[q]);
      for (int k = 0; k < NR - 1; ++k) acc[k] = _mm512_fmadd_ps(d, _mm512_loadu_ps(gr + 16 * k), acc[k]);
      acc[NR - 1] = _mm512_fmadd_ps(d, _mm512_maskz_loadu_ps(last, gr + 16 * (NR - 1)), acc[NR - 1]);
    }
  }
  const __m512 u = _mm512_set1_ps(unit);
  for (int k = 0; k < NR - 1; ++k) _mm512_storeu_ps(out + 16 * k, _mm512_mul_ps(acc[k], u));
  _mm512_mask_storeu_ps(out + 16 * (NR - 1), last, _mm512_mul_ps(acc[NR - 1], u));
}

template <bool Binary>
void accumulate_columns(const float* g, Eigen::Index cols, const int* row, const float* digit, int count, float unit,
                        float* out) {
  for (Eigen::Index c0 = 0; c0 < cols; c0 += 128) {
    const int w = static_cast<int>(std::min<Eigen::Index>(128, cols - c0)), nr = (w + 15) / 16;
    const __mmask16 last = w % 16 ? static_cast<__mmask16>((1u << (w % 16)) - 1) : static_cast<__mmask16>(0xFFFF);
    const int c = static_cast<int>(c0);
#define XBARSIM_CHUNK(NR) accumulate_chunk<NR, Binary>(g, cols, c, last, row, digit, count, unit, out + c0)
    switch (nr) {
      case 1:
        XBARSIM_CHUNK(1);
        break;
      case 2:
        XBARSIM_CHUNK(2);
        break;
      case 3:
        XBARSIM_CHUNK(3);
        break;
      case 4:
        XBARSIM_CHUNK(4);
        break;
      case 5:
        XBARSIM_CHUNK(5);
        break;
      case 6:
        XBARSIM_CHUNK(6);
        break;
      case 7:
        XBARSIM_CHUNK(7);
        break;
      case 8:
        XBARSIM_CHUNK(8);
        break;
    }
#undef XBARSIM_CHUNK
  }
}

constexpr int kMaxSlices = 32;  // input_bits <= 24: at most 25 reads

/// Every read of one vector for float (read_generic for each slice, up to the order of
/// rounding): one pass over the codes lists every slice's non-zero digits, 16 codes per
/// instruction; then each read sums its rows in registers. out: the reads' rows (slices x
/// cols), sum_x: each read's digit sum times its unit.
void read_vector_avx512(const AnalogLayer::RowMat<float>& g, const int32_t* code, const InputSlicing& sl, float* out,
                        float* sum_x) {
  const int rows = static_cast<int>(g.rows()), slices = sl.slices;
  const Eigen::Index cols = g.cols();
  const size_t stride = static_cast<size_t>(rows) + 16;  // a compressed store writes 16 lanes
  thread_local std::vector<int> row;
  thread_local std::vector<float> digit;
  row.resize(stride * slices);
  digit.resize(stride * slices);
  __m512i test[kMaxSlices];
  int count[kMaxSlices], shift[kMaxSlices];
  int32_t mask[kMaxSlices];
  float unit[kMaxSlices];
  long total[kMaxSlices];
  for (int s = 0; s < slices; ++s) {
    unit[s] = static_cast<float>(sl.digit_unit(s));
    shift[s] = sl.digit_shift(s);
    mask[s] = static_cast<int32_t>(sl.digit_mask(s));
    test[s] = _mm512_set1_epi32(mask[s] << shift[s]);
    count[s] = 0;
    total[s] = 0;
  }
  // Each listed digit's row as its offset in g (rows x cols < 2^31: see analog_of).
  const __m512i first_row = _mm512_mullo_epi32(_mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15),
                                               _mm512_set1_epi32(static_cast<int32_t>(cols)));
  for (int k = 0; k < rows; k += 16) {
    const __mmask16 live =
        rows - k >= 16 ? static_cast<__mmask16>(0xFFFF) : static_cast<__mmask16>((1u << (rows - k)) - 1);
    const __m512i codes = _mm512_maskz_loadu_epi32(live, code + k);
    if (!_mm512_mask_test_epi32_mask(live, codes, codes)) continue;  // all zero
    const __m512i index = _mm512_add_epi32(first_row, _mm512_set1_epi32(k * static_cast<int32_t>(cols)));
    for (int s = 0; s < slices; ++s) {
      const __mmask16 nz = _mm512_mask_test_epi32_mask(live, codes, test[s]);
      if (!nz) continue;
      // Compressed in a register and stored whole (a compressing store is slow): the lanes
      // past the count are overwritten by the next group or never read.
      const size_t at = s * stride + static_cast<size_t>(count[s]);
      _mm512_storeu_si512(row.data() + at, _mm512_maskz_compress_epi32(nz, index));
      if (mask[s] == 1) {
        total[s] += __builtin_popcount(nz);
      } else {
        const __m512i d = _mm512_maskz_and_epi32(nz, _mm512_srli_epi32(codes, static_cast<unsigned>(shift[s])),
                                                 _mm512_set1_epi32(mask[s]));
        total[s] += _mm512_reduce_add_epi32(d);
        _mm512_storeu_ps(digit.data() + at, _mm512_maskz_compress_ps(nz, _mm512_cvtepi32_ps(d)));
      }
      count[s] += __builtin_popcount(nz);
    }
  }
  for (int s = 0; s < slices; ++s) {
    float* o = out + s * cols;
    sum_x[s] = static_cast<float>(total[s]) * unit[s];
    const int* r = row.data() + s * stride;
    const float* d = digit.data() + s * stride;
    if (!count[s])
      std::fill(o, o + cols, 0.0f);
    else if (mask[s] == 1)
      accumulate_columns<true>(g.data(), cols, r, nullptr, count[s], unit[s], o);
    else
      accumulate_columns<false>(g.data(), cols, r, d, count[s], unit[s], o);
  }
}

/// One read's ADC on float currents (adc_of), 16 columns at a time.
void adc_read_avx512(float* __restrict row, Eigen::Index cols, float sum_x, AdcLanes adc) {
  const __m512 sx = _mm512_set1_ps(sum_x);
  Eigen::Index c = 0;
  for (; c + 16 <= cols; c += 16)
    _mm512_storeu_ps(row + c, convert16(_mm512_loadu_ps(row + c), sx, adc, c, static_cast<__mmask16>(0xFFFF)));
  if (c < cols) {
    const __mmask16 live = static_cast<__mmask16>((1u << (cols - c)) - 1);
    _mm512_mask_storeu_ps(row + c, live, convert16(_mm512_maskz_loadu_ps(live, row + c), sx, adc, c, live));
  }
}

/// One vector's recovery for float (recover_of) when a weight's `per` columns divide 16: the
/// reads weighted by their places summed in registers, 16 columns at a time, each column's
/// share k (A / alpha - g_min t) and the sum of every weight's columns within the register.
/// i: the vector's reads (slices rows of ld); sums: per weight column.
void recover_vector_avx512(const float* i, Eigen::Index ld, int slices, const float* ws, float t, const float* k,
                           float inv_alpha, float gmin, int per, int cols, float* sums) {
  const Eigen::Index weighted = static_cast<Eigen::Index>(per) * cols;  // the sum(X) column is not summed
  const __m512 g_t = _mm512_set1_ps(gmin * t), ia = _mm512_set1_ps(inv_alpha);
  __mmask16 first_of_weight = 0;  // lanes 0, per, 2 per, ...
  for (int l = 0; l < 16; l += per) first_of_weight |= static_cast<__mmask16>(1u << l);
  for (Eigen::Index c = 0; c < weighted; c += 16) {
    const __mmask16 live =
        weighted - c >= 16 ? static_cast<__mmask16>(0xFFFF) : static_cast<__mmask16>((1u << (weighted - c)) - 1);
    __m512 a = _mm512_mul_ps(_mm512_set1_ps(ws[0]), _mm512_maskz_loadu_ps(live, i + c));
    for (int s = 1; s < slices; ++s)
      a = _mm512_fmadd_ps(_mm512_set1_ps(ws[s]), _mm512_maskz_loadu_ps(live, i + s * ld + c), a);
    __m512 p = _mm512_maskz_mul_ps(live, _mm512_maskz_loadu_ps(live, k + c), _mm512_fmsub_ps(a, ia, g_t));
    // Butterflies: after them every lane of a weight's group holds the group's sum.
    if (per >= 2) p = _mm512_add_ps(p, _mm512_permute_ps(p, _MM_SHUFFLE(2, 3, 0, 1)));
    if (per >= 4) p = _mm512_add_ps(p, _mm512_permute_ps(p, _MM_SHUFFLE(1, 0, 3, 2)));
    if (per >= 8) p = _mm512_add_ps(p, _mm512_shuffle_f32x4(p, p, _MM_SHUFFLE(2, 3, 0, 1)));
    if (per >= 16) p = _mm512_add_ps(p, _mm512_shuffle_f32x4(p, p, _MM_SHUFFLE(1, 0, 3, 2)));
    const int n = static_cast<int>(std::min<Eigen::Index>(16, weighted - c)) / per;
    _mm512_mask_storeu_ps(sums + c / per, static_cast<__mmask16>((1u << n) - 1),
                          _mm512_maskz_compress_ps(first_of_weight, p));
  }
}
#endif

}  // namespace

template <typename S>
void AnalogLayer::analog(int b, const Codes& codes, Eigen::Index first, Eigen::Index vectors, ReadCurrents<S>& cur,
                         uint64_t image) const {
  analog_of<S>(*xbars_.at(b), codes, first, vectors, cur, image);
}

template <typename S>
void AnalogLayer::analog_of(const Crossbar& x, const Codes& codes, Eigen::Index first, Eigen::Index vectors,
                            ReadCurrents<S>& cur, uint64_t image) const {
  const int slices = slicing_.slices;
  cur.first = first;
  cur.vectors = vectors;
  cur.i.resize(vectors * slices, x.pcols);
  cur.sum_x.resize(static_cast<size_t>(vectors * slices));
  if (cfg_.xbar.is_linear()) {  // I = V G_eff, alpha folded into the stored rows
    for (Eigen::Index v = 0; v < vectors; ++v) {
      const int32_t* code = codes.row(first + v) + x.in0;
#if defined(__AVX512F__)
      if constexpr (std::is_same_v<S, float>) {
        static_assert(kMaxSlices > 25, "input_bits <= 24 and a sign slice");
        if (x.geff_rows_f.size() < (1LL << 31)) {  // offsets in int32
          read_vector_avx512(x.geff_rows_f, code, slicing_, cur.i.row(v * slices), cur.sum_x.data() + v * slices);
          continue;
        }
      }
#endif
      for (int s = 0; s < slices; ++s) {
        const Eigen::Index r = v * slices + s;
        long total;
        if constexpr (std::is_same_v<S, float>)
          total = read_generic<float>(x.geff_rows_f, code, slicing_, s, cur.i.row(r));
        else
          total = read_generic<double>(x.geff_rows_d, code, slicing_, s, cur.i.row(r));
        cur.sum_x[r] = static_cast<S>(total) * static_cast<S>(slicing_.digit_unit(s));
      }
    }
    if (x.noise_p1.size() || cfg_.converters.readout_noise_a > 0) {
      thread_local RowMat<S> values;
#if defined(__AVX512F__)
      // Binary digits (1-bit DACs): a read's squared values are its |digits| x unit^2 and every
      // digit of a read has one sign, so its sums against the variance rows are the same sparse
      // row sums as the read itself (|unit sum d p1| x |unit|, unit sum d p2).
      if constexpr (std::is_same_v<S, float>) {
        if (x.noise_p1.size() && slicing_.digit_max() == 1 && x.noise_p1.size() < (1LL << 31)) {
          thread_local Rows<float> v1, v2;
          thread_local std::vector<float> sums;
          const Eigen::Index reads = vectors * slices;
          v1.resize(reads, x.pcols);
          v2.resize(reads, x.pcols);
          sums.resize(static_cast<size_t>(slices));
          for (Eigen::Index v = 0; v < vectors; ++v) {
            const int32_t* code = codes.row(first + v) + x.in0;
            read_vector_avx512(x.noise_p1, code, slicing_, v1.row(v * slices), sums.data());
            read_vector_avx512(x.noise_p2, code, slicing_, v2.row(v * slices), sums.data());
          }
          for (Eigen::Index r = 0; r < reads; ++r) {
            const float unit = static_cast<float>(std::abs(slicing_.digit_unit(static_cast<int>(r % slices))));
            Eigen::Map<Eigen::ArrayXf> row(v1.row(r), x.pcols);
            row = row.abs() * unit;
          }
          values.resize(reads, 0);  // unused: the sums are given
          add_read_noise<S>(x, values, cur.i.data(), x.pcols, /*row_major=*/true, first * slices, image, v1.data(),
                            v2.data());
          return;
        }
      }
#endif
      // Read noise: every read's values (digit x unit per row), squared against the cells' variances
      // (the readout's noise alone needs no values).
      // In blocks of vectors, so that programming's thousands of reads need no copy of them all.
      constexpr Eigen::Index kVectors = 64;
      for (Eigen::Index v0 = 0; v0 < vectors; v0 += kVectors) {
        const Eigen::Index nv = std::min(kVectors, vectors - v0);
        if (x.noise_p1.size())
          read_values<S>(codes, first + v0, nv, x.in0, x.blk.rows, values);
        else
          values.resize(nv * slices, 0);
        add_read_noise<S>(x, values, cur.i.row(v0 * slices), x.pcols, /*row_major=*/true, (first + v0) * slices, image);
      }
    }
    return;
  }
  // Nonlinear devices: every read solved, all of them in one batch.
  RowMat<double> values;
  read_values<double>(codes, first, vectors, x.in0, x.blk.rows, values);
  for (Eigen::Index v = 0; v < vectors; ++v) {
    const int32_t* code = codes.row(first + v) + x.in0;
    for (int s = 0; s < slices; ++s) {
      long total = 0;
      for (int k = 0; k < x.blk.rows; ++k) total += slicing_.digit(code[k], s);
      cur.sum_x[v * slices + s] = static_cast<S>(total) * static_cast<S>(slicing_.digit_unit(s));
    }
  }
  if (cfg_.device.has_read_noise()) {  // every read solved with its own conductances
    cur.i.matrix() = noisy_solves(x, volts(values), first * slices, image).template cast<S>();
    return;
  }
  cur.i.matrix() = x.solver->column_currents(volts(values)).template cast<S>();
  add_read_noise<S>(x, values, cur.i.data(), x.pcols, /*row_major=*/true, first * slices, image);
}

template <typename S>
void AnalogLayer::adc_inplace(int b, ReadCurrents<S>& cur) const {
  adc_of<S>(*xbars_.at(b), cur);
}

template <typename S>
void AnalogLayer::adc_of(const Crossbar& x, ReadCurrents<S>& cur) const {
  // Drift compensation is the readout's gain, before the ADC (see the other adc_of).
  compensate<S>(x, cur.i.data(), cur.i.rows(), cur.i.cols(), /*row_major=*/true);
  if (cfg_.converters.adc_bits <= 0) return;
  using Row = Eigen::Array<S, Eigen::Dynamic, 1>;
  const Eigen::Index cols = cur.i.cols(), reads = cur.i.rows();
  const int slices = slicing_.slices;
  const Crossbar::AdcTable<S>& t = x.template adc_table<S>();
  const bool per_read = t.lo.cols() > 1;
  // FastQuantizer::apply on the offset-subtracted current of every column (the code by
  // multiplying with 1 / step), in the datapath's precision.
#if defined(__AVX512F__)
  if constexpr (std::is_same_v<S, float>) {
    AdcLanes lanes[kMaxSlices];
    for (Eigen::Index g = 0; g < t.lo.cols(); ++g)
      lanes[g] = {t.offset.data(),      t.lo.col(g).data(),       t.hi.col(g).data(),
                  t.step.col(g).data(), t.inv_step.col(g).data(), t.all_on[g] ? nullptr : t.on.col(g).data()};
    for (Eigen::Index r = 0, s = 0; r < reads; ++r, s = s + 1 == slices ? 0 : s + 1)
      adc_read_avx512(cur.i.row(r), cols, cur.sum_x[r], lanes[per_read ? s : 0]);
    return;
  }
#endif
  for (Eigen::Index r = 0; r < reads; ++r) {
    const Eigen::Index g = per_read ? r % slices : 0;
    const auto lo = t.lo.col(g), hi = t.hi.col(g), step = t.step.col(g), inv_step = t.inv_step.col(g);
    Eigen::Map<Row> row(cur.i.row(r), cols);
    const auto offset = t.offset * cur.sum_x[r];
    const auto v = row - offset;
    row = (t.on.col(g) > S(0)).select(((v.max(lo).min(hi) - lo) * inv_step + S(0.5)).floor() * step + lo, v) + offset;
  }
}

template <typename S>
void AnalogLayer::recover_add(int b, const ReadCurrents<S>& cur, Mat<S>& y, bool calibrated) const {
  const Crossbar& x = *xbars_.at(b);
  recover_of<S>(x, cur, y, x.blk.col0, calibrated);
}

template <typename S>
void AnalogLayer::recover_of(const Crossbar& x, const ReadCurrents<S>& cur, Mat<S>& y, int y_col0,
                             bool calibrated) const {
  using Row = Eigen::Array<S, Eigen::Dynamic, 1>;
  const int slices = slicing_.slices, per = x.per_weight, pcols = x.pcols;
  const S gmin = static_cast<S>(cfg_.xbar.g_min_s), inv_alpha = static_cast<S>(1.0 / alpha_),
          w_lo = static_cast<S>(x.w_lo);
  // The sum(X) column: I_sum / alpha = (g_min + beta s a_sum) sum(X).
  const bool analog_sum = cfg_.mapping.analog_sum();
  const S sum_scale =
      analog_sum ? static_cast<S>(1.0 / (alpha_ * (cfg_.xbar.g_min_s + x.beta(pcols - 1) * x.s(pcols - 1) * x.a_sum)))
                 : S(0);
  const int cols = x.blk.cols;
  thread_local Row k, a, part, gain, offset, out;
  k = x.recover_k.template cast<S>();
  a.resize(pcols);
  part.resize(pcols);
  if (calibrated) {
    gain = x.fit.gain.array().template cast<S>();
    offset = x.fit.offset.array().template cast<S>();
  } else {
    gain.setOnes(cols);
    offset.setZero(cols);
  }
  out.resize(cur.vectors * cols);  // the vectors' outputs, by vector
  thread_local std::vector<S> ws, sums;
  ws.assign(slicing_.weight.begin(), slicing_.weight.end());
  sums.resize(static_cast<size_t>(cols));
  // Per vector: A = sum_s w_s I_s and T = sum_s w_s sum(X)_s over its reads (input slices at
  // their places), then each column's share k (A / alpha - g_min T), summed over the
  // weight's columns (weight slices at their places, k), plus w_lo T: the same as recovering
  // every read and adding them, with one recovery per vector.
  for (Eigen::Index v = 0; v < cur.vectors; ++v) {
    S t = 0;
    for (int s = 0; s < slices; ++s) {
      const Eigen::Index r = v * slices + s;
      t += ws[s] * (analog_sum ? cur.i(r, pcols - 1) * sum_scale : cur.sum_x[r]);
    }
    const S* i0 = cur.i.row(v * slices);
#if defined(__AVX512F__)
    if constexpr (std::is_same_v<S, float>) {
      if (16 % per == 0) {
        recover_vector_avx512(i0, pcols, slices, ws.data(), t, k.data(), inv_alpha, gmin, per, cols, sums.data());
        Eigen::Map<Row>(out.data() + v * cols, cols) =
            gain * (Eigen::Map<const Row>(sums.data(), cols) + w_lo * t) + offset;
        continue;
      }
    }
#endif
    for (int s = 0; s < slices; ++s) {
      const Eigen::Map<const Row> i(i0 + s * pcols, pcols);
      if (s == 0)
        a = ws[s] * i;
      else
        a += ws[s] * i;
    }
    part = k * (a * inv_alpha - gmin * t);
    S* o = out.data() + v * cols;
    for (int j = 0; j < cols; ++j) {
      S p = part(j * per);
      for (int q = 1; q < per; ++q) p += part(j * per + q);
      o[j] = gain(j) * (p + w_lo * t) + offset(j);
    }
  }
  for (int j = 0; j < cols; ++j) {
    S* yc = y.col(y_col0 + j).data() + cur.first;
    for (Eigen::Index v = 0; v < cur.vectors; ++v) yc[v] += out(v * cols + j);
  }
}

template <typename S>
void AnalogLayer::forward_serial(const RowMat<S>& xq, Mat<S>& y, uint64_t image) const {
  thread_local Codes codes;
  thread_local ReadCurrents<S> cur;
  slice_inputs<S>(xq, codes);
  const Eigen::Index n = xq.rows();
  // A few vectors at a time, so that their reads stay in cache through the three stages;
  // nonlinear devices solve all reads in one batch.
  const Eigen::Index tile = cfg_.xbar.is_linear() ? 16 : std::max<Eigen::Index>(n, 1);
  for (int b = 0; b < crossbars(); ++b) {
    try {
      for (Eigen::Index first = 0; first < n; first += tile) {
        check_cancel();
        analog<S>(b, codes, first, std::min(tile, n - first), cur, image);
        adc_inplace<S>(b, cur);
        recover_add<S>(b, cur, y);
      }
    } catch (const std::exception&) {
      rethrow_with_context(crossbar_name(blocks_[b]));
    }
  }
}

Eigen::MatrixXd AnalogLayer::offset_currents(const Crossbar& x, const Eigen::MatrixXd& xq, Eigen::VectorXi& range,
                                             uint64_t image) const {
  Eigen::MatrixXd cur;
  Eigen::VectorXd sx;
  if (slicing_.serial()) {
    Codes codes;
    slice_inputs<double>(xq, codes);
    ReadCurrents<double> rc;
    analog_of<double>(x, codes, 0, xq.rows(), rc, image);
    cur = rc.i.matrix();
    sx = Eigen::Map<const Eigen::VectorXd>(rc.sum_x.data(), cur.rows());
    range = Eigen::VectorXi::LinSpaced(cur.rows(), 0, static_cast<int>(cur.rows()) - 1).unaryExpr([&](int r) {
      return r % slicing_.slices;
    });
  } else {
    cur = currents_of(x, xq, image);
    sx = xq.middleCols(x.in0, x.blk.rows).rowwise().sum();
    range = Eigen::VectorXi::Zero(cur.rows());
  }
  for (int c = 0; c < x.pcols; ++c) cur.col(c) -= x.adc_offset(c) * sx;
  return cur;
}

Eigen::VectorXd AnalogLayer::mean_read_values(const Crossbar& x, const Eigen::MatrixXd& xq) const {
  if (!slicing_.serial()) return xq.middleCols(x.in0, x.blk.rows).cwiseAbs().colwise().mean().transpose();
  Codes codes;
  slice_inputs<double>(xq, codes);
  RowMat<double> values;
  read_values<double>(codes, 0, xq.rows(), x.in0, x.blk.rows, values);
  return values.cwiseAbs().colwise().mean().transpose();
}

#define XBARSIM_INSTANTIATE(S)                                                                                         \
  template void AnalogLayer::slice_inputs<S>(const RowMat<S>&, Codes&) const;                                          \
  template void AnalogLayer::read_values<S>(const Codes&, Eigen::Index, Eigen::Index, int, int, RowMat<S>&) const;     \
  template void AnalogLayer::analog<S>(int, const Codes&, Eigen::Index, Eigen::Index, ReadCurrents<S>&, uint64_t)     \
      const;                                                                                                           \
  template void AnalogLayer::analog_of<S>(const Crossbar&, const Codes&, Eigen::Index, Eigen::Index, ReadCurrents<S>&, \
                                          uint64_t) const;                                                             \
  template void AnalogLayer::adc_inplace<S>(int, ReadCurrents<S>&) const;                                              \
  template void AnalogLayer::adc_of<S>(const Crossbar&, ReadCurrents<S>&) const;                                       \
  template void AnalogLayer::recover_add<S>(int, const ReadCurrents<S>&, Mat<S>&, bool) const;                         \
  template void AnalogLayer::recover_of<S>(const Crossbar&, const ReadCurrents<S>&, Mat<S>&, int, bool) const;         \
  template void AnalogLayer::forward_serial<S>(const RowMat<S>&, Mat<S>&, uint64_t) const;
XBARSIM_INSTANTIATE(float)
XBARSIM_INSTANTIATE(double)
#undef XBARSIM_INSTANTIATE

}  // namespace xbarsim
