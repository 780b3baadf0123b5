// WorkerThread: a joinable OS thread whose scheduling (name, CPU, SCHED_FIFO priority) is set at
// creation, so every failure is reported by start() as a Status instead of an exception from
// std::thread. Plus sleeps against CLOCK_MONOTONIC for fixed-rate loops.
#pragma once

#include <cstdint>

#include "dynamap/core/status.hpp"

namespace dynamap::platform {

/// How the worker thread is scheduled. Defaults: normal scheduling, any CPU.
struct ThreadOptions {
  const char* name = "dynamap";  ///< shown by top/htop (15 characters kept)
  int cpu = -1;                  ///< pin to this CPU; -1 = no affinity
  int fifo_priority = 0;         ///< SCHED_FIFO priority 1..99; 0 = normal scheduling
};

class WorkerThread {
 public:
  using Entry = void (*)(void* arg);

  WorkerThread() noexcept = default;
  WorkerThread(const WorkerThread&) = delete;
  WorkerThread& operator=(const WorkerThread&) = delete;
  ~WorkerThread();  ///< joins if still running

  /// Starts entry(arg) on a new thread. kPermissionDenied when SCHED_FIFO is not allowed,
  /// kInvalidArgument for a bad CPU or priority, kInvalidArgument if already running.
  [[nodiscard]] Status start(Entry entry, void* arg, const ThreadOptions& options) noexcept;
  /// Waits for the thread to return. kEmpty when it was not started.
  Status join() noexcept;
  bool joinable() const noexcept { return started_; }

 private:
  unsigned long handle_ = 0;  // pthread_t on Linux
  bool started_ = false;
  // Read by the new thread: the start argument is `this`, so nothing is allocated.
  Entry trampoline_entry_ = nullptr;
  void* trampoline_arg_ = nullptr;
};

/// Nanoseconds on CLOCK_MONOTONIC (the clock sleep_until_ns() waits on).
std::uint64_t sleep_clock_ns() noexcept;
/// Sleeps until the absolute CLOCK_MONOTONIC deadline (no drift in fixed-rate loops).
Status sleep_until_ns(std::uint64_t deadline_ns) noexcept;
/// Sleeps for a relative duration.
Status sleep_for_ns(std::uint64_t duration_ns) noexcept;

}  // namespace dynamap::platform
