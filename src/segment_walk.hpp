// Set-up of the Amanatides-Woo voxel walk shared by the map's segment queries (internal).
#pragma once

#include <array>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <limits>

#include <Eigen/Core>

namespace dynamap::detail {

/// Per-axis state of a walk from voxel `idx` (containing a) to voxel `end` (containing b):
/// step direction, steps left, t of the next boundary and t between boundaries (t in [0, 1]
/// along b - a; inf on an axis with no steps).
struct SegmentWalk {
  std::int32_t step[3];
  std::int32_t remaining[3];
  float t_max[3];
  float t_delta[3];

  /// One voxel step along the axis whose next boundary comes first (ties to the lower axis);
  /// returns that axis. Needs a step left on some axis.
  std::size_t advance(std::array<std::int32_t, 3>& idx) noexcept {
    std::size_t ax = 0;
    if (t_max[1] < t_max[ax]) ax = 1;
    if (t_max[2] < t_max[ax]) ax = 2;
    idx[ax] += step[ax];
    if (--remaining[ax] == 0) {
      t_max[ax] = std::numeric_limits<float>::infinity();
    } else {
      t_max[ax] += t_delta[ax];
    }
    return ax;
  }
};

inline SegmentWalk start_segment_walk(const Eigen::Vector3f& a, const Eigen::Vector3f& b,
                                      const std::array<std::int32_t, 3>& idx,
                                      const std::array<std::int32_t, 3>& end,
                                      float resolution) noexcept {
  SegmentWalk w{};
  const Eigen::Vector3f d = b - a;
  constexpr float kInf = std::numeric_limits<float>::infinity();
  for (std::size_t ax = 0; ax < 3; ++ax) {
    const int e = static_cast<int>(ax);
    w.remaining[ax] = std::abs(end[ax] - idx[ax]);
    w.step[ax] = end[ax] > idx[ax] ? 1 : -1;
    if (w.remaining[ax] == 0 || d[e] == 0.f) {
      w.remaining[ax] = 0;
      w.t_max[ax] = kInf;
      w.t_delta[ax] = kInf;
      continue;
    }
    const float boundary = static_cast<float>(idx[ax] + (w.step[ax] > 0 ? 1 : 0)) * resolution;
    w.t_max[ax] = (boundary - a[e]) / d[e];
    w.t_delta[ax] = resolution / std::fabs(d[e]);
  }
  return w;
}

}  // namespace dynamap::detail
