#include "dynamap/pipeline/stage_timing.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "alloc_guard.hpp"

namespace dynamap {
namespace {

// Nearest-rank reference: the ceil(per_mille * n / 1000)-th smallest sample.
std::uint64_t reference_percentile(std::vector<std::uint64_t> v, std::uint32_t per_mille) {
  std::sort(v.begin(), v.end());
  const std::uint64_t rank = (per_mille * v.size() + 999) / 1000;
  return v[rank == 0 ? 0 : rank - 1];
}

// The documented bound: within 1/16 of the exact value.
::testing::AssertionResult within_resolution(std::uint64_t estimate, std::uint64_t exact) {
  const std::uint64_t diff = estimate > exact ? estimate - exact : exact - estimate;
  if (diff * 16 <= exact) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure()
         << "estimate " << estimate << " vs exact " << exact << " (diff " << diff << ")";
}

TEST(StageStats, EmptyReportsZeros) {
  StageStats s;
  EXPECT_EQ(s.count(), 0u);
  EXPECT_EQ(s.min_ns(), 0u);
  EXPECT_EQ(s.max_ns(), 0u);
  EXPECT_EQ(s.mean_ns(), 0.0);
  EXPECT_EQ(s.p50_ns(), 0u);
  EXPECT_EQ(s.p99_ns(), 0u);
  EXPECT_EQ(s.overruns(), 0u);
}

TEST(StageStats, CountMinMaxMeanAreExact) {
  StageStats s;
  for (std::uint64_t v : {3000u, 1000u, 2000u, 6000u}) s.record(v);
  EXPECT_EQ(s.count(), 4u);
  EXPECT_EQ(s.min_ns(), 1000u);
  EXPECT_EQ(s.max_ns(), 6000u);
  EXPECT_DOUBLE_EQ(s.mean_ns(), 3000.0);
}

TEST(StageStats, SingleSampleIsExactThroughClamping) {
  StageStats s;
  s.record(123457);
  EXPECT_EQ(s.p50_ns(), 123457u);
  EXPECT_EQ(s.p99_ns(), 123457u);
}

TEST(StageStats, BucketsTileTheRangeWithBoundedWidth) {
  for (std::size_t i = 0; i < StageStats::kFiniteBuckets; ++i) {
    const std::uint64_t lo = StageStats::bucket_lower_ns(i);
    const std::uint64_t hi = StageStats::bucket_upper_ns(i);
    ASSERT_LE(lo, hi) << i;
    ASSERT_EQ(StageStats::bucket_index(lo), i);
    ASSERT_EQ(StageStats::bucket_index(hi), i);
    if (i + 1 < StageStats::kFiniteBuckets) {
      ASSERT_EQ(StageStats::bucket_lower_ns(i + 1), hi + 1);
    }
    if (lo >= 16) {
      ASSERT_LE((hi - lo + 1) * 8, lo) << i;  // width <= lower / 8
    }
  }
  EXPECT_EQ(StageStats::bucket_lower_ns(0), 0u);
  EXPECT_EQ(StageStats::bucket_upper_ns(StageStats::kFiniteBuckets - 1),
            StageStats::kOverflowNs - 1);
  EXPECT_EQ(StageStats::bucket_index(StageStats::kOverflowNs), StageStats::kFiniteBuckets);
  EXPECT_EQ(StageStats::bucket_index(UINT64_MAX), StageStats::kFiniteBuckets);
  // 1 us .. ~4 s is covered by finite buckets.
  EXPECT_LT(StageStats::bucket_index(4'000'000'000ull), StageStats::kFiniteBuckets);
}

TEST(StageStats, PercentilesMatchSortedReferenceWithinResolution) {
  std::mt19937_64 rng(12345);
  // Log-uniform durations from 100 ns to 2 s: every octave of the histogram gets exercised.
  std::uniform_real_distribution<double> log_ns(std::log(100.0), std::log(2e9));
  for (std::size_t n : {1u, 2u, 3u, 10u, 99u, 1000u, 100000u}) {
    StageStats s;
    std::vector<std::uint64_t> samples;
    for (std::size_t i = 0; i < n; ++i) {
      const auto v = static_cast<std::uint64_t>(std::exp(log_ns(rng)));
      samples.push_back(v);
      s.record(v);
    }
    for (std::uint32_t pm : {1u, 100u, 250u, 500u, 900u, 990u, 999u, 1000u}) {
      EXPECT_TRUE(within_resolution(s.percentile_ns(pm), reference_percentile(samples, pm)))
          << "n=" << n << " per_mille=" << pm;
    }
    EXPECT_EQ(s.percentile_ns(1000), *std::max_element(samples.begin(), samples.end()));
  }
}

TEST(StageStats, PercentilesOfTightClusterAreNearlyExact) {
  // A realistic stage: ~2 ms with jitter. Reference vs histogram within 1/16.
  std::mt19937_64 rng(7);
  std::normal_distribution<double> ms(2.0e6, 1.0e5);
  StageStats s;
  std::vector<std::uint64_t> samples;
  for (int i = 0; i < 5000; ++i) {
    const auto v = static_cast<std::uint64_t>(std::max(1.0, ms(rng)));
    samples.push_back(v);
    s.record(v);
  }
  EXPECT_TRUE(within_resolution(s.p50_ns(), reference_percentile(samples, 500)));
  EXPECT_TRUE(within_resolution(s.p90_ns(), reference_percentile(samples, 900)));
  EXPECT_TRUE(within_resolution(s.p99_ns(), reference_percentile(samples, 990)));
  EXPECT_LE(s.p50_ns(), s.p90_ns());
  EXPECT_LE(s.p90_ns(), s.p99_ns());
}

TEST(StageStats, SmallValuesAreExactAndRanksAreIntegers) {
  StageStats s;
  for (std::uint64_t v = 1; v <= 10; ++v) s.record(v);
  EXPECT_EQ(s.p50_ns(), 5u);
  EXPECT_EQ(s.p90_ns(), 9u);  // rank 9 of 10, not 10 (no floating-point round-up)
  EXPECT_EQ(s.p99_ns(), 10u);
}

TEST(StageStats, OverflowBucketReportsMax) {
  StageStats s;
  s.record(1000);
  s.record(10'000'000'000ull);  // 10 s: beyond the finite buckets
  EXPECT_EQ(s.p99_ns(), 10'000'000'000ull);
  EXPECT_EQ(s.p50_ns(), 1000u);
}

TEST(StageStats, BudgetCountsOverrunsAndSurvivesReset) {
  StageStats s;
  s.record(5000);  // no budget yet: no overrun
  s.set_budget_ns(1000);
  s.record(999);
  s.record(1000);  // at the budget is not an overrun
  s.record(1001);
  s.record(50000);
  EXPECT_EQ(s.overruns(), 2u);
  const StageSummary sum = s.summary();
  EXPECT_EQ(sum.overruns, 2u);
  EXPECT_EQ(sum.budget_ns, 1000u);
  EXPECT_EQ(sum.count, 5u);
  EXPECT_EQ(sum.max_ns, 50000u);
  EXPECT_EQ(sum.min_ns, 999u);

  s.reset();
  EXPECT_EQ(s.count(), 0u);
  EXPECT_EQ(s.overruns(), 0u);
  EXPECT_EQ(s.p99_ns(), 0u);
  EXPECT_EQ(s.budget_ns(), 1000u);
  s.record(2000);
  EXPECT_EQ(s.overruns(), 1u);
  EXPECT_EQ(s.min_ns(), 2000u);
}

std::uint64_t g_fake_now = 0;
std::uint64_t fake_clock() {
  return g_fake_now;
}

TEST(ScopedStageTimer, RecordsElapsedTimeFromInjectedClock) {
  StageStats s;
  s.set_budget_ns(1000);
  g_fake_now = 10'000;
  {
    ScopedStageTimer t(s, &fake_clock);
    g_fake_now += 750;
  }
  {
    ScopedStageTimer t(s, &fake_clock);
    g_fake_now += 1500;
  }
  EXPECT_EQ(s.count(), 2u);
  EXPECT_EQ(s.min_ns(), 750u);
  EXPECT_EQ(s.max_ns(), 1500u);
  EXPECT_EQ(s.overruns(), 1u);
}

TEST(ScopedStageTimer, StopRecordsOnceAndBackwardsClockRecordsZero) {
  StageStats s;
  g_fake_now = 5000;
  {
    ScopedStageTimer t(s, &fake_clock);
    g_fake_now += 42;
    EXPECT_EQ(t.stop(), 42u);
    g_fake_now += 1000;
    EXPECT_EQ(t.stop(), 0u);
  }  // destructor must not record again
  EXPECT_EQ(s.count(), 1u);
  EXPECT_EQ(s.max_ns(), 42u);
  {
    ScopedStageTimer t(s, &fake_clock);
    g_fake_now -= 100;
  }
  EXPECT_EQ(s.count(), 2u);
  EXPECT_EQ(s.min_ns(), 0u);
}

TEST(ScopedStageTimer, DefaultClockIsMonotonicPlatformClock) {
  StageStats s;
  { ScopedStageTimer t(s); }
  EXPECT_EQ(s.count(), 1u);
  EXPECT_LT(s.max_ns(), 1'000'000'000u);  // a sanity bound, not a timing goal
}

TEST(StageStats, NoAllocationsOnRecordOrTimer) {
  StageStats s;
  s.set_budget_ns(100);
  test::AllocationGuard guard;
  for (std::uint64_t i = 0; i < 10000; ++i) s.record(i * 977);
  { ScopedStageTimer t(s, &fake_clock); }
  const StageSummary sum = s.summary();
  EXPECT_EQ(guard.allocations(), 0u);
  EXPECT_EQ(sum.count, 10001u);
}

}  // namespace
}  // namespace dynamap
