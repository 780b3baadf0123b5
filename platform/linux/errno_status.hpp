// Maps a POSIX error number to a dynamap Status; shared by the Linux platform sources.
#pragma once

#include <cerrno>

#include "dynamap/core/status.hpp"

namespace dynamap::platform::detail {

inline Status status_from_errno(int err) noexcept {
  switch (err) {
    case 0:
      return Status::kOk;
    case EPERM:
    case EACCES:
      return Status::kPermissionDenied;
    case EINVAL:
      return Status::kInvalidArgument;
    case ENOSYS:
    case ENOTSUP:
      return Status::kUnsupported;
    default:
      return Status::kSystemError;
  }
}

}  // namespace dynamap::platform::detail
