// Analytic depth rendering for tests and benchmarks: axis-aligned boxes, an optional back wall
// (plane z = const) and an optional floor (plane y = const), all in the camera optical frame
// (x right, y down, z forward). Each pixel's ray through its centre is intersected exactly, so
// the ground truth of every test is known in closed form.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "dynamap/core/types.hpp"

namespace dynamap::test {

struct SceneBox {
  Eigen::Vector3f min;  ///< camera frame
  Eigen::Vector3f max;
};

struct SyntheticScene {
  std::vector<SceneBox> boxes;
  float wall_z = 0.f;   ///< back wall depth (metres); 0 = no wall
  float floor_y = 0.f;  ///< floor plane y (camera y is down, so > 0); 0 = no floor
};

/// Depth image owned by the test (row stride may include padding).
struct SyntheticImage {
  std::vector<std::uint16_t> pixels;
  int width = 0;
  int height = 0;
  int stride = 0;  ///< elements per row
  DepthView view() const {
    return DepthView{pixels.data(), width, height,
                     stride * static_cast<int>(sizeof(std::uint16_t))};
  }
};

/// Ray (origin 0, direction (dx, dy, 1)) vs box: the entry depth, or +inf on a miss.
inline float ray_box_depth(float dx, float dy, const SceneBox& b) {
  const float dir[3] = {dx, dy, 1.f};
  float t0 = 0.f, t1 = 1e30f;
  for (int a = 0; a < 3; ++a) {
    const float lo = b.min[a], hi = b.max[a];
    if (std::fabs(dir[a]) < 1e-12f) {
      if (0.f < lo || 0.f > hi) return 1e30f;
      continue;
    }
    float ta = lo / dir[a], tb = hi / dir[a];
    if (ta > tb) std::swap(ta, tb);
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb);
  }
  return (t0 <= t1 && t0 > 0.f) ? t0 : 1e30f;
}

/// Renders z-depth (dir.z = 1, so the ray parameter is the depth) in units of cam.depth_scale.
inline SyntheticImage render_depth(const SyntheticScene& scene, const CameraIntrinsics& cam,
                                   int pad = 0) {
  SyntheticImage img;
  img.width = cam.width;
  img.height = cam.height;
  img.stride = cam.width + pad;
  img.pixels.assign(static_cast<std::size_t>(img.stride) * static_cast<std::size_t>(img.height), 0);
  for (int v = 0; v < cam.height; ++v) {
    for (int u = 0; u < cam.width; ++u) {
      const float dx = (static_cast<float>(u) - cam.cx) / cam.fx;
      const float dy = (static_cast<float>(v) - cam.cy) / cam.fy;
      float t = 1e30f;
      for (const SceneBox& b : scene.boxes) t = std::min(t, ray_box_depth(dx, dy, b));
      if (scene.wall_z > 0.f) t = std::min(t, scene.wall_z);
      if (scene.floor_y > 0.f && dy > 0.f) t = std::min(t, scene.floor_y / dy);
      if (t >= 1e29f) continue;
      const float raw = std::round(t / cam.depth_scale);
      img.pixels[static_cast<std::size_t>(v) * static_cast<std::size_t>(img.stride) +
                 static_cast<std::size_t>(u)] = static_cast<std::uint16_t>(std::min(raw, 65535.f));
    }
  }
  return img;
}

/// Pose whose rotation maps optical axes onto map axes: camera z -> map x (forward),
/// camera x -> map -y, camera y -> map -z (map z up).
inline Pose optical_to_map_pose(const Eigen::Vector3f& translation) {
  Eigen::Matrix3f r;
  r << 0.f, 0.f, 1.f,  //
      -1.f, 0.f, 0.f,  //
      0.f, -1.f, 0.f;
  Pose p;
  p.translation = translation;
  p.rotation = Eigen::Quaternionf(r).normalized();
  return p;
}

/// Axis-aligned bounds of the 8 corners of a camera-frame box in the map frame.
inline Box3 box_to_map(const Eigen::Vector3f& mn, const Eigen::Vector3f& mx, const Pose& T) {
  Box3 r{Eigen::Vector3f::Constant(1e30f), Eigen::Vector3f::Constant(-1e30f)};
  for (int i = 0; i < 8; ++i) {
    const Eigen::Vector3f c((i & 1) ? mx.x() : mn.x(), (i & 2) ? mx.y() : mn.y(),
                            (i & 4) ? mx.z() : mn.z());
    const Eigen::Vector3f p = T.apply(c);
    r.min = r.min.cwiseMin(p);
    r.max = r.max.cwiseMax(p);
  }
  return r;
}

}  // namespace dynamap::test
