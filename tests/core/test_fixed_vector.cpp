#include <gtest/gtest.h>

#include "alloc_guard.hpp"
#include "dynamap/core/fixed_vector.hpp"

namespace dynamap {
namespace {

TEST(FixedVector, PushUntilFullThenRefuses) {
  FixedVector<int, 3> v;
  EXPECT_TRUE(v.empty());
  EXPECT_EQ(v.push_back(1), Status::kOk);
  EXPECT_EQ(v.push_back(2), Status::kOk);
  EXPECT_EQ(v.push_back(3), Status::kOk);
  EXPECT_TRUE(v.full());
  EXPECT_EQ(v.push_back(4), Status::kCapacityExceeded);
  EXPECT_EQ(v.size(), 3u);
  EXPECT_EQ(v.back(), 3);
  EXPECT_EQ(v.emplace_back(), nullptr);
}

TEST(FixedVector, SwapEraseAndClear) {
  FixedVector<int, 4> v;
  for (int i = 0; i < 4; ++i) ASSERT_EQ(v.push_back(i), Status::kOk);
  v.swap_erase(1);
  ASSERT_EQ(v.size(), 3u);
  EXPECT_EQ(v[1], 3);
  volatile std::size_t out_of_range = 7;  // opaque, so GCC does not warn on the dead path
  v.swap_erase(out_of_range);             // no-op
  EXPECT_EQ(v.size(), 3u);
  int sum = 0;
  for (int x : v) sum += x;
  EXPECT_EQ(sum, 0 + 3 + 2);
  v.pop_back();
  v.clear();
  EXPECT_TRUE(v.empty());
  v.pop_back();  // on empty: no-op
  EXPECT_TRUE(v.empty());
}

TEST(FixedVector, NeverAllocates) {
  test::AllocationGuard guard;
  FixedVector<double, 64> v;
  for (int i = 0; i < 100; ++i) (void)v.push_back(i);
  EXPECT_EQ(v.size(), 64u);
  EXPECT_EQ(guard.allocations(), 0u);
}

}  // namespace
}  // namespace dynamap
