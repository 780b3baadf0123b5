#include "dynamap/core/spsc_ring.hpp"

#include <array>
#include <cstdint>
#include <cstdlib>
#include <memory>
#include <thread>

#include <gtest/gtest.h>

#include "alloc_guard.hpp"

namespace dynamap {
namespace {

// Items for the two-thread stress tests: >= 1 million natively, a quarter under TSan
// or what DYNAMAP_STRESS_ITEMS says (e.g. on a slow emulator; qemu-aarch64 runs the full count
// in about a second here, so nothing sets it by default).
std::uint64_t stress_items(std::uint64_t native) {
  if (const char* env = std::getenv("DYNAMAP_STRESS_ITEMS")) {
    const unsigned long long v = std::strtoull(env, nullptr, 10);
    if (v > 0) return v;
  }
#if defined(__SANITIZE_THREAD__)
  return native / 4;
#elif defined(__has_feature)
#if __has_feature(thread_sanitizer)
  return native / 4;
#endif
#endif
  return native;
}

TEST(SpscRing, LayoutKeepsIndicesOnSeparateCacheLines) {
  EXPECT_EQ(alignof(SpscRing<std::uint64_t, 8>) % kCacheLine, 0u);
  // head, producer state, tail, consumer state: at least one line each, plus the slots.
  EXPECT_GE(sizeof(SpscRing<std::uint64_t, 8>), 4 * kCacheLine + 8 * sizeof(std::uint64_t));
  EXPECT_EQ((SpscRing<std::uint64_t, 8>::capacity()), 8u);
}

TEST(SpscRing, EmptyRingRejectsPop) {
  SpscRing<int, 4> ring;
  int out = 42;
  EXPECT_EQ(ring.try_pop(out), Status::kEmpty);
  EXPECT_EQ(out, 42);  // untouched
  EXPECT_EQ(ring.try_front(), nullptr);
  EXPECT_TRUE(ring.empty_approx());
  EXPECT_EQ(ring.size_approx(), 0u);
  EXPECT_EQ(ring.drops(), 0u);
}

TEST(SpscRing, FullRingRejectsPushAndCountsDrops) {
  SpscRing<int, 4> ring;
  for (int i = 0; i < 4; ++i) ASSERT_EQ(ring.try_push(i), Status::kOk);
  EXPECT_EQ(ring.size_approx(), 4u);
  EXPECT_EQ(ring.try_push(100), Status::kCapacityExceeded);
  EXPECT_EQ(ring.try_push(101), Status::kCapacityExceeded);
  EXPECT_EQ(ring.try_begin_push(), nullptr);
  EXPECT_EQ(ring.drops(), 3u);
  // The rejected values did not overwrite anything: FIFO order is intact.
  for (int i = 0; i < 4; ++i) {
    int out = -1;
    ASSERT_EQ(ring.try_pop(out), Status::kOk);
    EXPECT_EQ(out, i);
  }
  int out = -1;
  EXPECT_EQ(ring.try_pop(out), Status::kEmpty);
  // Space again after popping.
  EXPECT_EQ(ring.try_push(7), Status::kOk);
  EXPECT_EQ(ring.drops(), 3u);
}

TEST(SpscRing, WrapsAroundManyTimesInOrder) {
  SpscRing<std::uint32_t, 4> ring;
  std::uint32_t next_in = 0;
  std::uint32_t next_out = 0;
  // Varying occupancy (1..4) so the indices cross the end of the storage at every offset.
  for (int round = 0; round < 10000; ++round) {
    const int burst = 1 + round % 4;
    for (int i = 0; i < burst; ++i) ASSERT_EQ(ring.try_push(next_in++), Status::kOk);
    for (int i = 0; i < burst; ++i) {
      std::uint32_t out = 0;
      ASSERT_EQ(ring.try_pop(out), Status::kOk);
      ASSERT_EQ(out, next_out++);
    }
    ASSERT_EQ(ring.size_approx(), 0u);
  }
  EXPECT_EQ(next_out, next_in);
  EXPECT_EQ(ring.drops(), 0u);
}

TEST(SpscRing, InterleavedPushPopKeepsFifoAcrossWrap) {
  SpscRing<int, 8> ring;
  int next_in = 0;
  int next_out = 0;
  for (int i = 0; i < 5; ++i) ASSERT_EQ(ring.try_push(next_in++), Status::kOk);
  for (int step = 0; step < 1000; ++step) {  // always 5 or 6 in flight
    ASSERT_EQ(ring.try_push(next_in++), Status::kOk);
    int out = -1;
    ASSERT_EQ(ring.try_pop(out), Status::kOk);
    ASSERT_EQ(out, next_out++);
  }
  EXPECT_EQ(ring.size_approx(), 5u);
}

struct BigFrame {
  std::uint64_t seq = 0;
  std::array<std::uint16_t, 640 * 48> pixels{};
};

TEST(SpscRing, SlotApiFillsAndReadsInPlace) {
  auto ring = std::make_unique<SpscRing<BigFrame, 2>>();  // large: never on the stack
  BigFrame* slot = ring->try_begin_push();
  ASSERT_NE(slot, nullptr);
  EXPECT_EQ(ring->try_begin_push(), slot);  // same slot until committed
  EXPECT_EQ(ring->try_front(), nullptr);    // not visible before commit
  slot->seq = 1;
  slot->pixels.fill(111);
  ring->commit_push();

  BigFrame* slot2 = ring->try_begin_push();
  ASSERT_NE(slot2, nullptr);
  EXPECT_NE(slot2, slot);
  slot2->seq = 2;
  slot2->pixels.fill(222);
  ring->commit_push();

  EXPECT_EQ(ring->try_begin_push(), nullptr);  // full: counted as a drop
  EXPECT_EQ(ring->drops(), 1u);

  const BigFrame* front = ring->try_front();
  ASSERT_NE(front, nullptr);
  EXPECT_EQ(front, slot);  // read in place, no copy
  EXPECT_EQ(front->seq, 1u);
  EXPECT_EQ(front->pixels[0], 111);
  EXPECT_EQ(front->pixels.back(), 111);
  EXPECT_EQ(ring->try_front(), front);  // stays until popped
  ring->pop_front();

  front = ring->try_front();
  ASSERT_NE(front, nullptr);
  EXPECT_EQ(front->seq, 2u);
  EXPECT_EQ(front->pixels[100], 222);
  ring->pop_front();
  EXPECT_EQ(ring->try_front(), nullptr);

  // The freed slot is reused.
  EXPECT_EQ(ring->try_begin_push(), slot);
}

TEST(SpscRing, NoAllocationsOnPushPopOrSlots) {
  auto ring = std::make_unique<SpscRing<BigFrame, 4>>();
  SpscRing<std::uint64_t, 16> small;
  test::AllocationGuard guard;
  for (std::uint64_t i = 0; i < 100; ++i) {
    (void)small.try_push(i);
    std::uint64_t out = 0;
    (void)small.try_pop(out);
    BigFrame* slot = ring->try_begin_push();
    if (slot != nullptr) {
      slot->seq = i;
      ring->commit_push();
    }
    if (i % 2 == 0 && ring->try_front() != nullptr) ring->pop_front();
  }
  EXPECT_GT(ring->drops(), 0u);  // the slow consumer above made the ring overflow
  EXPECT_EQ(guard.allocations(), 0u);
  EXPECT_EQ(guard.deallocations(), 0u);
}

TEST(SpscRingThreads, MillionsOfItemsArriveInOrder) {
  const std::uint64_t n = stress_items(4'000'000);
  SpscRing<std::uint64_t, 1024> ring;
  std::uint64_t producer_rejects = 0;
  std::thread producer([&] {
    for (std::uint64_t i = 0; i < n;) {
      if (ring.try_push(i) == Status::kOk) {
        ++i;
      } else {
        ++producer_rejects;
        std::this_thread::yield();  // the machine has few cores; let the consumer run
      }
    }
  });
  std::uint64_t expected = 0;
  std::uint64_t mismatches = 0;
  while (expected < n) {
    std::uint64_t v = 0;
    if (ring.try_pop(v) == Status::kOk) {
      if (v != expected) ++mismatches;
      ++expected;
    } else {
      std::this_thread::yield();
    }
  }
  producer.join();
  EXPECT_EQ(mismatches, 0u);
  EXPECT_EQ(expected, n);
  EXPECT_EQ(ring.drops(), producer_rejects);  // every rejected push was counted, no more
  std::uint64_t v = 0;
  EXPECT_EQ(ring.try_pop(v), Status::kEmpty);
}

struct Chunk {
  std::uint64_t seq = 0;
  std::array<std::uint32_t, 126> words{};
};

TEST(SpscRingThreads, SlotApiNeverShowsPartialElements) {
  const std::uint64_t n = stress_items(400'000);
  auto ring = std::make_unique<SpscRing<Chunk, 8>>();
  std::thread producer([&] {
    for (std::uint64_t i = 0; i < n;) {
      Chunk* slot = ring->try_begin_push();
      if (slot == nullptr) {
        std::this_thread::yield();
        continue;
      }
      slot->seq = i;
      for (std::size_t k = 0; k < slot->words.size(); ++k) {
        slot->words[k] = static_cast<std::uint32_t>(i * 2654435761u + k);
      }
      ring->commit_push();
      ++i;
    }
  });
  std::uint64_t expected = 0;
  std::uint64_t bad = 0;
  while (expected < n) {
    const Chunk* c = ring->try_front();
    if (c == nullptr) {
      std::this_thread::yield();
      continue;
    }
    if (c->seq != expected) ++bad;
    for (std::size_t k = 0; k < c->words.size(); ++k) {
      if (c->words[k] != static_cast<std::uint32_t>(expected * 2654435761u + k)) ++bad;
    }
    ring->pop_front();
    ++expected;
  }
  producer.join();
  EXPECT_EQ(bad, 0u);
}

}  // namespace
}  // namespace dynamap
