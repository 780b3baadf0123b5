#include "dynamap/testing/worst_case.hpp"

#include <algorithm>
#include <cmath>

namespace dynamap {
namespace {
std::uint16_t to_units(float metres, const CameraIntrinsics& cam) noexcept {
  const float u = std::floor(metres / cam.depth_scale);
  return static_cast<std::uint16_t>(std::clamp(u, 1.0f, 65535.0f));
}
}  // namespace

DepthView make_worst_case_depth(WorstCase kind, const CameraIntrinsics& cam, float max_depth_m,
                                std::size_t obstacles, std::uint16_t* pixels,
                                unsigned phase) noexcept {
  const int w = cam.width;
  const int h = cam.height;
  // Long hit rays (not truncated free rays), dithered by up to 1.5 m so that neighbouring
  // pixels end in different voxels: the map cannot merge them, every sampled pixel costs a ray.
  for (int v = 0; v < h; ++v) {
    for (int u = 0; u < w; ++u) {
      const float dither = 0.1f * static_cast<float>((u * 7 + v * 13) % 16);
      pixels[v * w + u] = to_units(max_depth_m * 0.98f - dither, cam);
    }
  }

  if (kind != WorstCase::kMaxRange && obstacles > 0) {
    // Bars of at least kMinBarPixels with gaps of a third of that.
    const int min_pitch = kMinBarPixels + kMinBarPixels / 3;
    const std::size_t max_bars =
        static_cast<std::size_t>(std::max(1, (w - min_pitch / 2) / min_pitch));
    const std::size_t n = std::min(obstacles, max_bars);
    const int pitch = (w - min_pitch / 2) / static_cast<int>(n);
    const int bar = std::max(kMinBarPixels, pitch * 3 / 4);
    // Odd phases move every bar about 1.8 m deeper: no bar can be associated with a track of
    // the previous frame, so alternating phases fill the tracker.
    // kApproach: every bar comes 3 cm closer per phase (0.9 m/s at 30 Hz) from 4 m to 1.2 m.
    const float base = kind == WorstCase::kApproach ? 4.0f - 0.03f * static_cast<float>(phase % 94)
                                                    : ((phase % 2 == 1) ? 2.9f : 1.1f);
    const int v0 = h / 5;
    const int v1 = h - h / 4;
    for (std::size_t b = 0; b < n; ++b) {
      // Neighbours alternate 0.5 m apart so they never share depth bins.
      const float d = base + (b % 2 == 0 ? 0.f : 0.5f) + 0.03f * static_cast<float>(b % 7);
      const std::uint16_t z = to_units(d, cam);
      const int u0 = static_cast<int>(b) * pitch + (pitch - bar) / 2;
      for (int v = v0; v < v1; ++v) {
        for (int u = u0; u < u0 + bar && u < w; ++u) pixels[v * w + u] = z;
      }
    }
  }
  return DepthView{pixels, w, h, w * static_cast<int>(sizeof(std::uint16_t))};
}

PipelineConfig largest_work_caps() noexcept {
  PipelineConfig c;
  c.map.pixel_stride = 1;
  c.map.max_rays_per_frame = kMaxRaysPerFrame;
  c.map.max_voxel_visits_per_frame = kMaxPipelineVoxelVisitsPerFrame;
  c.detector.max_detections = kMaxDetections;
  c.refiner.max_voxels_per_box = kMaxRefinerVoxelsPerFrame / (2 * kMaxDetections);
  c.cleaner.max_voxels_per_frame = kMaxCleanerVoxelsPerFrame;
  return c;
}

}  // namespace dynamap
