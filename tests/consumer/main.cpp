// Consumer of the installed dynamap package: uses headers and compiled code from the library.
#include <cstdint>
#include <cstdio>
#include <memory>

#include <dynamap/core/latest_value.hpp>
#include <dynamap/core/spsc_ring.hpp>
#include <dynamap/core/status.hpp>
#include <dynamap/pipeline/stage_timing.hpp>
#include <dynamap/platform/clock.hpp>
#include <dynamap/testing/worst_case.hpp>

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

  // The testing library (worst-case frames for timing-budget tests) is installed too.
  dynamap::CameraIntrinsics cam;
  cam.width = 8;
  cam.height = 4;
  std::uint16_t pixels[32] = {};
  const dynamap::DepthView frame =
      dynamap::make_worst_case_depth(dynamap::WorstCase::kMaxRange, cam, 5.0f, 0, pixels);
  if (frame.data != pixels || pixels[0] == 0) return 5;

  std::printf("dynamap consumer ok: %s, clock %s\n", dynamap::to_string(dynamap::Status::kOk),
              dynamap::platform::clock_source());
  return 0;
}
