// Thread helpers for real-time use on Linux: name, CPU affinity, SCHED_FIFO priority, mlockall.
// Each acts on the calling thread and reports failure as a Status (kPermissionDenied when the
// process lacks the privilege); none throws.
#pragma once

#include "dynamap/core/status.hpp"

namespace dynamap::platform {

/// Names the calling thread (truncated to 15 characters, the Linux limit).
[[nodiscard]] Status set_thread_name(const char* name) noexcept;
/// Pins the calling thread to one CPU.
[[nodiscard]] Status set_cpu_affinity(int cpu) noexcept;
/// Switches the calling thread to SCHED_FIFO with the given priority (1..99).
[[nodiscard]] Status set_fifo_priority(int priority) noexcept;
/// Locks all current and future pages of the process in RAM (no page faults later).
/// kPermissionDenied without CAP_IPC_LOCK or when RLIMIT_MEMLOCK is too small. Do not use it in
/// sanitizer builds: their huge shadow mappings would all be locked.
[[nodiscard]] Status lock_memory() noexcept;
/// Undoes lock_memory() (munlockall).
[[nodiscard]] Status unlock_memory() noexcept;

}  // namespace dynamap::platform
