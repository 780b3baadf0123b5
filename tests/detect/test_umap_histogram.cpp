// U-map histogram kernels: the binning formula, the scalar reference against an independent
// count, and the fast path (NEON on aarch64, SSE2 on x86-64) bit-identical to the reference on
// random images, edge values and odd widths.
#include <gtest/gtest.h>

#include <cstdint>
#include <random>
#include <vector>

#include "alloc_guard.hpp"
#include "dynamap/detect/detail/umap_histogram.hpp"

namespace dynamap {
namespace {

struct Hist {
  std::vector<std::uint16_t> counts;
  UMapBuffer buffer;
  Hist(int bins, int stride, std::uint16_t fill = 0xBEEF)
      : counts(static_cast<std::size_t>(bins + 1) * static_cast<std::size_t>(stride), fill) {
    buffer = UMapBuffer{counts.data(), stride, static_cast<int>(counts.size())};
  }
  std::uint16_t at(int b, int u) const {
    return counts[static_cast<std::size_t>(b) * static_cast<std::size_t>(buffer.stride) +
                  static_cast<std::size_t>(u)];
  }
};

UMapBinning binning_or_die(float d_min, float d_max, float scale, int bins) {
  UMapBinning b;
  EXPECT_EQ(make_umap_binning(d_min, d_max, scale, bins, &b), Status::kOk);
  return b;
}

// Both kernels on the same image; every cell of rows [0, bins] x [0, width) must match.
void expect_identical(const std::vector<std::uint16_t>& img, int width, int height, int stride,
                      const UMapBinning& binning) {
  const DepthView view{img.data(), width, height, stride * 2};
  // Different fills and a wider U-map stride: nothing outside the contract may be relied on.
  Hist a(binning.bins, width, 0x1111), b(binning.bins, width + 5, 0x2222);
  ASSERT_EQ(umap_histogram_scalar(view, binning, a.buffer), Status::kOk);
  ASSERT_EQ(umap_histogram_fast(view, binning, b.buffer), Status::kOk);
  for (int bin = 0; bin <= binning.bins; ++bin) {
    for (int u = 0; u < width; ++u) {
      ASSERT_EQ(a.at(bin, u), b.at(bin, u)) << "bin " << bin << " u " << u << " width " << width;
    }
  }
  // Untouched padding of the fast path's buffer keeps its fill.
  for (int bin = 0; bin <= binning.bins; ++bin) {
    for (int u = width; u < width + 5; ++u) ASSERT_EQ(b.at(bin, u), 0x2222);
  }
}

TEST(UMapBinning, RejectsBadRanges) {
  UMapBinning b;
  EXPECT_EQ(make_umap_binning(1.f, 0.5f, 0.001f, 10, &b), Status::kInvalidArgument);
  EXPECT_EQ(make_umap_binning(0.f, 8.f, 0.f, 10, &b), Status::kInvalidArgument);
  EXPECT_EQ(make_umap_binning(0.f, 8.f, 0.001f, 0, &b), Status::kInvalidArgument);
  EXPECT_EQ(make_umap_binning(0.f, 8.f, 0.001f, kMaxUMapBins + 1, &b), Status::kInvalidArgument);
  EXPECT_EQ(make_umap_binning(0.f, 100.f, 0.001f, 10, &b), Status::kInvalidArgument);   // > 65535
  EXPECT_EQ(make_umap_binning(0.f, 0.05f, 0.001f, 120, &b), Status::kInvalidArgument);  // 50 < 120
  EXPECT_EQ(make_umap_binning(0.f, NAN, 0.001f, 10, &b), Status::kInvalidArgument);
  EXPECT_EQ(make_umap_binning(0.f, 8.f, 0.001f, 10, nullptr), Status::kNullData);
}

TEST(UMapBinning, BinsAreContiguousOrderedAndMatchDepths) {
  for (const UMapBinning& b :
       {binning_or_die(0.01f, 8.f, 0.001f, 120), binning_or_die(0.3f, 5.f, 1.f / 5000.f, 128),
        binning_or_die(0.f, 65.535f, 0.001f, 7), binning_or_die(0.5f, 0.6f, 0.001f, 101),
        binning_or_die(0.5f, 0.6f, 0.001f, 100)}) {
    EXPECT_GE(b.raw_min, 1);
    // Bin edges in metres: evenly spread over [raw_min, raw_max] (to within a raw unit or so).
    for (int k = 0; k <= b.bins; ++k) {
      const double lo = b.raw_min * static_cast<double>(b.depth_scale);
      const double hi = (b.raw_max + 1) * static_cast<double>(b.depth_scale);
      EXPECT_NEAR(b.bin_near_depth(k), lo + k * (hi - lo) / b.bins, 2.5 * b.depth_scale);
    }
    EXPECT_EQ(b.bin_of(0), b.bins);
    EXPECT_EQ(b.bin_of(static_cast<std::uint16_t>(b.raw_min - 1)), b.bins);
    EXPECT_EQ(b.bin_of(b.raw_min), 0);
    EXPECT_EQ(b.bin_of(b.raw_max), b.bins - 1) << "last bin reaches raw_max";
    if (b.raw_max < 65535) {
      EXPECT_EQ(b.bin_of(static_cast<std::uint16_t>(b.raw_max + 1)), b.bins);
    }
    int prev = 0;
    for (std::uint32_t d = b.raw_min; d <= b.raw_max; ++d) {
      const int bin = b.bin_of(static_cast<std::uint16_t>(d));
      ASSERT_TRUE(bin == prev || bin == prev + 1) << d;  // no bin skipped, never decreasing
      prev = bin;
    }
    for (int bin = 0; bin < b.bins; ++bin) {
      const std::uint32_t first = b.bin_first_raw(bin);
      ASSERT_EQ(b.bin_of(static_cast<std::uint16_t>(first)), bin);
      if (bin > 0) {
        ASSERT_EQ(b.bin_of(static_cast<std::uint16_t>(first - 1)), bin - 1);
      }
      // Bin widths equal to within one raw unit.
      const std::uint32_t width = b.bin_first_raw(bin + 1) - first;
      const double ideal = static_cast<double>(b.raw_max - b.raw_min + 1) / b.bins;
      const double span = static_cast<double>(b.raw_max - b.raw_min + 1);
      ASSERT_LE(std::abs(static_cast<double>(width) - ideal), 1.0 + span / 32768.0) << bin;
    }
  }
}

TEST(UMapHistogram, ScalarMatchesIndependentCount) {
  const UMapBinning b = binning_or_die(0.1f, 8.f, 0.001f, 120);
  const int w = 37, h = 23;
  std::vector<std::uint16_t> img(static_cast<std::size_t>(w * h));
  std::mt19937 rng(7);
  std::uniform_int_distribution<int> dist(0, 9000);
  for (auto& p : img) p = static_cast<std::uint16_t>(dist(rng));
  Hist hist(b.bins, w);
  ASSERT_EQ(umap_histogram_scalar(DepthView{img.data(), w, h, w * 2}, b, hist.buffer), Status::kOk);
  for (int u = 0; u < w; ++u) {
    // Independent count by search over the bin edges: bin k covers raw [first(k), first(k+1)).
    std::vector<int> expect(static_cast<std::size_t>(b.bins + 1), 0);
    for (int v = 0; v < h; ++v) {
      const std::uint32_t d = img[static_cast<std::size_t>(v * w + u)];
      int bin = b.bins;
      for (int k = 0; k < b.bins; ++k) {
        if (d >= b.bin_first_raw(k) && d < b.bin_first_raw(k + 1)) bin = k;
      }
      ++expect[static_cast<std::size_t>(bin)];
    }
    int total = 0;
    for (int k = 0; k <= b.bins; ++k) {
      ASSERT_EQ(hist.at(k, u), expect[static_cast<std::size_t>(k)]) << "u " << u << " bin " << k;
      total += hist.at(k, u);
    }
    EXPECT_EQ(total, h);  // every pixel lands somewhere (invalid ones in the dummy row)
  }
}

TEST(UMapHistogram, FastIdenticalOnRandomImagesAndOddWidths) {
  std::printf("fast path: %s\n", umap_histogram_fast_name());
  std::mt19937 rng(12345);
  const UMapBinning binnings[] = {
      binning_or_die(0.01f, 8.f, 0.001f, 120), binning_or_die(0.3f, 5.f, 1.f / 5000.f, 128),
      binning_or_die(0.f, 65.535f, 0.001f, 1), binning_or_die(1.f, 1.2f, 0.001f, 33),
      // shift 15 (the host fast path's 32-bit fallback) and exactly 16 (SSE2, no final shift)
      binning_or_die(0.001f, 0.128f, 0.001f, 128), binning_or_die(0.001f, 0.130f, 0.001f, 128)};
  EXPECT_EQ(binnings[4].shift, 15);
  EXPECT_EQ(binnings[5].shift, 16);
  for (int width : {1, 2, 3, 7, 8, 9, 15, 16, 17, 63, 64, 65, 71, 127, 129, 639, 640}) {
    const int height = 1 + static_cast<int>(rng() % 19);
    const int stride = width + static_cast<int>(rng() % 3);  // padded rows too
    std::vector<std::uint16_t> img(static_cast<std::size_t>(stride * height));
    std::uniform_int_distribution<int> any(0, 65535);
    std::uniform_int_distribution<int> near(0, 9000);
    for (std::size_t i = 0; i < img.size(); ++i) {
      img[i] = static_cast<std::uint16_t>((i % 3 == 0) ? any(rng) : near(rng));
    }
    for (const UMapBinning& b : binnings) expect_identical(img, width, height, stride, b);
  }
}

TEST(UMapHistogram, FastIdenticalOnEdgeValues) {
  for (const UMapBinning& b :
       {binning_or_die(0.01f, 8.f, 0.001f, 120), binning_or_die(0.f, 65.535f, 0.001f, 128),
        binning_or_die(0.3f, 5.f, 1.f / 5000.f, 64), binning_or_die(0.001f, 0.128f, 0.001f, 128),
        binning_or_die(0.001f, 0.130f, 0.001f, 128)}) {
    std::vector<std::uint16_t> values = {0, 1, 2, 65534, 65535, b.raw_min, b.raw_max};
    if (b.raw_min > 0) values.push_back(static_cast<std::uint16_t>(b.raw_min - 1));
    if (b.raw_max < 65535) values.push_back(static_cast<std::uint16_t>(b.raw_max + 1));
    for (int k = 1; k < b.bins; ++k) {  // both sides of every bin edge
      values.push_back(static_cast<std::uint16_t>(b.bin_first_raw(k)));
      values.push_back(static_cast<std::uint16_t>(b.bin_first_raw(k) - 1));
    }
    for (int width : {13, 64, 333}) {
      const int height = 7;
      std::vector<std::uint16_t> img(static_cast<std::size_t>(width * height));
      for (std::size_t i = 0; i < img.size(); ++i) img[i] = values[(i * 7 + i / 5) % values.size()];
      expect_identical(img, width, height, width, b);
      // And a check of the reference itself on these values.
      Hist h(b.bins, width);
      ASSERT_EQ(umap_histogram_scalar(DepthView{img.data(), width, height, width * 2}, b, h.buffer),
                Status::kOk);
      for (int u = 0; u < width; ++u) {
        std::vector<int> expect(static_cast<std::size_t>(b.bins + 1), 0);
        for (int v = 0; v < height; ++v) {
          ++expect[static_cast<std::size_t>(
              b.bin_of(img[static_cast<std::size_t>(v * width + u)]))];
        }
        for (int k = 0; k <= b.bins; ++k)
          ASSERT_EQ(h.at(k, u), expect[static_cast<std::size_t>(k)]);
      }
    }
    EXPECT_EQ(b.bin_of(0), b.bins);
    EXPECT_EQ(b.bin_of(b.raw_min), 0);
  }
}

TEST(UMapHistogram, TallColumnsCountWithoutWrapping) {
  // 480 identical pixels in one column: count 480 in a single cell, in both kernels.
  const UMapBinning b = binning_or_die(0.1f, 8.f, 0.001f, 120);
  const int w = 9, h = 480;
  std::vector<std::uint16_t> img(static_cast<std::size_t>(w * h), 2500);
  Hist a(b.bins, w), f(b.bins, w);
  const DepthView view{img.data(), w, h, w * 2};
  ASSERT_EQ(umap_histogram_scalar(view, b, a.buffer), Status::kOk);
  ASSERT_EQ(umap_histogram_fast(view, b, f.buffer), Status::kOk);
  for (int u = 0; u < w; ++u) {
    EXPECT_EQ(a.at(b.bin_of(2500), u), 480);
    EXPECT_EQ(f.at(b.bin_of(2500), u), 480);
  }
}

TEST(UMapHistogram, BadArgumentsLeaveOutputUntouched) {
  const UMapBinning b = binning_or_die(0.1f, 8.f, 0.001f, 120);
  std::vector<std::uint16_t> img(64 * 8, 1000);
  for (auto* kernel : {&umap_histogram_scalar, &umap_histogram_fast}) {
    Hist h(b.bins, 64, 0x7777);
    EXPECT_EQ(kernel(DepthView{nullptr, 64, 8, 128}, b, h.buffer), Status::kNullData);
    EXPECT_EQ(kernel(DepthView{img.data(), 64, 8, 126}, b, h.buffer), Status::kWrongSize);
    EXPECT_EQ(kernel(DepthView{img.data(), 32, 8, 127}, b, h.buffer), Status::kWrongSize);
    EXPECT_EQ(kernel(DepthView{img.data(), 0, 8, 128}, b, h.buffer), Status::kWrongSize);
    EXPECT_EQ(kernel(DepthView{img.data(), 64, 70000, 128}, b, h.buffer),
              Status::kInvalidArgument);  // counts are uint16: refuse, never wrap
    const auto* odd = reinterpret_cast<const std::uint16_t*>(
        reinterpret_cast<const std::uint8_t*>(img.data()) + 1);
    EXPECT_EQ(kernel(DepthView{odd, 32, 4, 128}, b, h.buffer), Status::kWrongSize);
    UMapBuffer small = h.buffer;
    small.capacity = (b.bins + 1) * 64 - 1;
    EXPECT_EQ(kernel(DepthView{img.data(), 64, 8, 128}, b, small), Status::kWrongSize);
    UMapBuffer narrow = h.buffer;
    narrow.stride = 63;
    EXPECT_EQ(kernel(DepthView{img.data(), 64, 8, 128}, b, narrow), Status::kWrongSize);
    EXPECT_EQ(kernel(DepthView{img.data(), 64, 8, 128}, b, UMapBuffer{}), Status::kNullData);
    UMapBinning bad = b;
    bad.multiplier = 0;
    EXPECT_EQ(kernel(DepthView{img.data(), 64, 8, 128}, bad, h.buffer), Status::kInvalidArgument);
    for (std::uint16_t c : h.counts) ASSERT_EQ(c, 0x7777);
  }
}

TEST(UMapHistogram, NoAllocations) {
  const UMapBinning b = binning_or_die(0.1f, 8.f, 0.001f, 120);
  std::vector<std::uint16_t> img(640 * 480, 3000);
  Hist h(b.bins, 640);
  const DepthView view{img.data(), 640, 480, 1280};
  test::AllocationGuard g;
  ASSERT_EQ(umap_histogram_scalar(view, b, h.buffer), Status::kOk);
  ASSERT_EQ(umap_histogram_fast(view, b, h.buffer), Status::kOk);
  EXPECT_EQ(g.allocations(), 0u);
}

}  // namespace
}  // namespace dynamap
