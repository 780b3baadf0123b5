// SSE2 U-map histogram kernel (x86-64, where SSE2 is always present). For binnings with
// shift >= 16 the integer bin formula of UMapBinning::bin_of runs in 16-bit lanes, eight pixels
// per step: (x * multiplier) >> shift is the high half of the 16 x 16-bit product shifted right
// by shift - 16, and raw_min <= d <= raw_max iff the wrapping d - raw_min is <= raw_max -
// raw_min (a saturating subtract that gives 0). Invalid pixels get the dummy bin, so there are
// no branches on pixel values; the bins of 64 pixels are then scattered with scalar increments
// through a table of bin-row pointers (SSE2 has no scatter).
#include <emmintrin.h>

#include <cstddef>
#include <cstdint>

#include "dynamap/detect/detail/umap_histogram.hpp"

namespace dynamap::detail {

void umap_histogram_sse2(const DepthView& depth, const UMapBinning& binning,
                         const UMapBuffer& out) noexcept {
  constexpr int kChunk = 64;  // bins per scatter batch; a multiple of 8
  const __m128i v_lo = _mm_set1_epi16(static_cast<short>(binning.raw_min));
  const __m128i v_span = _mm_set1_epi16(static_cast<short>(binning.raw_max - binning.raw_min));
  const __m128i v_mul = _mm_set1_epi16(static_cast<short>(binning.multiplier));
  const __m128i v_shift = _mm_cvtsi32_si128(binning.shift - 16);
  const __m128i v_dummy = _mm_set1_epi16(static_cast<short>(binning.bins));
  const __m128i v_zero = _mm_setzero_si128();
  std::uint16_t* rows[kMaxUMapBins + 1];
  for (int b = 0; b <= binning.bins; ++b) {
    rows[b] = out.counts + static_cast<std::ptrdiff_t>(b) * out.stride;
  }
  alignas(16) std::uint16_t bin[kChunk];

  for (int v = 0; v < depth.height; ++v) {
    const std::uint16_t* row = depth.row(v);
    int u0 = 0;
    for (; u0 + 8 <= depth.width; u0 += kChunk) {
      const int n = (depth.width - u0 < kChunk ? depth.width - u0 : kChunk) & ~7;
      for (int i = 0; i < n; i += 8) {
        const __m128i d = _mm_loadu_si128(reinterpret_cast<const __m128i*>(row + u0 + i));
        const __m128i x = _mm_sub_epi16(d, v_lo);
        const __m128i valid = _mm_cmpeq_epi16(_mm_subs_epu16(x, v_span), v_zero);
        const __m128i b = _mm_srl_epi16(_mm_mulhi_epu16(x, v_mul), v_shift);
        const __m128i sel = _mm_or_si128(_mm_and_si128(valid, b), _mm_andnot_si128(valid, v_dummy));
        _mm_store_si128(reinterpret_cast<__m128i*>(bin + i), sel);
      }
      std::uint16_t* const* const r = rows;
      for (int i = 0; i < n; i += 4) {
        ++r[bin[i]][u0 + i];
        ++r[bin[i + 1]][u0 + i + 1];
        ++r[bin[i + 2]][u0 + i + 2];
        ++r[bin[i + 3]][u0 + i + 3];
      }
      if (n < kChunk) {
        u0 += n;
        break;
      }
    }
    // Tail (< 8 pixels): the scalar reference formula.
    for (int u = u0; u < depth.width; ++u) ++rows[binning.bin_of(row[u])][u];
  }
}

}  // namespace dynamap::detail
