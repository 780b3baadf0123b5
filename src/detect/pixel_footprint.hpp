// How the detector (and the refiner's group split) turn per-column and per-row pixel sums into a
// map-frame box (internal; docs/umap_detector.md, step 5 "3-D box"): each column's pixels stand at
// their mean depth and mean row, each row's at their mean depth and mean column, so flying pixels
// do not stretch the box. One definition, so both measure boxes identically.
#pragma once

#include <algorithm>

#include <Eigen/Core>

#include "dynamap/core/types.hpp"

namespace dynamap::detail {

/// Grows [mn, mx] by the map-frame footprint of image column u (both pixel edges) at depth z and
/// mean row v_mean, seen by camera `cam` with map-from-camera rotation R and translation t.
inline void grow_by_column(const CameraIntrinsics& cam, const Eigen::Matrix3f& R,
                           const Eigen::Vector3f& t, int u, float z, float v_mean,
                           Eigen::Vector3f& mn, Eigen::Vector3f& mx) noexcept {
  const float ut = static_cast<float>(u) - 0.5f - cam.cx;
  const Eigen::Vector3f base = R * Eigen::Vector3f(0.f, (v_mean - cam.cy) * z / cam.fy, z) + t;
  const Eigen::Vector3f step = R.col(0) * (z / cam.fx);
  const Eigen::Vector3f left = base + step * ut, right = base + step * (ut + 1.f);
  mn = mn.cwiseMin(left).cwiseMin(right);
  mx = mx.cwiseMax(left).cwiseMax(right);
}

/// Grows [z_min, z_max] by the map-frame heights of image row v's pixel edges at depth z and
/// mean column u_mean.
inline void grow_by_row(const CameraIntrinsics& cam, const Eigen::Matrix3f& R,
                        const Eigen::Vector3f& t, int v, float z, float u_mean, float& z_min,
                        float& z_max) noexcept {
  const float vt = static_cast<float>(v) - 0.5f - cam.cy;
  const Eigen::Vector3f base = R * Eigen::Vector3f((u_mean - cam.cx) * z / cam.fx, 0.f, z) + t;
  const Eigen::Vector3f step = R.col(1) * (z / cam.fy);
  const float top = (base + step * vt).z(), bottom = (base + step * (vt + 1.f)).z();
  z_min = std::min({z_min, top, bottom});
  z_max = std::max({z_max, top, bottom});
}

}  // namespace dynamap::detail
