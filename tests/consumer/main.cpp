// Consumer of the installed dynamap package: uses headers and compiled code from the library.
#include <cstdio>
#include <memory>

#include <dynamap/latest_value.hpp>
#include <dynamap/platform/clock.hpp>
#include <dynamap/spsc_ring.hpp>
#include <dynamap/stage_timing.hpp>
#include <dynamap/status.hpp>

int main() {
  auto ring = std::make_unique<dynamap::SpscRing<int, 4>>();
  if (ring->try_push(7) != dynamap::Status::kOk) return 1;
  int v = 0;
  if (ring->try_pop(v) != dynamap::Status::kOk || v != 7) return 2;

  dynamap::LatestValue<int> latest;
  latest.write_buffer() = 3;
  latest.publish();
  if (!latest.update() || latest.read_buffer() != 3) return 3;

  dynamap::StageStats stats;  // compiled in libdynamap (stage_timing.cpp)
  { dynamap::ScopedStageTimer timer(stats); }
  if (stats.count() != 1) return 4;

  std::printf("dynamap consumer ok: %s, clock %s\n", dynamap::to_string(dynamap::Status::kOk),
              dynamap::platform::clock_source());
  return 0;
}
