#include "dynamap/platform/clock.hpp"

#include <chrono>
#include <ctime>

namespace dynamap::platform {

#if defined(__aarch64__)
namespace {
inline std::uint64_t read_cntvct() noexcept {
  std::uint64_t v;
  asm volatile("isb; mrs %0, cntvct_el0" : "=r"(v)::"memory");
  return v;
}
inline std::uint64_t read_cntfrq() noexcept {
  std::uint64_t f;
  asm volatile("mrs %0, cntfrq_el0" : "=r"(f));
  return f;
}
}  // namespace

std::uint64_t monotonic_ns() noexcept {
  static const std::uint64_t freq = read_cntfrq();
  const std::uint64_t c = read_cntvct();
  if (freq == 0) {  // should not happen; fall back rather than divide by zero
    return static_cast<std::uint64_t>(std::chrono::duration_cast<std::chrono::nanoseconds>(
                                          std::chrono::steady_clock::now().time_since_epoch())
                                          .count());
  }
  // Split to avoid overflowing 64 bits in c * 1e9.
  return (c / freq) * 1000000000ULL + ((c % freq) * 1000000000ULL) / freq;
}
const char* clock_source() noexcept {
  return "cntvct_el0";
}
#else
std::uint64_t monotonic_ns() noexcept {
  return static_cast<std::uint64_t>(std::chrono::duration_cast<std::chrono::nanoseconds>(
                                        std::chrono::steady_clock::now().time_since_epoch())
                                        .count());
}
const char* clock_source() noexcept {
  return "steady_clock";
}
#endif

std::uint64_t thread_cpu_ns() noexcept {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<std::uint64_t>(ts.tv_sec) * 1000000000ULL +
         static_cast<std::uint64_t>(ts.tv_nsec);
}

}  // namespace dynamap::platform
