#include "dynamap/pipeline/stage_timing.hpp"

namespace dynamap {

void StageStats::reset() noexcept {
  count_ = 0;
  sum_ns_ = 0;
  min_ns_ = UINT64_MAX;
  max_ns_ = 0;
  overruns_ = 0;
  buckets_.fill(0);
}

std::uint64_t StageStats::bucket_lower_ns(std::size_t index) noexcept {
  if (index < 2 * kSubBuckets) return index;
  if (index >= kFiniteBuckets) return kOverflowNs;
  const unsigned e = static_cast<unsigned>(index / kSubBuckets) + kSubBucketBits - 1;
  const std::uint64_t sub = index % kSubBuckets;
  return (kSubBuckets + sub) << (e - kSubBucketBits);
}

std::uint64_t StageStats::bucket_upper_ns(std::size_t index) noexcept {
  if (index < 2 * kSubBuckets) return index;
  if (index >= kFiniteBuckets) return UINT64_MAX;
  const unsigned e = static_cast<unsigned>(index / kSubBuckets) + kSubBucketBits - 1;
  return bucket_lower_ns(index) + (std::uint64_t{1} << (e - kSubBucketBits)) - 1;
}

std::uint64_t StageStats::percentile_ns(std::uint32_t per_mille) const noexcept {
  if (count_ == 0) return 0;
  if (per_mille < 1) per_mille = 1;
  if (per_mille > 1000) per_mille = 1000;
  // Nearest rank k = ceil(per_mille * n / 1000), in integers so 900 of 10 is exactly 9.
  const std::uint64_t rank = (per_mille * count_ + 999) / 1000;
  // The extreme ranks are known exactly.
  if (rank <= 1) return min_ns_;
  if (rank >= count_) return max_ns_;
  std::uint64_t seen = 0;
  std::size_t index = 0;
  for (; index < kBucketCount; ++index) {
    seen += buckets_[index];
    if (seen >= rank) break;
  }
  if (index >= kFiniteBuckets) return max_ns_;  // overflow bucket: only max is known
  const std::uint64_t lo = bucket_lower_ns(index);
  const std::uint64_t hi = bucket_upper_ns(index);
  std::uint64_t estimate = lo + (hi - lo) / 2;
  if (estimate < min_ns_) estimate = min_ns_;
  if (estimate > max_ns_) estimate = max_ns_;
  return estimate;
}

StageSummary StageStats::summary() const noexcept {
  StageSummary s;
  s.count = count_;
  s.min_ns = min_ns();
  s.max_ns = max_ns_;
  s.mean_ns = mean_ns();
  s.p50_ns = p50_ns();
  s.p90_ns = p90_ns();
  s.p99_ns = p99_ns();
  s.budget_ns = budget_ns_;
  s.overruns = overruns_;
  return s;
}

}  // namespace dynamap
