#include <cstdint>
#include <random>
#include <unordered_map>

#include <gtest/gtest.h>

#include "alloc_guard.hpp"
#include "dynamap/core/fixed_hash_map.hpp"

namespace dynamap {
namespace {

TEST(FixedHashMap, InsertFindOverwriteErase) {
  FixedHashMap<std::uint64_t, int, 16> m;
  EXPECT_EQ(m.insert_or_assign(5, 50), Status::kOk);
  EXPECT_EQ(m.insert_or_assign(7, 70), Status::kOk);
  ASSERT_NE(m.find(5), nullptr);
  EXPECT_EQ(*m.find(5), 50);
  EXPECT_EQ(m.insert_or_assign(5, 55), Status::kOk);
  EXPECT_EQ(*m.find(5), 55);
  EXPECT_EQ(m.size(), 2u);
  EXPECT_TRUE(m.erase(5));
  EXPECT_FALSE(m.erase(5));
  EXPECT_EQ(m.find(5), nullptr);
  EXPECT_EQ(m.size(), 1u);
}

TEST(FixedHashMap, RefusesAboveMaxLoadAndKeepsContents) {
  FixedHashMap<std::uint64_t, int, 8> m;
  const std::size_t limit = m.max_load();
  for (std::uint64_t k = 0; k < limit; ++k) ASSERT_EQ(m.insert_or_assign(k, int(k)), Status::kOk);
  EXPECT_EQ(m.insert_or_assign(1000, 1), Status::kCapacityExceeded);
  EXPECT_EQ(m.size(), limit);
  EXPECT_EQ(m.insert_or_assign(3, 33), Status::kOk);  // existing key still assignable when full
  EXPECT_EQ(*m.find(3), 33);
  EXPECT_FALSE(m.contains(1000));
}

// Colliding keys all hash to the same home slot; deleting from the middle of the chain must keep
// the rest reachable (backward shift), including across the wrap-around at the table's end.
struct ConstantHash {
  std::uint64_t operator()(std::uint64_t) const noexcept { return 6; }
};
TEST(FixedHashMap, BackwardShiftKeepsChainsReachableAcrossWrap) {
  FixedHashMap<std::uint64_t, int, 8, ConstantHash> m;
  for (std::uint64_t k = 1; k <= 5; ++k) ASSERT_EQ(m.insert_or_assign(k, int(k)), Status::kOk);
  EXPECT_TRUE(m.erase(2));
  for (std::uint64_t k : {1u, 3u, 4u, 5u}) {
    ASSERT_NE(m.find(k), nullptr) << k;
    EXPECT_EQ(*m.find(k), int(k));
  }
  EXPECT_TRUE(m.erase(1));
  EXPECT_TRUE(m.erase(5));
  EXPECT_EQ(*m.find(3), 3);
  EXPECT_EQ(*m.find(4), 4);
  EXPECT_EQ(m.size(), 2u);
}

TEST(FixedHashMap, RandomisedAgainstStdUnorderedMap) {
  FixedHashMap<std::uint64_t, std::uint32_t, 1024> m;
  std::unordered_map<std::uint64_t, std::uint32_t> ref;
  std::mt19937_64 rng(42);
  for (int step = 0; step < 200000; ++step) {
    const std::uint64_t key = rng() % 1500;
    const int op = int(rng() % 3);
    if (op == 0) {
      const auto val = static_cast<std::uint32_t>(rng());
      const Status s = m.insert_or_assign(key, val);
      if (s == Status::kOk) {
        ref[key] = val;
      } else {
        EXPECT_EQ(ref.count(key), 0u);
      }
    } else if (op == 1) {
      EXPECT_EQ(m.erase(key), ref.erase(key) == 1);
    } else {
      const auto* v = m.find(key);
      auto it = ref.find(key);
      ASSERT_EQ(v != nullptr, it != ref.end());
      if (v) {
        EXPECT_EQ(*v, it->second);
      }
    }
    ASSERT_EQ(m.size(), ref.size());
  }
  std::size_t visited = 0;
  m.for_each([&](std::uint64_t k, std::uint32_t v) {
    ++visited;
    EXPECT_EQ(ref.at(k), v);
  });
  EXPECT_EQ(visited, ref.size());
}

TEST(FixedHashSet, InsertContainsEraseWithoutHeap) {
  test::AllocationGuard guard;
  FixedHashSet<std::uint64_t, 64> s;
  EXPECT_EQ(s.insert(9), Status::kOk);
  EXPECT_EQ(s.insert(9), Status::kOk);
  EXPECT_EQ(s.size(), 1u);
  EXPECT_TRUE(s.contains(9));
  EXPECT_TRUE(s.erase(9));
  EXPECT_FALSE(s.contains(9));
  EXPECT_EQ(guard.allocations(), 0u);
}

}  // namespace
}  // namespace dynamap
