// Types shared by the trajectory predictors (Markov and linear): the per-obstacle input, the
// per-obstacle output, a non-owning collision-query view of a map, and the swept-footprint
// free-distance check that both predictors use (so their failure definitions are identical).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>

#include <Eigen/Core>

#include "dynamap/core/constants.hpp"
#include "dynamap/core/status.hpp"
#include "dynamap/core/types.hpp"
#include "dynamap/predict/path_library.hpp"

namespace dynamap {

/// What the predictors need to know about one dynamic obstacle (from its track).
struct ObstacleState {
  std::uint32_t track_id = 0;
  Eigen::Vector3f position = Eigen::Vector3f::Zero();  ///< box centre, map frame
  Eigen::Vector2f velocity = Eigen::Vector2f::Zero();  ///< m/s in the map's x-y plane
  float footprint_radius = 0.3f;                       ///< m, clearance kept from the static map
  float height = 1.8f;                                 ///< m, vertical extent of the box
  /// m added to ClearanceConfig::self_margin for this obstacle, >= 0: its own hits scatter
  /// farther from its box the farther it is from the camera (Pipeline sets it from the range).
  float body_margin = 0.0f;
};

/// Non-owning, type-erased view of anything with OccupancyMap's
/// `bool first_occupied_on_segment(a, b, Eigen::Vector3f* hit) const noexcept`: a context pointer
/// plus a plain function pointer, so tests can pass a fake world and nothing is virtual.
struct OccupancyQuery {
  using SegmentFn = bool (*)(const void* context, const Eigen::Vector3f& a,
                             const Eigen::Vector3f& b, Eigen::Vector3f* hit) noexcept;
  const void* context = nullptr;
  SegmentFn first_occupied_on_segment = nullptr;

  bool valid() const noexcept { return context != nullptr && first_occupied_on_segment != nullptr; }
  bool segment(const Eigen::Vector3f& a, const Eigen::Vector3f& b,
               Eigen::Vector3f* hit) const noexcept {
    return first_occupied_on_segment(context, a, b, hit);
  }

  /// View of `map`, which must outlive the view.
  template <class Map>
  static OccupancyQuery of(const Map& map) noexcept {
    OccupancyQuery q;
    q.context = &map;
    q.first_occupied_on_segment = [](const void* ctx, const Eigen::Vector3f& a,
                                     const Eigen::Vector3f& b, Eigen::Vector3f* hit) noexcept {
      return static_cast<const Map*>(ctx)->first_occupied_on_segment(a, b, hit);
    };
    return q;
  }
};

inline constexpr std::size_t kMaxClearanceLines = 9;
inline constexpr std::size_t kMaxHeightLevels = 4;

/// How the obstacle's swept footprint is checked against the map. The footprint is swept as
/// polylines parallel to the path, evenly spread over [-radius, +radius] across it, at most
/// `line_spacing` apart (the centre line alone for radius 0) and at most `max_lines` of them
/// (wider spacing beyond that), at `height_levels` heights spread over the body above the ground
/// clearance. Consecutive samples are merged into one chord while the chord stays within
/// `chord_tolerance` of the path (whole straight parts become one chord), and each chord of each
/// line is one exact 3-D DDA query, so nothing is stepped over along the path; with
/// line_spacing <= the map resolution nothing slips between lines either.
struct ClearanceConfig {
  float line_spacing = 0.1f;                   ///< m between swept lines (map resolution)
  std::size_t max_lines = kMaxClearanceLines;  ///< 1..kMaxClearanceLines: caps the work
  std::size_t height_levels = 1;               ///< 1..kMaxHeightLevels
  float chord_tolerance = 0.02f;  ///< m a merged chord may deviate from the path (0: straight only)
  float ground_clearance = 0.2f;  ///< m above the box bottom that is not checked (floor voxels)
  /// m beyond the footprint radius around the obstacle's current centre that is not checked: the
  /// map still holds the obstacle's own body (this frame's hits, a lagging or size-corrected
  /// box, the cleaner's margin), and without this every path "collides" within 0.0-0.4 m.
  /// 0 disables it (every voxel along the path counts, also inside the body).
  float self_margin = 0.15f;
  /// m per m^2 of the obstacle's range from the camera (capped at map.max_depth) that Pipeline
  /// adds to self_margin as ObstacleState::body_margin: a far walker's own hits scatter along the
  /// ray by the depth noise, which grows with range squared (2 sigma of a stereo camera's range
  /// term; 0.21 m at 5 m). Without it a walker coming towards the camera from 4-5 m "collides"
  /// with its own front on every path. 0 disables it.
  float self_range_margin = 0.0084f;
};

/// kInvalidArgument when a ClearanceConfig field is out of range.
[[nodiscard]] Status validate(const ClearanceConfig& c) noexcept;
/// kNonFinite / kInvalidArgument when an obstacle's numbers are unusable.
[[nodiscard]] Status validate(const ObstacleState& o) noexcept;

/// One obstacle's prediction. For the linear predictor num_paths is 1.
struct PathPrediction {
  std::uint32_t track_id = 0;
  std::size_t num_paths = 0;
  /// index of the most likely path (Markov with choose_free: of the free ones, if any is free)
  std::size_t chosen = 0;
  std::array<float, kMaxPaths> probability{};    ///< per path, sums to 1
  std::array<float, kMaxPaths> free_distance{};  ///< per path, m (== path_length when free)
  std::uint32_t free_mask = 0;                   ///< bit i set when path i is collision-free
  /// bit i set when the far-field layer met a remembered wall on path i where the map held none
  std::uint32_t far_blocked_mask = 0;
  float path_length = 0.0f;  ///< m, arc length of every path
  std::size_t num_samples = 0;
  std::array<Eigen::Vector3f, kMaxPathSamples> position;  ///< chosen path, map frame
  std::array<float, kMaxPathSamples> time{};              ///< s after the input's time
  bool any_free = false;                                  ///< at least one path is collision-free
  bool failed = false;  ///< the chosen path collides (always so when no path is free)

  bool path_free(std::size_t i) const noexcept { return ((free_mask >> i) & 1u) != 0; }
};

/// Checks one predict() call's arguments before any state is touched: kCapacityExceeded
/// (count > kMaxTracks), kNullData (null arrays with count > 0, invalid map view), then each
/// obstacle's validate(). Shared by both predictors so their errors are identical.
[[nodiscard]] Status validate_prediction_call(const ObstacleState* obstacles, std::size_t count,
                                              const OccupancyQuery& map,
                                              const PathPrediction* out) noexcept;

/// Copies `path` (map top view) into out->position/time/num_samples at height z.
void write_chosen_path(const PathSamples& path, float z, PathPrediction* out) noexcept;

}  // namespace dynamap
