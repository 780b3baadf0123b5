#include <array>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <initializer_list>
#include <thread>

#include <gtest/gtest.h>

#include "dynamap/platform/clock.hpp"
#include "dynamap/platform/thread.hpp"
#include "dynamap/platform/worker_team.hpp"

#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
#define DYNAMAP_TEST_SANITIZED 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer) || \
    __has_feature(memory_sanitizer)
#define DYNAMAP_TEST_SANITIZED 1
#endif
#endif

namespace dynamap {
namespace {

bool is_one_of(Status s, std::initializer_list<Status> allowed) {
  for (Status a : allowed) {
    if (s == a) return true;
  }
  return false;
}

// Runs f on a short-lived thread, so a changed name, affinity or scheduling class never sticks
// to the test's main thread (a SCHED_FIFO main thread could starve this shared machine).
template <typename F>
Status on_fresh_thread(F f) {
  Status result = Status::kSystemError;
  std::thread t([&] { result = f(); });
  t.join();
  return result;
}

TEST(PlatformClock, IsMonotonicAndAdvances) {
  std::uint64_t prev = platform::monotonic_ns();
  const std::uint64_t first = prev;
  for (int i = 0; i < 100000; ++i) {
    const std::uint64_t now = platform::monotonic_ns();
    ASSERT_GE(now, prev);
    prev = now;
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(2));
  const std::uint64_t later = platform::monotonic_ns();
  EXPECT_GE(later - first, 1'000'000u);  // slept >= 2 ms; allow coarse clocks
  const char* src = platform::clock_source();
  ASSERT_NE(src, nullptr);
#if defined(__aarch64__)
  EXPECT_STREQ(src, "cntvct_el0");
#else
  EXPECT_STREQ(src, "steady_clock");
#endif
}

TEST(PlatformThread, NameIsSetAndValidated) {
  EXPECT_EQ(on_fresh_thread([] { return platform::set_thread_name("dynamap-test"); }), Status::kOk);
  // Longer than the 15-character Linux limit: truncated, not an error.
  EXPECT_EQ(
      on_fresh_thread([] { return platform::set_thread_name("a-very-long-thread-name-indeed"); }),
      Status::kOk);
  EXPECT_EQ(platform::set_thread_name(nullptr), Status::kNullData);
}

TEST(PlatformThread, AffinityToCpu0IsOkOrAStatus) {
  const Status s = on_fresh_thread([] { return platform::set_cpu_affinity(0); });
  EXPECT_TRUE(is_one_of(
      s, {Status::kOk, Status::kPermissionDenied, Status::kInvalidArgument, Status::kUnsupported}))
      << to_string(s);
  EXPECT_EQ(platform::set_cpu_affinity(-1), Status::kInvalidArgument);
  EXPECT_EQ(platform::set_cpu_affinity(1 << 20), Status::kInvalidArgument);
}

TEST(PlatformThread, FifoPriorityIsOkOrPermissionDenied) {
  const Status s = on_fresh_thread([] { return platform::set_fifo_priority(10); });
  EXPECT_TRUE(is_one_of(s, {Status::kOk, Status::kPermissionDenied})) << to_string(s);
  EXPECT_EQ(platform::set_fifo_priority(0), Status::kInvalidArgument);
  EXPECT_EQ(platform::set_fifo_priority(100), Status::kInvalidArgument);
}

TEST(PlatformThread, LockAndUnlockMemory) {
#if defined(DYNAMAP_TEST_SANITIZED)
  // mlockall(MCL_FUTURE) would lock the sanitizer's terabyte-scale shadow reservations as they
  // are touched and can break the process; the call is not meant for sanitizer builds.
  GTEST_SKIP() << "lock_memory is not exercised in sanitizer builds";
#else
  const Status s = platform::lock_memory();
  EXPECT_TRUE(is_one_of(s, {Status::kOk, Status::kPermissionDenied, Status::kUnsupported}))
      << to_string(s);
  // Allocation still works while locked (with a limit, MCL_FUTURE could make it fail).
  std::thread([] {}).join();
  EXPECT_EQ(platform::unlock_memory(), Status::kOk);
#endif
}

}  // namespace
}  // namespace dynamap

// ---- WorkerTeam -------------------------------------------------------------------------------

namespace dynamap {
namespace {

struct TeamProbe {
  std::array<std::atomic<int>, platform::WorkerTeam::kMaxMembers> calls{};
  std::atomic<int> slow_member{-1};
};

void probe_task(void* context, unsigned member) {
  auto* p = static_cast<TeamProbe*>(context);
  if (static_cast<int>(member) == p->slow_member.load()) {
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  p->calls[member].fetch_add(1);
}

TEST(PlatformWorkerTeam, EveryMemberRunsEveryTaskOnceAndRunWaitsForAll) {
  for (unsigned members = 1; members <= platform::WorkerTeam::kMaxMembers; ++members) {
    SCOPED_TRACE(members);
    platform::WorkerTeam team;
    ASSERT_EQ(team.start(members, platform::ThreadOptions{}), Status::kOk);
    EXPECT_EQ(team.size(), members);
    TeamProbe probe;
    probe.slow_member = static_cast<int>(members) - 1;  // the last member is slow
    for (int run = 1; run <= 50; ++run) {
      team.run(&probe_task, &probe);
      // run() returned: every member has finished this run, the slow one included.
      for (unsigned m = 0; m < members; ++m) EXPECT_EQ(probe.calls[m].load(), run);
      probe.slow_member = run % 5 == 0 ? static_cast<int>(members) - 1 : -1;
    }
    team.stop();
    team.stop();  // idempotent
    EXPECT_EQ(team.size(), 1u);
  }
}

TEST(PlatformWorkerTeam, StartValidatesAndRestarts) {
  platform::WorkerTeam team;
  EXPECT_EQ(team.start(0, platform::ThreadOptions{}), Status::kInvalidArgument);
  EXPECT_EQ(team.start(platform::WorkerTeam::kMaxMembers + 1, platform::ThreadOptions{}),
            Status::kInvalidArgument);
  ASSERT_EQ(team.start(3, platform::ThreadOptions{}), Status::kOk);
  EXPECT_EQ(team.start(2, platform::ThreadOptions{}), Status::kInvalidArgument);  // running
  team.stop();
  ASSERT_EQ(team.start(2, platform::ThreadOptions{}), Status::kOk);
  TeamProbe probe;
  team.run(&probe_task, &probe);
  EXPECT_EQ(probe.calls[0].load() + probe.calls[1].load(), 2);
}  // the destructor joins

}  // namespace
}  // namespace dynamap
