#include "dynamap/platform/worker_team.hpp"

#include <climits>

#include <linux/futex.h>
#include <sys/syscall.h>
#include <unistd.h>

namespace dynamap::platform {
namespace {

static_assert(sizeof(std::atomic<std::uint32_t>) == sizeof(std::uint32_t) &&
                  std::atomic<std::uint32_t>::is_always_lock_free,
              "futex words are plain 32-bit atomics");

/// Spins before sleeping: a frame's hand-off usually arrives within microseconds.
constexpr int kSpinsBeforeSleep = 4000;

std::uint32_t* futex_word(std::atomic<std::uint32_t>& a) noexcept {
  return reinterpret_cast<std::uint32_t*>(&a);
}

void futex_wait(std::atomic<std::uint32_t>& a, std::uint32_t expected) noexcept {
  // Returns at once when the word no longer holds `expected` (EAGAIN); spurious wake-ups are
  // fine, every caller re-checks its condition.
  (void)syscall(SYS_futex, futex_word(a), FUTEX_WAIT_PRIVATE, expected, nullptr, nullptr, 0);
}

void futex_wake_all(std::atomic<std::uint32_t>& a) noexcept {
  (void)syscall(SYS_futex, futex_word(a), FUTEX_WAKE_PRIVATE, INT_MAX, nullptr, nullptr, 0);
}

inline void cpu_relax() noexcept {
#if defined(__x86_64__) || defined(__i386__)
  __builtin_ia32_pause();
#elif defined(__aarch64__)
  asm volatile("yield" ::: "memory");
#endif
}

/// Waits until a.load() != value: spins, then sleeps on the futex.
void wait_while_equal(std::atomic<std::uint32_t>& a, std::uint32_t value) noexcept {
  for (int i = 0; i < kSpinsBeforeSleep; ++i) {
    if (a.load(std::memory_order_acquire) != value) return;
    cpu_relax();
  }
  while (a.load(std::memory_order_acquire) == value) futex_wait(a, value);
}

}  // namespace

Status WorkerTeam::start(unsigned members, const ThreadOptions& options) noexcept {
  if (members < 1 || members > kMaxMembers || members_ > 1) return Status::kInvalidArgument;
  stopping_.store(false, std::memory_order_relaxed);
  for (unsigned m = 1; m < members; ++m) {
    Helper& h = helpers_[m - 1];
    h.team = this;
    h.member = m;
    // The helper waits for the next generation after this one, even if it starts late.
    h.start_generation = generation_.load(std::memory_order_relaxed);
    members_ = m;  // helpers started so far + the caller, for stop() on failure
    ThreadOptions own = options;
    if (options.cpu >= 0) own.cpu = options.cpu + static_cast<int>(m) - 1;
    if (const Status s = h.thread.start(&WorkerTeam::helper_main, &h, own); !ok(s)) {
      stop();
      return s;
    }
  }
  members_ = members;
  return Status::kOk;
}

void WorkerTeam::helper_main(void* arg) noexcept {
  auto* h = static_cast<Helper*>(arg);
  WorkerTeam& team = *h->team;
  std::uint32_t seen = h->start_generation;
  for (;;) {
    wait_while_equal(team.generation_, seen);
    seen = team.generation_.load(std::memory_order_acquire);
    if (team.stopping_.load(std::memory_order_acquire)) return;
    team.task_(team.context_, h->member);
    if (team.pending_.fetch_sub(1, std::memory_order_acq_rel) == 1) {
      futex_wake_all(team.pending_);
    }
  }
}

void WorkerTeam::run(Task task, void* context) noexcept {
  if (members_ <= 1) {
    task(context, 0);
    return;
  }
  task_ = task;
  context_ = context;
  pending_.store(members_ - 1, std::memory_order_relaxed);
  generation_.fetch_add(1, std::memory_order_acq_rel);  // publishes task_, context_, pending_
  futex_wake_all(generation_);
  task(context, 0);
  for (;;) {
    const std::uint32_t left = pending_.load(std::memory_order_acquire);
    if (left == 0) break;
    wait_while_equal(pending_, left);
  }
}

void WorkerTeam::stop() noexcept {
  if (members_ <= 1) return;
  stopping_.store(true, std::memory_order_release);
  generation_.fetch_add(1, std::memory_order_acq_rel);
  futex_wake_all(generation_);
  for (unsigned m = 1; m < members_; ++m) (void)helpers_[m - 1].thread.join();
  members_ = 1;
}

}  // namespace dynamap::platform
