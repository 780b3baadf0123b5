// Per-stage timing statistics in fixed storage: count, min, max, mean, p50/p90/p99 from a
// log-scale histogram, and a time budget with an overrun counter that a caller's timing test can
// assert on. ScopedStageTimer measures one scope with an injectable clock.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>

#include "dynamap/platform/clock.hpp"

namespace dynamap {

/// A snapshot of one stage's statistics; small and copyable (goes into output snapshots).
struct StageSummary {
  std::uint64_t count = 0;
  std::uint64_t min_ns = 0;
  std::uint64_t max_ns = 0;
  double mean_ns = 0.0;
  std::uint64_t p50_ns = 0;
  std::uint64_t p90_ns = 0;
  std::uint64_t p99_ns = 0;
  std::uint64_t budget_ns = 0;  // 0 = no budget
  std::uint64_t overruns = 0;
};

/// Timing statistics of one stage, ~2 KB, no allocation ever. Single writer: record() from the
/// thread that runs the stage; copy summary() into an output snapshot for other threads.
///
/// Histogram: values below 16 ns get one bucket each; above, every power of two [2^e, 2^(e+1))
/// is split into 8 equal sub-buckets, up to 2^32 ns (~4.29 s); longer times share one overflow
/// bucket. A percentile is reported as the middle of the bucket that holds the nearest-rank
/// sample, clamped to [min, max], so it is within 1/16 (6.25 %) of the exact nearest-rank value
/// (exact below 16 ns). The first and last ranks return min and max exactly; other
/// overflow-bucket percentiles report max.
class StageStats {
 public:
  static constexpr unsigned kSubBucketBits = 3;  // 8 sub-buckets per octave
  static constexpr std::uint64_t kSubBuckets = 1u << kSubBucketBits;
  static constexpr unsigned kMaxExponent = 31;  // last finite octave: [2^31, 2^32) ns
  static constexpr std::size_t kFiniteBuckets =
      (kMaxExponent - kSubBucketBits + 2) * kSubBuckets;           // 240
  static constexpr std::size_t kBucketCount = kFiniteBuckets + 1;  // + overflow
  static constexpr std::uint64_t kOverflowNs = std::uint64_t{1} << (kMaxExponent + 1);

  /// Adds one measurement. O(1), branch-light, no allocation.
  void record(std::uint64_t ns) noexcept {
    ++count_;
    sum_ns_ += ns;
    if (ns < min_ns_) min_ns_ = ns;
    if (ns > max_ns_) max_ns_ = ns;
    if (budget_ns_ != 0 && ns > budget_ns_) ++overruns_;
    ++buckets_[bucket_index(ns)];
  }

  /// Budget for one run of the stage; every record() above it counts an overrun. 0 disables.
  void set_budget_ns(std::uint64_t budget_ns) noexcept { budget_ns_ = budget_ns; }
  std::uint64_t budget_ns() const noexcept { return budget_ns_; }
  std::uint64_t overruns() const noexcept { return overruns_; }

  /// Clears all measurements and overruns; keeps the budget.
  void reset() noexcept;

  std::uint64_t count() const noexcept { return count_; }
  std::uint64_t min_ns() const noexcept { return count_ == 0 ? 0 : min_ns_; }
  std::uint64_t max_ns() const noexcept { return max_ns_; }
  double mean_ns() const noexcept {
    return count_ == 0 ? 0.0 : static_cast<double>(sum_ns_) / static_cast<double>(count_);
  }

  /// Nearest-rank percentile estimate: per_mille in [1, 1000] (500 = median, 990 = p99).
  /// 0 when nothing was recorded. Integer ranks, so p90 of 10 samples is exactly the 9th.
  std::uint64_t percentile_ns(std::uint32_t per_mille) const noexcept;
  std::uint64_t p50_ns() const noexcept { return percentile_ns(500); }
  std::uint64_t p90_ns() const noexcept { return percentile_ns(900); }
  std::uint64_t p99_ns() const noexcept { return percentile_ns(990); }

  StageSummary summary() const noexcept;

  /// Histogram bucket of a duration, and the inclusive range [lower, upper] a bucket covers.
  static std::size_t bucket_index(std::uint64_t ns) noexcept {
    if (ns < 2 * kSubBuckets) return static_cast<std::size_t>(ns);
    if (ns >= kOverflowNs) return kFiniteBuckets;
    const unsigned e = highest_bit(ns);
    return static_cast<std::size_t>((e - kSubBucketBits + 1) * kSubBuckets +
                                    ((ns >> (e - kSubBucketBits)) & (kSubBuckets - 1)));
  }
  static std::uint64_t bucket_lower_ns(std::size_t index) noexcept;
  static std::uint64_t bucket_upper_ns(std::size_t index) noexcept;

 private:
  static unsigned highest_bit(std::uint64_t v) noexcept {
#if defined(__GNUC__) || defined(__clang__)
    return 63u - static_cast<unsigned>(__builtin_clzll(v));
#else
    unsigned e = 0;
    while (v >>= 1) ++e;
    return e;
#endif
  }

  std::uint64_t count_ = 0;
  std::uint64_t sum_ns_ = 0;
  std::uint64_t min_ns_ = UINT64_MAX;
  std::uint64_t max_ns_ = 0;
  std::uint64_t budget_ns_ = 0;
  std::uint64_t overruns_ = 0;
  std::array<std::uint64_t, kBucketCount> buckets_{};
};

/// Clock the timer reads: nanoseconds from any monotonic source. Tests pass a fake clock.
using StageClock = std::uint64_t (*)();

/// Records the time from construction to destruction (or to stop()) into a StageStats.
/// Two clock reads and one record(); a clock that steps backwards records 0.
class ScopedStageTimer {
 public:
  explicit ScopedStageTimer(StageStats& stats, StageClock clock = &platform::monotonic_ns) noexcept
      : stats_(&stats), clock_(clock), start_ns_(clock()) {}
  ~ScopedStageTimer() { (void)stop(); }
  ScopedStageTimer(const ScopedStageTimer&) = delete;
  ScopedStageTimer& operator=(const ScopedStageTimer&) = delete;

  /// Records now and returns the elapsed ns; later calls (and the destructor) do nothing and
  /// return 0.
  std::uint64_t stop() noexcept {
    if (stats_ == nullptr) return 0;
    const std::uint64_t now = clock_();
    const std::uint64_t elapsed = now > start_ns_ ? now - start_ns_ : 0;
    stats_->record(elapsed);
    stats_ = nullptr;
    return elapsed;
  }

 private:
  StageStats* stats_;
  StageClock clock_;
  std::uint64_t start_ns_;
};

}  // namespace dynamap
