#include <cstdlib>
#include <memory>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "alloc_guard.hpp"

namespace dynamap {
namespace {

// Makes a pointer escape so the optimiser cannot elide a new/delete pair (clang does).
void escape(void* p) {
  asm volatile("" : : "r"(p) : "memory");
}

TEST(AllocationGuard, CatchesVectorGrowth) {
  std::vector<int> v;
  test::AllocationGuard guard;
  for (int i = 0; i < 100; ++i) v.push_back(i);
  EXPECT_GT(guard.allocations(), 0u);
  EXPECT_GT(guard.deallocations(), 0u);  // growth frees the old buffer
}

TEST(AllocationGuard, CountsNothingWhenNothingAllocates) {
  int x = 0;
  test::AllocationGuard guard;
  for (int i = 0; i < 100; ++i) x += i;
  EXPECT_EQ(x, 4950);
  EXPECT_EQ(guard.allocations(), 0u);
}

TEST(AllocationGuard, CatchesMallocWhereCounted) {
  if (!test::malloc_is_counted()) GTEST_SKIP() << "sanitizer build: only new/delete are counted";
  test::AllocationGuard guard;
  void* volatile p = std::malloc(32);  // volatile: the optimiser may not elide the pair
  std::free(p);
  EXPECT_EQ(guard.allocations(), 1u);
  // glibc may release internal buffers through the public free() as well (seen under qemu).
  EXPECT_GE(guard.deallocations(), 1u);
}

TEST(AllocationGuard, IgnoresOtherThreads) {
  test::AllocationGuard guard;
  const std::size_t before = guard.allocations();  // std::thread itself allocates its state
  std::thread t([] {
    auto p = std::make_unique<int[]>(1000);
    escape(p.get());
  });
  t.join();
  // The worker's 1000-int allocation is not ours; only the thread object's own state may be.
  EXPECT_LE(guard.allocations() - before, 2u);
}

TEST(AllocationGuard, NestedGuardsBothCount) {
  test::AllocationGuard outer;
  std::size_t inner_count = 0;
  {
    test::AllocationGuard inner;
    auto p = std::make_unique<int>(3);
    escape(p.get());
    inner_count = inner.allocations();
  }
  const std::size_t outer_count = outer.allocations();  // read before any assertion allocates
  EXPECT_EQ(inner_count, 1u);
  EXPECT_EQ(outer_count, 1u);
}

}  // namespace
}  // namespace dynamap
