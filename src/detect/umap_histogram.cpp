#include "dynamap/detect/detail/umap_histogram.hpp"

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>

namespace dynamap {

Status make_umap_binning(float d_min, float d_max, float depth_scale, int bins,
                         UMapBinning* out) noexcept {
  if (out == nullptr) return Status::kNullData;
  if (!std::isfinite(d_min) || !std::isfinite(d_max) || !std::isfinite(depth_scale)) {
    return Status::kInvalidArgument;
  }
  if (depth_scale <= 0.f || d_min < 0.f || d_max <= d_min) return Status::kInvalidArgument;
  if (bins < 1 || bins > kMaxUMapBins) return Status::kInvalidArgument;
  // Snap quotients within 1e-3 of an integer so that e.g. 0.6 m at 0.001 m/unit is 600 units,
  // not 599 through float rounding.
  const auto snap = [](double q) {
    const double r = std::round(q);
    return std::fabs(q - r) < 1e-3 ? r : q;
  };
  const double lo = std::ceil(snap(static_cast<double>(d_min) / depth_scale));
  const double hi = std::floor(snap(static_cast<double>(d_max) / depth_scale));
  const double raw_min = lo < 1.0 ? 1.0 : lo;  // raw 0 means "no measurement"
  if (hi > 65535.0 || hi < raw_min) return Status::kInvalidArgument;
  const std::uint32_t span = static_cast<std::uint32_t>(hi - raw_min) + 1u;
  if (span < static_cast<std::uint32_t>(bins)) return Status::kInvalidArgument;
  // Largest shift whose multiplier still fits 16 bits: x (< 2^16) * multiplier (< 2^16) fits
  // in 32 bits, which is what a widening 16x16 multiply gives in NEON.
  int shift = 31;
  std::uint64_t mul = 0;
  for (; shift >= 0; --shift) {
    mul = (static_cast<std::uint64_t>(bins) << shift) / span;
    if (mul <= 0xFFFFu) break;
  }
  if (shift < 0 || mul == 0) return Status::kInvalidArgument;
  UMapBinning b;
  b.raw_min = static_cast<std::uint16_t>(raw_min);
  b.raw_max = static_cast<std::uint16_t>(hi);
  b.multiplier = static_cast<std::uint16_t>(mul);
  b.shift = static_cast<std::uint8_t>(shift);
  b.bins = bins;
  b.depth_scale = depth_scale;
  *out = b;
  return Status::kOk;
}

namespace detail {

Status check_umap_args(const DepthView& depth, const UMapBinning& binning,
                       const UMapBuffer& out) noexcept {
  if (depth.data == nullptr || out.counts == nullptr) return Status::kNullData;
  if (depth.width <= 0 || depth.height <= 0) return Status::kWrongSize;
  if (depth.stride_bytes < depth.width * static_cast<int>(sizeof(std::uint16_t)) ||
      depth.stride_bytes % static_cast<int>(sizeof(std::uint16_t)) != 0 ||
      reinterpret_cast<std::uintptr_t>(depth.data) % alignof(std::uint16_t) != 0) {
    return Status::kWrongSize;
  }
  if (depth.height > kMaxUMapColumnHeight) return Status::kInvalidArgument;
  if (binning.bins < 1 || binning.bins > kMaxUMapBins || binning.multiplier == 0 ||
      binning.shift > 31 || binning.raw_min == 0 || binning.raw_max < binning.raw_min) {
    return Status::kInvalidArgument;
  }
  if (out.stride < depth.width) return Status::kWrongSize;
  const std::int64_t needed = static_cast<std::int64_t>(binning.bins + 1) * out.stride;
  if (out.capacity < needed) return Status::kWrongSize;
  return Status::kOk;
}

namespace {
void clear_rows(const DepthView& depth, const UMapBinning& binning, const UMapBuffer& out) {
  for (int b = 0; b <= binning.bins; ++b) {
    std::memset(out.counts + static_cast<std::ptrdiff_t>(b) * out.stride, 0,
                static_cast<std::size_t>(depth.width) * sizeof(std::uint16_t));
  }
}

#if !defined(DYNAMAP_HAVE_NEON)
// Chunked host path: a branch-free offset pass the compiler vectorises, then a scalar scatter.
// Within one image row every pixel writes its own column, so the scatter has no store-to-load
// conflicts and needs no sub-histograms.
void umap_histogram_chunked(const DepthView& depth, const UMapBinning& binning,
                            const UMapBuffer& out) noexcept {
  constexpr int kChunk = 64;
  const std::uint32_t lo = binning.raw_min;
  const std::uint32_t hi = binning.raw_max;
  const std::uint32_t mul = binning.multiplier;
  const std::uint32_t shift = binning.shift;
  const std::uint32_t dummy = static_cast<std::uint32_t>(binning.bins);
  const std::uint32_t stride = static_cast<std::uint32_t>(out.stride);
  std::uint16_t* const counts = out.counts;
  std::uint32_t off[kChunk];
  for (int v = 0; v < depth.height; ++v) {
    const std::uint16_t* row = depth.row(v);
    for (int u0 = 0; u0 < depth.width; u0 += kChunk) {
      const int n = depth.width - u0 < kChunk ? depth.width - u0 : kChunk;
      const std::uint16_t* src = row + u0;
      for (int i = 0; i < n; ++i) {
        const std::uint32_t d = src[i];
        const std::uint32_t x = (d - lo) & 0xFFFFu;
        const std::uint32_t b = (d >= lo && d <= hi) ? ((x * mul) >> shift) : dummy;
        off[i] = b * stride + static_cast<std::uint32_t>(u0 + i);
      }
      for (int i = 0; i < n; ++i) ++counts[off[i]];
    }
  }
}
#endif
}  // namespace
}  // namespace detail

Status umap_histogram_scalar(const DepthView& depth, const UMapBinning& binning,
                             const UMapBuffer& out) noexcept {
  const Status s = detail::check_umap_args(depth, binning, out);
  if (!ok(s)) return s;
  detail::clear_rows(depth, binning, out);
  for (int v = 0; v < depth.height; ++v) {
    const std::uint16_t* row = depth.row(v);
    for (int u = 0; u < depth.width; ++u) {
      const int b = binning.bin_of(row[u]);
      ++out.counts[static_cast<std::ptrdiff_t>(b) * out.stride + u];
    }
  }
  return Status::kOk;
}

Status umap_histogram_fast(const DepthView& depth, const UMapBinning& binning,
                           const UMapBuffer& out) noexcept {
  const Status s = detail::check_umap_args(depth, binning, out);
  if (!ok(s)) return s;
  detail::clear_rows(depth, binning, out);
#if defined(DYNAMAP_HAVE_NEON)
  detail::umap_histogram_neon(depth, binning, out);
#elif defined(DYNAMAP_HAVE_SSE2)
  if (binning.shift >= 16) {
    detail::umap_histogram_sse2(depth, binning, out);
  } else {
    detail::umap_histogram_chunked(depth, binning, out);  // bins nearly one raw unit wide
  }
#else
  detail::umap_histogram_chunked(depth, binning, out);
#endif
  return Status::kOk;
}

const char* umap_histogram_fast_name() noexcept {
#if defined(DYNAMAP_HAVE_NEON)
  return "neon";
#elif defined(DYNAMAP_HAVE_SSE2)
  return "sse2";
#else
  return "host-chunked";
#endif
}

}  // namespace dynamap
