#include <gtest/gtest.h>

#include <memory>

#include "alloc_guard.hpp"
#include "dynamap/map/clean_history.hpp"

namespace dynamap {
namespace {

constexpr Stamp kSecond = 1'000'000'000ULL;

TEST(CleanHistory, RemembersKeysAndServesTheLookupThunk) {
  auto h = std::make_unique<CleanHistory>();
  ASSERT_EQ(h->init(3 * kSecond), Status::kOk);
  h->insert(42, kSecond);
  h->insert(7, kSecond);
  EXPECT_TRUE(h->contains(42));
  EXPECT_TRUE(h->contains(7));
  EXPECT_FALSE(h->contains(8));
  // The {ctx, fn} form the map refiner calls.
  bool (*fn)(const void*, std::uint64_t) noexcept = &CleanHistory::contains_thunk;
  const void* ctx = h.get();
  EXPECT_TRUE(fn(ctx, 42));
  EXPECT_FALSE(fn(ctx, 43));
  h->insert(42, 2 * kSecond);  // refresh, not a second copy
  EXPECT_EQ(h->size(), 2u);
}

TEST(CleanHistory, EvictsTheOldestWhenFull) {
  BasicCleanHistory<8> h;
  ASSERT_EQ(h.init(0), Status::kOk);  // no aging: only capacity limits it
  for (std::uint64_t k = 0; k < 8; ++k) h.insert(100 + k, k + 1);
  EXPECT_EQ(h.size(), 8u);
  h.insert(200, 9);
  EXPECT_EQ(h.size(), 8u);
  EXPECT_FALSE(h.contains(100));  // the oldest went
  for (std::uint64_t k = 1; k < 8; ++k) EXPECT_TRUE(h.contains(100 + k)) << k;
  EXPECT_TRUE(h.contains(200));
  // Refreshing 101 makes it young again: when 201 needs room, 101 gets a second chance and
  // 102 goes; 202 then pushes out 103.
  h.insert(101, 10);
  h.insert(201, 11);
  h.insert(202, 12);
  EXPECT_TRUE(h.contains(101));
  EXPECT_FALSE(h.contains(102));
  EXPECT_FALSE(h.contains(103));
  EXPECT_TRUE(h.contains(104));
  EXPECT_EQ(h.size(), 8u);
}

TEST(CleanHistory, EntriesExpireAfterMaxAge) {
  BasicCleanHistory<64> h;
  ASSERT_EQ(h.init(2 * kSecond), Status::kOk);
  h.insert(1, 1 * kSecond);
  h.insert(2, 2 * kSecond);
  EXPECT_EQ(h.expire(3 * kSecond), 0u);
  EXPECT_TRUE(h.contains(1));
  // At t = 3.5 s key 1 (1.0 s) is too old; lookups already ignore it before it is purged.
  h.insert(3, 3 * kSecond + kSecond / 2);
  EXPECT_FALSE(h.contains(1));
  EXPECT_TRUE(h.contains(2));
  EXPECT_EQ(h.size(), 3u);
  EXPECT_EQ(h.expire(3 * kSecond + kSecond / 2), 1u);
  EXPECT_EQ(h.size(), 2u);
  // Purging is bounded per call.
  for (std::uint64_t k = 10; k < 30; ++k) h.insert(k, 4 * kSecond);
  EXPECT_EQ(h.expire(10 * kSecond, 5), 5u);
  EXPECT_EQ(h.expire(10 * kSecond), 17u);
  EXPECT_EQ(h.size(), 0u);
}

TEST(CleanHistory, NeverGrowsBeyondCapacityAndDoesNotAllocate) {
  auto h = std::make_unique<BasicCleanHistory<1024>>();
  ASSERT_EQ(h->init(0), Status::kOk);
  test::AllocationGuard guard;
  for (std::uint64_t k = 0; k < 100000; ++k) {
    h->insert(k * 2654435761ULL, k);
    if (k % 3 == 0) h->insert((k / 2) * 2654435761ULL, k);  // refreshes
  }
  EXPECT_EQ(guard.allocations(), 0u);
  EXPECT_LE(h->size(), 1024u);
  EXPECT_TRUE(h->contains(99999 * 2654435761ULL));
  EXPECT_FALSE(h->contains(0));
}

}  // namespace
}  // namespace dynamap
