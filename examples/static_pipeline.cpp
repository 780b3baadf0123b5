// A Pipeline as a static global object: all of its memory lives in .bss, fixed at build time,
// and nothing is allocated on the heap, neither at init() nor per frame.
//
// Build: part of the default build (examples/). Run: ./build/<preset>/examples/static_pipeline
#include <cstdio>

#include "dynamap/dynamap.hpp"
#include "dynamap/testing/worst_case.hpp"

namespace {
dynamap::Pipeline g_pipeline;   // ~tens of MB in .bss; see memory_bytes()
dynamap::FrameOutput g_output;  // fixed-size output, reused every frame
std::uint16_t g_depth[dynamap::kMaxImageWidth * dynamap::kMaxImageHeight];
}  // namespace

int main() {
  dynamap::PipelineConfig config;  // documented defaults, 640x480 camera
  dynamap::ConfigError error;
  if (const dynamap::Status s = g_pipeline.init(config, &error); !dynamap::ok(s)) {
    char why[256];
    std::printf("init failed: %s (%s)\n", dynamap::to_string(s),
                dynamap::describe(error, why, sizeof why));
    return 1;
  }
  std::printf("pipeline footprint: %.1f MiB (static)\n",
              static_cast<double>(dynamap::Pipeline::memory_bytes()) / (1024.0 * 1024.0));

  // A camera 1.5 m above the floor looking along +x at cluttered bars (a worst-case frame).
  dynamap::Frame frame;
  frame.depth = dynamap::make_worst_case_depth(dynamap::WorstCase::kClutter, config.camera,
                                               config.map.max_depth, 8, g_depth);
  frame.T_map_camera.translation = Eigen::Vector3f(0.f, 0.f, 1.5f);
  // optical (x right, y down, z forward) -> map (x forward, y left, z up)
  Eigen::Matrix3f r;
  r << 0, 0, 1, -1, 0, 0, 0, -1, 0;
  frame.T_map_camera.rotation = Eigen::Quaternionf(r);

  for (int i = 0; i < 30; ++i) {
    frame.stamp = static_cast<dynamap::Stamp>(i + 1) * 33'333'333ULL;
    if (const dynamap::Status s = g_pipeline.process(frame, g_output); !dynamap::ok(s)) {
      std::printf("frame %d rejected: %s\n", i, dynamap::to_string(s));
      return 1;
    }
  }
  const auto& t = g_pipeline.frame_stats();
  std::printf("30 frames: %zu obstacles tracked, frame time median %.2f ms, max %.2f ms\n",
              g_output.num_obstacles, static_cast<double>(t.p50_ns()) * 1e-6,
              static_cast<double>(t.max_ns()) * 1e-6);
  return 0;
}
