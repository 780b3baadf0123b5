// An RTOS-like fixed-rate loop: wake at an absolute deadline (no drift), process one frame,
// check the frame against its budget, sleep until the next period. This is the shape of the
// loop a flight stack runs dynamap in (optionally on a SCHED_FIFO thread pinned to a core).
//
// Usage: rtos_loop [frames=60] [period_ms=33] [budget_ms=10] [threads=1]
// threads > 1 gives the pipeline a team of that many threads (the map's tiled carving, 4 tiles,
// with detection beside it): the pipeline creates its helpers at init, the loop is unchanged.
#include <cstdio>
#include <cstdlib>
#include <memory>

#include "dynamap/dynamap.hpp"
#include "dynamap/platform/worker_thread.hpp"
#include "dynamap/testing/worst_case.hpp"

int main(int argc, char** argv) {
  const int frames = argc > 1 ? std::atoi(argv[1]) : 60;
  const std::uint64_t period_ns =
      (argc > 2 ? std::strtoull(argv[2], nullptr, 10) : 33) * 1000000ULL;
  const std::uint64_t budget_ns =
      (argc > 3 ? std::strtoull(argv[3], nullptr, 10) : 10) * 1000000ULL;

  // Start-up (not real-time): take all memory now.
  auto pipeline = std::make_unique<dynamap::Pipeline>();
  auto output = std::make_unique<dynamap::FrameOutput>();
  auto depth =
      std::make_unique<std::uint16_t[]>(dynamap::kMaxImageWidth * dynamap::kMaxImageHeight);
  const int map_threads = argc > 4 ? std::atoi(argv[4]) : 1;
  dynamap::PipelineConfig config;
  config.budgets.frame_ns = budget_ns;
  if (map_threads > 1) {
    config.map.carve_tiles = 4;
    config.team.members = map_threads;
  }
  if (!dynamap::ok(pipeline->init(config))) return 1;

  dynamap::Frame frame;
  frame.depth = dynamap::make_worst_case_depth(dynamap::WorstCase::kClutter, config.camera,
                                               config.map.max_depth, 6, depth.get());
  frame.T_map_camera.translation = Eigen::Vector3f(0.f, 0.f, 1.5f);
  Eigen::Matrix3f r;
  r << 0, 0, 1, -1, 0, 0, 0, -1, 0;
  frame.T_map_camera.rotation = Eigen::Quaternionf(r);

  // The loop: absolute deadlines, so a late frame does not shift every later one.
  std::uint64_t next = dynamap::platform::sleep_clock_ns() + period_ns;
  int late = 0;
  for (int i = 0; i < frames; ++i) {
    frame.stamp = dynamap::platform::sleep_clock_ns();
    if (!dynamap::ok(pipeline->process(frame, *output))) return 1;
    if (output->total_ns > budget_ns) ++late;  // a real system would degrade or alert here
    if (dynamap::platform::sleep_clock_ns() > next) ++late;
    (void)dynamap::platform::sleep_until_ns(next);
    next += period_ns;
  }
  const auto& t = pipeline->frame_stats();
  std::printf(
      "%d frames at %.1f Hz: median %.2f ms, p99 %.2f ms, max %.2f ms; "
      "%llu over the %.1f ms budget, %d late\n",
      frames, 1e9 / static_cast<double>(period_ns), static_cast<double>(t.p50_ns()) * 1e-6,
      static_cast<double>(t.p99_ns()) * 1e-6, static_cast<double>(t.max_ns()) * 1e-6,
      static_cast<unsigned long long>(t.overruns()), static_cast<double>(budget_ns) * 1e-6, late);
  return 0;
}
