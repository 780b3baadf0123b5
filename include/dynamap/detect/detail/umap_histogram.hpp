// Internal: include/dynamap/detail/ is installed because Pipeline holds its stages inline, but it
// is not a stable API. U-map histogram kernel: for every image column u, how many of its pixels
// fall in each depth bin.
// Two implementations behind one contract: a scalar reference and a fast path (NEON on aarch64
// when DYNAMAP_HAVE_NEON; SSE2 on x86-64 when DYNAMAP_HAVE_SSE2 and the binning's shift is at
// least 16, i.e. bins wider than about two raw units; otherwise a chunked host loop the compiler
// vectorises). All use the same integer bin formula, so their outputs are identical bit for bit
// on every input.
#pragma once

#include <cstdint>

#include "dynamap/core/constants.hpp"
#include "dynamap/core/status.hpp"
#include "dynamap/core/types.hpp"

namespace dynamap {

/// Most depth bins a U map may have (one extra dummy row collects invalid pixels).
inline constexpr int kMaxUMapBins = 128;

// Counts are uint16 and never saturate: a column holds at most `height` pixels and the kernels
// refuse images taller than this, so no per-pixel saturation logic is needed.
inline constexpr int kMaxUMapColumnHeight = 65535;
static_assert(kMaxImageHeight <= kMaxUMapColumnHeight, "U-map counts are uint16");

/// Integer binning of raw depth values d (uint16, depth_scale metres per unit):
///   valid  iff raw_min <= d <= raw_max (raw_min >= 1, so 0 = "no measurement" is never valid);
///   bin    = ((d - raw_min) * multiplier) >> shift, always in [0, bins - 1].
/// multiplier is the largest 16-bit value floor(bins * 2^shift / span) can take, so bins are
/// equal width to about 1/32768. Invalid pixels go to the dummy bin `bins`.
struct UMapBinning {
  std::uint16_t raw_min = 1;
  std::uint16_t raw_max = 1;
  std::uint16_t multiplier = 0;
  std::uint8_t shift = 0;
  int bins = 0;
  float depth_scale = 0.f;

  /// Bin of one raw depth value; `bins` (the dummy bin) when invalid. The reference formula.
  int bin_of(std::uint16_t d) const noexcept {
    if (d < raw_min || d > raw_max) return bins;
    const std::uint32_t x = static_cast<std::uint32_t>(d - raw_min);
    return static_cast<int>((x * multiplier) >> shift);
  }
  /// Smallest raw depth that falls in bin b (b in [0, bins]; b == bins gives raw_max + 1).
  std::uint32_t bin_first_raw(int b) const noexcept {
    if (b <= 0) return raw_min;
    if (b >= bins) return static_cast<std::uint32_t>(raw_max) + 1u;
    // smallest x with x * multiplier >= b << shift
    const std::uint64_t need = static_cast<std::uint64_t>(b) << shift;
    return raw_min + static_cast<std::uint32_t>((need + multiplier - 1) / multiplier);
  }
  /// Depth (metres) of the near edge of bin b.
  float bin_near_depth(int b) const noexcept {
    return static_cast<float>(bin_first_raw(b)) * depth_scale;
  }
  /// Depth (metres) of the far edge of bin b (= near edge of b + 1).
  float bin_far_depth(int b) const noexcept { return bin_near_depth(b + 1); }
};

/// Builds the binning for [d_min, d_max] metres. kInvalidArgument when the range is empty,
/// non-finite, not representable in uint16 units, or has fewer raw units than bins.
[[nodiscard]] Status make_umap_binning(float d_min, float d_max, float depth_scale, int bins,
                                       UMapBinning* out) noexcept;

/// Caller-owned U-map storage, bin-major: counts[b * stride + u] for b in [0, bins] (row `bins`
/// is the dummy row for invalid pixels). Bin-major keeps neighbouring pixels of one image row,
/// which mostly share a depth bin, on the same cache line, and each bin row is contiguous for
/// the segment scan that follows.
struct UMapBuffer {
  std::uint16_t* counts = nullptr;
  int stride = 0;    ///< elements between bin rows, >= image width
  int capacity = 0;  ///< total elements available at counts
};

/// Scalar reference: overwrites rows [0, bins] x columns [0, width) of `out`.
/// kNullData / kWrongSize / kInvalidArgument on bad input (out unchanged).
[[nodiscard]] Status umap_histogram_scalar(const DepthView& depth, const UMapBinning& binning,
                                           const UMapBuffer& out) noexcept;

/// Fast path with the same contract and bit-identical output (NEON on aarch64 builds with
/// DYNAMAP_HAVE_NEON; SSE2 on x86-64 for shift >= 16; a vectorisable chunked loop elsewhere).
[[nodiscard]] Status umap_histogram_fast(const DepthView& depth, const UMapBinning& binning,
                                         const UMapBuffer& out) noexcept;

/// Name of the implementation behind umap_histogram_fast ("neon", "sse2" or "host-chunked";
/// "sse2" falls back to the chunked loop for binnings with shift < 16).
const char* umap_histogram_fast_name() noexcept;

namespace detail {
/// Shared argument check of both kernels.
Status check_umap_args(const DepthView& depth, const UMapBinning& binning,
                       const UMapBuffer& out) noexcept;
#if defined(DYNAMAP_HAVE_NEON)
/// NEON kernel body (platform/neon); arguments already checked.
void umap_histogram_neon(const DepthView& depth, const UMapBinning& binning,
                         const UMapBuffer& out) noexcept;
#endif
#if defined(DYNAMAP_HAVE_SSE2)
/// SSE2 kernel body (platform/x86); arguments already checked and binning.shift >= 16.
void umap_histogram_sse2(const DepthView& depth, const UMapBinning& binning,
                         const UMapBuffer& out) noexcept;
#endif
}  // namespace detail

}  // namespace dynamap
