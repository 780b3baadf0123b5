// A tiny world-frame scene renderer for pipeline tests: a floor (z = 0), axis-aligned boxes in
// the map frame, and a camera at a map-frame pose. Exact per-pixel ray casting, so every test's
// ground truth is known in closed form.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "dynamap/core/types.hpp"

namespace dynamap::test {

struct WorldScene {
  std::vector<Box3> boxes;  ///< map frame
  bool floor = true;        ///< plane z = 0
};

/// Camera at `position` looking horizontally along map direction `yaw` (radians from +x).
inline Pose level_camera(const Eigen::Vector3f& position, float yaw = 0.f) {
  Eigen::Matrix3f
      optical_to_level;  // optical (x right, y down, z fwd) -> map (x fwd, y left, z up)
  optical_to_level << 0.f, 0.f, 1.f, -1.f, 0.f, 0.f, 0.f, -1.f, 0.f;
  Pose p;
  p.translation = position;
  p.rotation =
      (Eigen::AngleAxisf(yaw, Eigen::Vector3f::UnitZ()) * Eigen::Quaternionf(optical_to_level))
          .normalized();
  return p;
}

inline float ray_box(const Eigen::Vector3f& o, const Eigen::Vector3f& d, const Box3& b) {
  float t0 = 0.f, t1 = 1e30f;
  for (int a = 0; a < 3; ++a) {
    if (std::fabs(d[a]) < 1e-9f) {
      if (o[a] < b.min[a] || o[a] > b.max[a]) return 1e30f;
      continue;
    }
    float ta = (b.min[a] - o[a]) / d[a];
    float tb = (b.max[a] - o[a]) / d[a];
    if (ta > tb) std::swap(ta, tb);
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb);
  }
  return (t0 <= t1 && t0 > 0.f) ? t0 : 1e30f;
}

/// Renders the depth image (units of cam.depth_scale, 0 where nothing is hit) into `pixels`.
inline DepthView render(const WorldScene& scene, const CameraIntrinsics& cam, const Pose& pose,
                        std::vector<std::uint16_t>& pixels) {
  pixels.assign(static_cast<std::size_t>(cam.width) * static_cast<std::size_t>(cam.height), 0);
  const Eigen::Matrix3f R = pose.rotation.toRotationMatrix();
  const Eigen::Vector3f o = pose.translation;
  for (int v = 0; v < cam.height; ++v) {
    for (int u = 0; u < cam.width; ++u) {
      // Camera-frame direction with z = 1, so the ray parameter is the depth itself.
      const Eigen::Vector3f dc((static_cast<float>(u) - cam.cx) / cam.fx,
                               (static_cast<float>(v) - cam.cy) / cam.fy, 1.f);
      const Eigen::Vector3f d = R * dc;
      float t = 1e30f;
      for (const Box3& b : scene.boxes) t = std::min(t, ray_box(o, d, b));
      if (scene.floor && d.z() < -1e-6f) t = std::min(t, -o.z() / d.z());
      if (t >= 1e29f) continue;
      const float raw = std::round(t / cam.depth_scale);
      pixels[static_cast<std::size_t>(v) * static_cast<std::size_t>(cam.width) +
             static_cast<std::size_t>(u)] = static_cast<std::uint16_t>(std::min(raw, 65535.f));
    }
  }
  return DepthView{pixels.data(), cam.width, cam.height,
                   cam.width * static_cast<int>(sizeof(std::uint16_t))};
}

/// A person-sized box (0.5 x 0.5 x 1.7 m) standing on the floor at (x, y).
inline Box3 person_at(float x, float y) {
  return Box3::from_center_size(Eigen::Vector3f(x, y, 0.85f), Eigen::Vector3f(0.5f, 0.5f, 1.7f));
}

/// A person shaped from boxes, facing the camera along x, centred at (x, y): two legs, a torso
/// with an arm on each side (0.54 m across the arms) and a head, 1.72 m tall. Between two such
/// people side by side the depth image holds only arms: the density minimum the refiner splits
/// at. `hole` cuts a 0.1 m slot through the torso's middle (z 1.0 to 1.3 m).
inline std::vector<Box3> person_shape_at(float x, float y, bool hole = false) {
  const auto box = [&](float y0, float y1, float z0, float z1, float depth) {
    return Box3{Eigen::Vector3f(x - 0.5f * depth, y + y0, z0),
                Eigen::Vector3f(x + 0.5f * depth, y + y1, z1)};
  };
  std::vector<Box3> parts = {
      box(-0.175f, -0.025f, 0.f, 0.85f, 0.2f),                                        // legs
      box(0.025f, 0.175f, 0.f, 0.85f, 0.2f), box(-0.27f, -0.2f, 0.75f, 1.4f, 0.25f),  // arms
      box(0.2f, 0.27f, 0.75f, 1.4f, 0.25f), box(-0.1f, 0.1f, 1.45f, 1.72f, 0.2f)};    // head
  if (hole) {
    parts.push_back(box(-0.2f, -0.05f, 0.85f, 1.45f, 0.25f));
    parts.push_back(box(0.05f, 0.2f, 0.85f, 1.45f, 0.25f));
    parts.push_back(box(-0.05f, 0.05f, 0.85f, 1.0f, 0.25f));
    parts.push_back(box(-0.05f, 0.05f, 1.3f, 1.45f, 0.25f));
  } else {
    parts.push_back(box(-0.2f, 0.2f, 0.85f, 1.45f, 0.25f));  // torso
  }
  return parts;
}

}  // namespace dynamap::test
