// NEON U-map histogram kernel (aarch64). Bins 8 pixels per step with the same integer formula as
// UMapBinning::bin_of, writes the 8 bin-major cell offsets to a small buffer, then scatters them
// with scalar increments (NEON has no scatter). Invalid pixels go to the dummy row, so the loop
// has no branches on pixel values.
#include <arm_neon.h>

#include <cstddef>
#include <cstdint>

#include "dynamap/detect/detail/umap_histogram.hpp"

namespace dynamap::detail {

void umap_histogram_neon(const DepthView& depth, const UMapBinning& binning,
                         const UMapBuffer& out) noexcept {
  constexpr int kChunk = 64;  // offsets per scatter batch; a multiple of 8
  const uint16x8_t v_lo = vdupq_n_u16(binning.raw_min);
  const uint16x8_t v_hi = vdupq_n_u16(binning.raw_max);
  const uint16x8_t v_mul = vdupq_n_u16(binning.multiplier);
  const int32x4_t v_shift = vdupq_n_s32(-static_cast<std::int32_t>(binning.shift));
  const uint16x8_t v_dummy = vdupq_n_u16(static_cast<std::uint16_t>(binning.bins));
  const uint32x4_t v_stride = vdupq_n_u32(static_cast<std::uint32_t>(out.stride));
  const std::uint32_t lane_init[4] = {0u, 1u, 2u, 3u};
  const uint32x4_t v_lane = vld1q_u32(lane_init);
  std::uint16_t* const counts = out.counts;
  alignas(16) std::uint32_t off[kChunk];

  for (int v = 0; v < depth.height; ++v) {
    const std::uint16_t* row = depth.row(v);
    int u0 = 0;
    for (; u0 + 8 <= depth.width; u0 += kChunk) {
      const int n = (depth.width - u0 < kChunk ? depth.width - u0 : kChunk) & ~7;
      for (int i = 0; i < n; i += 8) {
        const uint16x8_t d = vld1q_u16(row + u0 + i);
        const uint16x8_t valid = vandq_u16(vcgeq_u16(d, v_lo), vcleq_u16(d, v_hi));
        const uint16x8_t x = vsubq_u16(d, v_lo);  // garbage where invalid; masked below
        const uint32x4_t p0 = vshlq_u32(vmull_u16(vget_low_u16(x), vget_low_u16(v_mul)), v_shift);
        const uint32x4_t p1 = vshlq_u32(vmull_high_u16(x, v_mul), v_shift);
        const uint16x8_t bin = vbslq_u16(valid, vmovn_high_u32(vmovn_u32(p0), p1), v_dummy);
        const uint32x4_t base = vaddq_u32(vdupq_n_u32(static_cast<std::uint32_t>(u0 + i)), v_lane);
        const uint32x4_t o0 = vmlaq_u32(base, vmovl_u16(vget_low_u16(bin)), v_stride);
        const uint32x4_t o1 =
            vmlaq_u32(vaddq_u32(base, vdupq_n_u32(4u)), vmovl_high_u16(bin), v_stride);
        vst1q_u32(off + i, o0);
        vst1q_u32(off + i + 4, o1);
      }
      for (int i = 0; i < n; ++i) ++counts[off[i]];
      if (n < kChunk) {
        u0 += n;
        break;
      }
    }
    // Tail (< 8 pixels): the scalar reference formula.
    for (int u = u0; u < depth.width; ++u) {
      const int b = binning.bin_of(row[u]);
      ++counts[static_cast<std::ptrdiff_t>(b) * out.stride + u];
    }
  }
}

}  // namespace dynamap::detail
