#include "dynamap/worst_case.hpp"

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
                                std::size_t obstacles, std::uint16_t* pixels) noexcept {
  const int w = cam.width;
  const int h = cam.height;
  // Just inside the range so every ray is a full-length hit ray, not a truncated free ray.
  const std::uint16_t far = to_units(max_depth_m * 0.98f, cam);
  for (int i = 0; i < w * h; ++i) pixels[i] = far;

  if (kind == WorstCase::kClutter && obstacles > 0) {
    const std::size_t max_bars = static_cast<std::size_t>(std::max(1, w / 16));
    const std::size_t n = std::min(obstacles, max_bars);
    const int pitch = w / static_cast<int>(n);
    const int bar = std::max(8, pitch * 2 / 3);
    const int v0 = h / 5;
    const int v1 = h - h / 4;
    for (std::size_t b = 0; b < n; ++b) {
      // Alternate near and far so neighbouring bars never share depth bins.
      const float d = (b % 2 == 0 ? 1.2f : 2.6f) + 0.05f * static_cast<float>(b % 7);
      const std::uint16_t z = to_units(d, cam);
      const int u0 = static_cast<int>(b) * pitch + (pitch - bar) / 2;
      for (int v = v0; v < v1; ++v) {
        for (int u = u0; u < u0 + bar && u < w; ++u) pixels[v * w + u] = z;
      }
    }
  }
  return DepthView{pixels, w, h, w * static_cast<int>(sizeof(std::uint16_t))};
}

}  // namespace dynamap
