// WorkerTeam: the TaskTeam the pipeline owns, a fixed team of threads that run one task
// together, for per-frame data parallelism. The helper threads are created once by start() (through
// WorkerThread) and then wait for work; run() hands a task to all of them with one atomic
// generation counter, runs the caller's share itself and returns when every member has finished. No
// lock, allocation or thread creation per run(). Waiting members spin briefly, then sleep on a
// futex.
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>

#include "dynamap/core/status.hpp"
#include "dynamap/core/task_team.hpp"
#include "dynamap/platform/worker_thread.hpp"

namespace dynamap::platform {

class WorkerTeam final : public TaskTeam {
 public:
  /// Members including the caller of run(): member 0 is always the caller.
  static constexpr unsigned kMaxMembers = kMaxTeamMembers;

  WorkerTeam() noexcept = default;
  WorkerTeam(const WorkerTeam&) = delete;
  WorkerTeam& operator=(const WorkerTeam&) = delete;
  ~WorkerTeam() { stop(); }

  /// Creates members - 1 helper threads (none for members == 1) with `options`, except that
  /// with options.cpu >= 0 helper m (1..members-1) is pinned to CPU options.cpu + m - 1.
  /// kInvalidArgument outside 1..kMaxMembers or when already started; a thread creation error
  /// as WorkerThread::start() reports it (the team is then stopped again).
  [[nodiscard]] Status start(unsigned members, const ThreadOptions& options) noexcept;
  /// Runs task(context, m) on every member m and returns when all have returned. Call it from
  /// one thread at a time (the owner's). Without helpers it simply calls task(context, 0).
  void run(Task task, void* context) noexcept override;
  /// Wakes and joins the helpers; a run() in progress on the owner's thread must have returned.
  /// Idempotent.
  void stop() noexcept;
  unsigned size() const noexcept override { return members_; }

 private:
  struct Helper {
    WorkerTeam* team = nullptr;
    unsigned member = 0;
    std::uint32_t start_generation = 0;  ///< generation_ when the helper was started
    WorkerThread thread{};
  };
  static void helper_main(void* arg) noexcept;

  unsigned members_ = 1;
  Task task_ = nullptr;
  void* context_ = nullptr;
  std::atomic<std::uint32_t> generation_{0};  ///< bumped per run() (and by stop())
  std::atomic<std::uint32_t> pending_{0};     ///< helpers still running the current task
  std::atomic<bool> stopping_{false};
  Helper helpers_[kMaxMembers - 1]{};
};

}  // namespace dynamap::platform
