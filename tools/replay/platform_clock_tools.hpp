// Wall-clock seconds for the replay tool's progress and throughput figures.
#pragma once

#include <chrono>

namespace dynamap::tools {
inline double wall_seconds() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}
}  // namespace dynamap::tools
