// PathLibrary: the l candidate paths of the trajectory predictor, generated analytically.
// Curvature family ("turn, then go straight"): path i turns at constant curvature
// turn_curvature until its heading has changed by theta_i, then continues straight, where
// theta_i is evenly spaced from +max_heading_change (index 0, sharpest left) through 0 (the
// centre, straight) to -max_heading_change (index l-1, sharpest right). All paths have the same
// arc length, so their free distances are directly comparable.
#pragma once

#include <array>
#include <cstddef>

#include <Eigen/Core>

#include "dynamap/core/constants.hpp"
#include "dynamap/core/status.hpp"

namespace dynamap {

/// Shape and horizon of the candidate paths (docs/design.md §4.6).
struct PathLibraryConfig {
  /// l, 1..kMaxPaths. Nine paths 45 degrees apart, from a U-turn left to a U-turn right: a
  /// walker facing a wall or a dead end turns back, and a library that stops at 90 degrees has
  /// no free path for it.
  std::size_t num_paths = 9;
  float max_heading_change = 3.14159265f;  ///< rad, heading change of the outermost paths, [0, pi]
  float turn_curvature = 1.0f;             ///< 1/m while turning (1 m radius: a walker's corner)
  float horizon_distance = 3.0f;           ///< m of travel at the current speed ...
  float slow_speed = 0.1f;                 ///< m/s; ... unless slower than this, then
  float slow_horizon_time = 2.0f;          ///< s of travel
  float sample_interval = 0.1f;            ///< s, upper bound on the spacing of samples in time
};

/// How far ahead one obstacle's paths reach: the same for every path of the library.
struct PathHorizon {
  float duration = 0.0f;    ///< s
  float length = 0.0f;      ///< m of arc length
  std::size_t samples = 0;  ///< samples including t = 0, 2..kMaxPathSamples, evenly spaced
};

/// One sampled path: positions, unit travel directions, times and arc lengths per sample.
/// The frame is whatever the producing call says (velocity frame or map top view).
struct PathSamples {
  std::size_t count = 0;
  std::array<Eigen::Vector2f, kMaxPathSamples> position;
  std::array<Eigen::Vector2f, kMaxPathSamples> tangent;
  std::array<float, kMaxPathSamples> time{};        ///< s from now
  std::array<float, kMaxPathSamples> arc_length{};  ///< m from the start
};

/// The candidate path family. Immutable after init(); sampling is allocation-free and costs one
/// sin/cos pair per path (samples along the arc use a rotation recurrence).
class PathLibrary {
 public:
  /// kInvalidArgument (and nothing changes) when a parameter is out of range or non-finite.
  [[nodiscard]] Status init(const PathLibraryConfig& config) noexcept;

  const PathLibraryConfig& config() const noexcept { return config_; }
  std::size_t size() const noexcept { return config_.num_paths; }
  /// Index of the straight path; fractional (between two paths) when l is even.
  float center_index() const noexcept { return 0.5f * static_cast<float>(config_.num_paths - 1); }
  /// Total heading change of path i, rad, positive = left (counter-clockwise seen from above).
  float heading_change(std::size_t i) const noexcept;

  /// Horizon for an obstacle moving at `speed` m/s.
  PathHorizon horizon(float speed) const noexcept;

  /// Last sample of path i, at `speed`, still on its turning arc (0 for the straight path). Paths
  /// turning the same way have bit-identical samples up to the gentler one's turn end.
  std::size_t turn_end_sample(std::size_t i, float speed) const noexcept;

  /// Samples path i in the velocity frame (x along the velocity, y to its left) for `speed`.
  void sample_local(std::size_t i, float speed, PathSamples* out) const noexcept;

  /// Samples path i in the map's top view for an obstacle at `origin` moving with `velocity`.
  /// A (near) zero velocity uses +x as heading; the path then has (near) zero length.
  void sample(std::size_t i, const Eigen::Vector2f& origin, const Eigen::Vector2f& velocity,
              PathSamples* out) const noexcept;

 private:
  PathLibraryConfig config_{};
};

}  // namespace dynamap
