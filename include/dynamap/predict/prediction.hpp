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
/// `bool first_occupied_on_segment(a, b, Eigen::Vector3f* hit) const noexcept` and, optionally,
/// `bool first_non_free_on_segment(a, b, Eigen::Vector3f* hit) const noexcept` (first voxel not
/// observed free): a context pointer plus plain function pointers, so tests can pass a fake world
/// and nothing is virtual. Without the second query (nullptr) every voxel that is not occupied
/// counts as observed free.
struct OccupancyQuery {
  using SegmentFn = bool (*)(const void* context, const Eigen::Vector3f& a,
                             const Eigen::Vector3f& b, Eigen::Vector3f* hit) noexcept;
  const void* context = nullptr;
  SegmentFn first_occupied_on_segment = nullptr;
  SegmentFn first_non_free_on_segment = nullptr;  ///< optional

  bool valid() const noexcept { return context != nullptr && first_occupied_on_segment != nullptr; }
  bool segment(const Eigen::Vector3f& a, const Eigen::Vector3f& b,
               Eigen::Vector3f* hit) const noexcept {
    return first_occupied_on_segment(context, a, b, hit);
  }
  bool knows_unknown() const noexcept { return first_non_free_on_segment != nullptr; }
  bool non_free_segment(const Eigen::Vector3f& a, const Eigen::Vector3f& b,
                        Eigen::Vector3f* hit) const noexcept {
    return knows_unknown() ? first_non_free_on_segment(context, a, b, hit) : segment(a, b, hit);
  }

  /// View of `map` (both queries), which must outlive the view.
  template <class Map>
  static OccupancyQuery of(const Map& map) noexcept {
    OccupancyQuery q = occupied_only(map);
    q.first_non_free_on_segment = [](const void* ctx, const Eigen::Vector3f& a,
                                     const Eigen::Vector3f& b, Eigen::Vector3f* hit) noexcept {
      return static_cast<const Map*>(ctx)->first_non_free_on_segment(a, b, hit);
    };
    return q;
  }
  /// View of `map` that only knows occupied voxels (everything else counts as observed free).
  template <class Map>
  static OccupancyQuery occupied_only(const Map& map) noexcept {
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

/// The current depth frame as a second, bounded source of environment knowledge for the sweep
/// (docs/predictor.md, "Options in more detail"). The map integrates hits only up to map.max_depth
/// (5 m) and needs a few frames to mark a surface occupied, while the tracker follows people to
/// ~8 m: a far walker's walls are unknown in the map, but they are in this frame. Each swept point
/// is projected into the image: more than the noise margin m(d) in front of the measured surface
/// it is seen free now; from there to m(d) + max(surface_thickness, the sample spacing) behind the
/// surface, the path meets something; farther behind it (occluded), outside the image, with no
/// return or out of the range below, the image knows nothing and the map's answer stands. (Only
/// "behind the surface by more than m(d)" was tried too: corridor walls seen at a grazing angle
/// then slip through, docs/notes/predictor-depth-check.md.) Pixels whose measured point is floor
/// (below the obstacle's bottom + ground_clearance) or lies on a predicted obstacle (within its
/// footprint radius + self_margin + m(d), top view: its own body and the other walkers) never
/// count as a surface.
struct DepthCheckConfig {
  bool enabled = false;  ///< false: the map alone decides (docs/design.md §4.6)
  /// Noise margin m(d) = noise_margin + noise_quadratic * d^2 of a pixel at depth d (stereo
  /// noise grows with d^2): a point that close in front of the surface counts as at it.
  float noise_margin = 0.05f;       ///< m, >= 0
  float noise_quadratic = 0.0042f;  ///< m per m^2, >= 0 (one sigma of a typical stereo camera)
  /// m behind the measured surface (beyond the margin) that still counts as inside the object;
  /// at least the path's sample spacing is used, so no surface is stepped over. The object's
  /// real thickness is unknown: much more makes a path just behind a thin pillar collide.
  float surface_thickness = 0.1f;
  float min_depth = 0.3f;  ///< m: nearer pixels (and points) are not used
  float max_depth = 8.0f;  ///< m: farther pixels are not used (> min_depth)
};

/// kInvalidArgument when a DepthCheckConfig field is out of range.
[[nodiscard]] Status validate(const DepthCheckConfig& c) noexcept;

/// Non-owning view of the frame being processed plus the camera model and pose: the pixels are
/// read in place (the frame must stay alive during predict(); Pipeline::process guarantees it).
struct DepthEvidence {
  DepthView depth{};
  CameraIntrinsics camera{};
  Eigen::Matrix3f R_cam_map = Eigen::Matrix3f::Identity();  ///< map -> camera rotation
  Eigen::Vector3f t_cam_map = Eigen::Vector3f::Zero();      ///< map -> camera translation
  Eigen::Vector3f origin = Eigen::Vector3f::Zero();         ///< camera centre, map frame

  /// View of `depth` taken with `camera` at `T_map_camera`.
  static DepthEvidence of(const DepthView& depth, const CameraIntrinsics& camera,
                          const Pose& T_map_camera) noexcept;
};

/// kNullData / kWrongSize (validate_depth), kNonFinite (pose or intrinsics) for an unusable view.
[[nodiscard]] Status validate(const DepthEvidence& e) noexcept;

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
  /// per path, m before the first voxel not observed free (== free_distance when not measured)
  std::array<float, kMaxPaths> observed_distance{};
  std::uint32_t free_mask = 0;  ///< bit i set when path i is collision-free
  /// bit i set when the depth image (DepthCheckConfig) met a surface on path i where the map
  /// held none (before the map's first hit, or on a path the map holds free)
  std::uint32_t depth_blocked_mask = 0;
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
/// The same, and then validate(*depth) when `depth` is given.
[[nodiscard]] Status validate_prediction_call(const ObstacleState* obstacles, std::size_t count,
                                              const OccupancyQuery& map, const DepthEvidence* depth,
                                              const PathPrediction* out) noexcept;

/// Copies `path` (map top view) into out->position/time/num_samples at height z.
void write_chosen_path(const PathSamples& path, float z, PathPrediction* out) noexcept;

}  // namespace dynamap
