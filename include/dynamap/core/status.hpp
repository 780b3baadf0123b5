// Status: the error value every fallible dynamap call returns.
// Errors are values, never exceptions; a non-Ok status means the call changed nothing.
#pragma once

#include <cstdint>

namespace dynamap {

enum class [[nodiscard]] Status : std::uint8_t{
    kOk = 0,
    kInvalidArgument,    // a parameter is out of its documented range
    kNullData,           // a required pointer is null
    kWrongSize,          // image size/stride does not match the configuration
    kNonFinite,          // NaN or inf in a pose, box or other numeric input
    kNonUnitQuaternion,  // rotation quaternion norm differs from 1 beyond tolerance
    kTimeNotIncreasing,  // timestamp equal to or older than the previous one
    kCapacityExceeded,   // a fixed-capacity container is full
    kNotInitialized,     // init() has not succeeded yet
    kPermissionDenied,   // the OS refused (e.g. SCHED_FIFO without privilege)
    kUnsupported,        // not available on this platform
    kSystemError,        // any other OS failure
    kEmpty,              // nothing to take (e.g. an empty ring)
    kOutOfRange,         // finite, but outside what can be represented (e.g. a pose beyond the
                         // occupancy map's key range)
    kStopped,            // the receiver is stopping or stopped (e.g. Runner::submit after stop)
};

/// Short, stable, human-readable name of a status ("ok", "wrong_size", ...).
constexpr const char* to_string(Status s) noexcept {
  switch (s) {
    case Status::kOk:
      return "ok";
    case Status::kInvalidArgument:
      return "invalid_argument";
    case Status::kNullData:
      return "null_data";
    case Status::kWrongSize:
      return "wrong_size";
    case Status::kNonFinite:
      return "non_finite";
    case Status::kNonUnitQuaternion:
      return "non_unit_quaternion";
    case Status::kTimeNotIncreasing:
      return "time_not_increasing";
    case Status::kCapacityExceeded:
      return "capacity_exceeded";
    case Status::kNotInitialized:
      return "not_initialized";
    case Status::kPermissionDenied:
      return "permission_denied";
    case Status::kUnsupported:
      return "unsupported";
    case Status::kSystemError:
      return "system_error";
    case Status::kEmpty:
      return "empty";
    case Status::kOutOfRange:
      return "out_of_range";
    case Status::kStopped:
      return "stopped";
  }
  return "unknown";
}

constexpr bool ok(Status s) noexcept {
  return s == Status::kOk;
}

}  // namespace dynamap
