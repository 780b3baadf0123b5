#include "dynamap/platform/worker_thread.hpp"

#include "errno_status.hpp"

#include <cerrno>
#include <cstring>
#include <ctime>

#include <pthread.h>
#include <sched.h>

namespace dynamap::platform {

using detail::status_from_errno;

static_assert(sizeof(unsigned long) >= sizeof(pthread_t), "pthread_t must fit the handle");

WorkerThread::~WorkerThread() {
  (void)join();
}

Status WorkerThread::start(Entry entry, void* arg, const ThreadOptions& options) noexcept {
  if (started_) return Status::kInvalidArgument;
  if (entry == nullptr) return Status::kNullData;
  if (options.cpu < -1 || options.cpu >= CPU_SETSIZE) return Status::kInvalidArgument;
  if (options.fifo_priority != 0 && (options.fifo_priority < sched_get_priority_min(SCHED_FIFO) ||
                                     options.fifo_priority > sched_get_priority_max(SCHED_FIFO))) {
    return Status::kInvalidArgument;
  }

  pthread_attr_t attr;
  if (pthread_attr_init(&attr) != 0) return Status::kSystemError;
  int err = 0;
  if (options.cpu >= 0) {
    cpu_set_t set;
    CPU_ZERO(&set);
    CPU_SET(options.cpu, &set);
    err = pthread_attr_setaffinity_np(&attr, sizeof(set), &set);
  }
  if (err == 0 && options.fifo_priority > 0) {
    sched_param p{};
    p.sched_priority = options.fifo_priority;
    err = pthread_attr_setinheritsched(&attr, PTHREAD_EXPLICIT_SCHED);
    if (err == 0) err = pthread_attr_setschedpolicy(&attr, SCHED_FIFO);
    if (err == 0) err = pthread_attr_setschedparam(&attr, &p);
  }
  pthread_t handle{};
  trampoline_entry_ = entry;
  trampoline_arg_ = arg;
  if (err == 0) {
    err = pthread_create(
        &handle, &attr,
        [](void* self) -> void* {
          auto* t = static_cast<WorkerThread*>(self);
          t->trampoline_entry_(t->trampoline_arg_);
          return nullptr;
        },
        this);
  }
  pthread_attr_destroy(&attr);
  if (err != 0) return status_from_errno(err);
  handle_ = static_cast<unsigned long>(handle);
  started_ = true;
  if (options.name != nullptr) {
    char buf[16];
    std::strncpy(buf, options.name, sizeof(buf) - 1);
    buf[sizeof(buf) - 1] = '\0';
    (void)pthread_setname_np(handle, buf);  // cosmetic; never fails the start
  }
  return Status::kOk;
}

Status WorkerThread::join() noexcept {
  if (!started_) return Status::kEmpty;
  const int err = pthread_join(static_cast<pthread_t>(handle_), nullptr);
  started_ = false;
  return status_from_errno(err);
}

std::uint64_t sleep_clock_ns() noexcept {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<std::uint64_t>(ts.tv_sec) * 1000000000ULL +
         static_cast<std::uint64_t>(ts.tv_nsec);
}

Status sleep_until_ns(std::uint64_t deadline_ns) noexcept {
  timespec ts{};
  ts.tv_sec = static_cast<time_t>(deadline_ns / 1000000000ULL);
  ts.tv_nsec = static_cast<long>(deadline_ns % 1000000000ULL);
  int err;
  do {
    err = clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr);
  } while (err == EINTR);
  return status_from_errno(err);
}

Status sleep_for_ns(std::uint64_t duration_ns) noexcept {
  return sleep_until_ns(sleep_clock_ns() + duration_ns);
}

}  // namespace dynamap::platform
