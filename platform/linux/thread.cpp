#include "dynamap/platform/thread.hpp"

#include "errno_status.hpp"

#include <cerrno>
#include <cstring>

#include <pthread.h>
#include <sched.h>
#include <sys/mman.h>

namespace dynamap::platform {

using detail::status_from_errno;

Status set_thread_name(const char* name) noexcept {
  if (name == nullptr) return Status::kNullData;
  char buf[16];
  std::strncpy(buf, name, sizeof(buf) - 1);
  buf[sizeof(buf) - 1] = '\0';
  return status_from_errno(pthread_setname_np(pthread_self(), buf));
}

Status set_cpu_affinity(int cpu) noexcept {
  if (cpu < 0 || cpu >= CPU_SETSIZE) return Status::kInvalidArgument;
  cpu_set_t set;
  CPU_ZERO(&set);
  CPU_SET(cpu, &set);
  return status_from_errno(pthread_setaffinity_np(pthread_self(), sizeof(set), &set));
}

Status set_fifo_priority(int priority) noexcept {
  if (priority < sched_get_priority_min(SCHED_FIFO) ||
      priority > sched_get_priority_max(SCHED_FIFO)) {
    return Status::kInvalidArgument;
  }
  sched_param p{};
  p.sched_priority = priority;
  return status_from_errno(pthread_setschedparam(pthread_self(), SCHED_FIFO, &p));
}

Status lock_memory() noexcept {
  if (mlockall(MCL_CURRENT | MCL_FUTURE) != 0) {
    // ENOMEM here means "over RLIMIT_MEMLOCK" for an unprivileged process: a privilege matter.
    return errno == ENOMEM ? Status::kPermissionDenied : status_from_errno(errno);
  }
  return Status::kOk;
}

Status unlock_memory() noexcept {
  if (munlockall() != 0) return status_from_errno(errno);
  return Status::kOk;
}

}  // namespace dynamap::platform
