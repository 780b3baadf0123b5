// Monotonic clock of the platform layer: the generic counter CNTVCT_EL0 on aarch64 (cheap, no
// syscall), std::chrono::steady_clock elsewhere. The pipeline takes it as an injectable function.
#pragma once

#include <cstdint>

namespace dynamap::platform {

/// Nanoseconds since an arbitrary fixed origin; never goes backwards.
std::uint64_t monotonic_ns() noexcept;

/// CPU time consumed by the calling thread, in nanoseconds (CLOCK_THREAD_CPUTIME_ID). For
/// benchmarks on shared machines: unlike wall time it does not count time spent descheduled.
std::uint64_t thread_cpu_ns() noexcept;

/// Name of the clock source in use ("cntvct_el0" or "steady_clock").
const char* clock_source() noexcept;

}  // namespace dynamap::platform
