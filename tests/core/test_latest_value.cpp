#include "dynamap/core/latest_value.hpp"

#include <array>
#include <cstdint>
#include <cstdlib>
#include <memory>
#include <thread>

#include <gtest/gtest.h>

#include "alloc_guard.hpp"

namespace dynamap {
namespace {

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

struct Snapshot {
  std::uint64_t id = 0;
  std::array<std::uint64_t, 31> words{};  // all derived from id: a torn read breaks the relation
};

void fill(Snapshot& s, std::uint64_t id) {
  s.id = id;
  for (std::size_t k = 0; k < s.words.size(); ++k) s.words[k] = id * 0x9E3779B97F4A7C15ull + k;
}
bool consistent(const Snapshot& s) {
  for (std::size_t k = 0; k < s.words.size(); ++k) {
    if (s.words[k] != s.id * 0x9E3779B97F4A7C15ull + k) return false;
  }
  return true;
}

TEST(LatestValue, NothingPublishedYet) {
  LatestValue<int> lv;
  EXPECT_FALSE(lv.update());
  EXPECT_EQ(lv.read_buffer(), 0);
  EXPECT_EQ(lv.read_sequence(), 0u);
  EXPECT_EQ(lv.publish_count(), 0u);
}

TEST(LatestValue, ReaderTakesEachPublishOnce) {
  LatestValue<int> lv;
  lv.write_buffer() = 10;
  lv.publish();
  EXPECT_EQ(lv.publish_count(), 1u);
  EXPECT_TRUE(lv.update());
  EXPECT_EQ(lv.read_buffer(), 10);
  EXPECT_EQ(lv.read_sequence(), 1u);
  EXPECT_FALSE(lv.update());  // nothing newer
  EXPECT_EQ(lv.read_buffer(), 10);

  lv.write_buffer() = 20;
  lv.publish();
  EXPECT_TRUE(lv.update());
  EXPECT_EQ(lv.read_buffer(), 20);
  EXPECT_EQ(lv.read_sequence(), 2u);
}

TEST(LatestValue, NewestSnapshotWins) {
  LatestValue<int> lv;
  for (int v = 1; v <= 5; ++v) {
    lv.write_buffer() = v;
    lv.publish();
  }
  EXPECT_TRUE(lv.update());
  EXPECT_EQ(lv.read_buffer(), 5);
  EXPECT_EQ(lv.read_sequence(), 5u);
  EXPECT_FALSE(lv.update());
  EXPECT_EQ(lv.publish_count(), 5u);
}

TEST(LatestValue, WriterAndReaderNeverShareABuffer) {
  LatestValue<int> lv;
  for (int step = 0; step < 50; ++step) {
    ASSERT_NE(&lv.write_buffer(), &lv.read_buffer());
    lv.write_buffer() = step;
    if (step % 3 != 2) lv.publish();
    ASSERT_NE(&lv.write_buffer(), &lv.read_buffer());
    if (step % 2 == 0) (void)lv.update();
    // What the reader holds is never modified behind its back.
    const int held = lv.read_buffer();
    lv.write_buffer() = -1;
    ASSERT_EQ(lv.read_buffer(), held);
  }
}

TEST(LatestValue, NoAllocationsOnPublishOrUpdate) {
  auto lv = std::make_unique<LatestValue<Snapshot>>();
  test::AllocationGuard guard;
  for (std::uint64_t i = 1; i <= 100; ++i) {
    fill(lv->write_buffer(), i);
    lv->publish();
    if (i % 3 == 0) (void)lv->update();
  }
  EXPECT_EQ(guard.allocations(), 0u);
  EXPECT_EQ(lv->read_buffer().id, 99u);
  EXPECT_TRUE(consistent(lv->read_buffer()));
}

TEST(LatestValueThreads, ReaderSeesWholeMonotonicSnapshots) {
  const std::uint64_t n = stress_items(1'000'000);
  auto lv = std::make_unique<LatestValue<Snapshot>>();
  std::thread writer([&] {
    for (std::uint64_t i = 1; i <= n; ++i) {
      fill(lv->write_buffer(), i);
      lv->publish();
      if (i % 64 == 0) std::this_thread::yield();  // give the reader chances on a busy machine
    }
  });
  std::uint64_t last = 0;
  std::uint64_t taken = 0;
  std::uint64_t torn = 0;
  std::uint64_t backwards = 0;
  std::uint64_t seq_mismatch = 0;
  while (last < n) {
    if (!lv->update()) {
      std::this_thread::yield();
      continue;
    }
    const Snapshot& s = lv->read_buffer();
    ++taken;
    if (!consistent(s)) ++torn;
    if (s.id <= last) ++backwards;
    if (lv->read_sequence() != s.id) ++seq_mismatch;
    last = s.id;
  }
  writer.join();
  EXPECT_EQ(torn, 0u);
  EXPECT_EQ(backwards, 0u);
  EXPECT_EQ(seq_mismatch, 0u);
  EXPECT_EQ(last, n);
  EXPECT_GT(taken, 0u);
  EXPECT_EQ(lv->publish_count(), n);
  EXPECT_FALSE(lv->update());
}

}  // namespace
}  // namespace dynamap
