// Status is header-only; this unit keeps the library non-empty and checks the header compiles
// alone.
#include "dynamap/core/status.hpp"

static_assert(dynamap::ok(dynamap::Status::kOk), "kOk must be ok");
