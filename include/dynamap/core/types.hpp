// Plain value types shared by every stage: camera model, depth image view, pose, boxes.
// All are fixed-size and trivially copyable so they can live in rings and static storage.
#pragma once

#include <cmath>
#include <cstdint>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "dynamap/core/status.hpp"

namespace dynamap {

/// Nanoseconds on the sensor's clock. Only differences matter.
using Stamp = std::uint64_t;

/// Pinhole model of the depth camera (optical frame: x right, y down, z forward).
struct CameraIntrinsics {
  float fx = 535.4f;
  float fy = 539.2f;
  float cx = 320.1f;
  float cy = 247.6f;
  int width = 640;
  int height = 480;
  float depth_scale = 0.001f;  ///< metres per depth unit (RealSense 0.001, TUM 1/5000)
};

/// Non-owning view of a 16-bit depth image; 0 means "no measurement".
struct DepthView {
  const std::uint16_t* data = nullptr;
  int width = 0;
  int height = 0;
  int stride_bytes = 0;  ///< bytes from the start of one row to the next

  const std::uint16_t* row(int v) const noexcept {
    return reinterpret_cast<const std::uint16_t*>(reinterpret_cast<const std::uint8_t*>(data) +
                                                  static_cast<std::ptrdiff_t>(v) * stride_bytes);
  }
  std::uint16_t at(int u, int v) const noexcept { return row(v)[u]; }
};

/// Rigid transform T_map_camera: maps camera-frame points into the map frame.
struct Pose {
  Eigen::Vector3f translation = Eigen::Vector3f::Zero();
  Eigen::Quaternionf rotation = Eigen::Quaternionf::Identity();  ///< must be unit length

  Eigen::Vector3f apply(const Eigen::Vector3f& p) const noexcept {
    return rotation * p + translation;
  }
  /// The inverse of apply(): a point of the outer frame (the map) in this pose's frame.
  Eigen::Vector3f apply_inverse(const Eigen::Vector3f& p) const noexcept {
    return rotation.conjugate() * (p - translation);
  }
};

/// Axis-aligned 3-D box by its corners (min <= max on every axis when valid).
struct Box3 {
  Eigen::Vector3f min = Eigen::Vector3f::Zero();
  Eigen::Vector3f max = Eigen::Vector3f::Zero();

  Eigen::Vector3f center() const noexcept { return 0.5f * (min + max); }
  Eigen::Vector3f size() const noexcept { return max - min; }
  bool contains(const Eigen::Vector3f& p) const noexcept {
    return (p.array() >= min.array()).all() && (p.array() <= max.array()).all();
  }
  static Box3 from_center_size(const Eigen::Vector3f& c, const Eigen::Vector3f& s) noexcept {
    return Box3{c - 0.5f * s, c + 0.5f * s};
  }
  /// Same centre, every extent multiplied by `factor`.
  Box3 scaled(float factor) const noexcept { return from_center_size(center(), factor * size()); }
};

/// Pixel box in the image, inclusive bounds.
struct ImageBox {
  int u0 = 0, v0 = 0, u1 = -1, v1 = -1;
};

/// Tolerance on |q| - 1 for a pose quaternion to count as unit length.
inline constexpr float kQuaternionNormTolerance = 1e-3f;

/// Checks a pose for NaN/inf and a unit quaternion.
inline Status validate_pose(const Pose& pose) noexcept {
  if (!pose.translation.allFinite() || !pose.rotation.coeffs().allFinite()) {
    return Status::kNonFinite;
  }
  if (std::fabs(pose.rotation.norm() - 1.0f) > kQuaternionNormTolerance) {
    return Status::kNonUnitQuaternion;
  }
  return Status::kOk;
}

/// Checks a depth view's own layout: non-null data aligned for uint16_t (kNullData /
/// kInvalidArgument), positive size, and a row stride of at least one row that is a whole number
/// of pixels (kWrongSize), so every row starts aligned and every pixel read is an aligned load.
inline Status validate_depth_layout(const DepthView& depth) noexcept {
  if (depth.data == nullptr) return Status::kNullData;
  if (reinterpret_cast<std::uintptr_t>(depth.data) % alignof(std::uint16_t) != 0) {
    return Status::kInvalidArgument;
  }
  if (depth.width <= 0 || depth.height <= 0) return Status::kWrongSize;
  if (depth.stride_bytes < depth.width * static_cast<int>(sizeof(std::uint16_t)) ||
      depth.stride_bytes % static_cast<int>(sizeof(std::uint16_t)) != 0) {
    return Status::kWrongSize;
  }
  return Status::kOk;
}

/// Checks a depth view against the camera model: validate_depth_layout(), and the camera's size.
inline Status validate_depth(const DepthView& depth, const CameraIntrinsics& cam) noexcept {
  if (depth.data == nullptr) return Status::kNullData;
  if (depth.width != cam.width || depth.height != cam.height) return Status::kWrongSize;
  return validate_depth_layout(depth);
}

}  // namespace dynamap
