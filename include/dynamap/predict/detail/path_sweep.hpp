// Internal: include/dynamap/detail/ is installed because the predictors hold these types in their
// private members, but it is not a stable API. The swept-footprint check both predictors use, so
// their failure definitions are identical (docs/predictor.md, "Footprint sweep").
#pragma once

#include <cstddef>

#include "dynamap/predict/path_library.hpp"
#include "dynamap/predict/prediction.hpp"

namespace dynamap {

class FarFieldLayer;

/// Number of swept lines for a footprint of `radius` under `c`.
std::size_t clearance_lines(const ClearanceConfig& c, float radius) noexcept;

/// Result of sweeping one path.
struct PathClearance {
  float free_distance = 0.0f;  ///< m of arc length before the first hit; full length when free
  bool free = true;            ///< no occupied voxel met over the whole path
  /// m of arc length before the footprint first meets a voxel that is not observed free
  /// (unknown or occupied), <= free_distance; == free_distance when not measured.
  float observed_distance = 0.0f;
  bool depth_blocked = false;  ///< the depth image met a surface before the map's first hit
  bool far_blocked = false;    ///< the far-field layer met a wall before the map's first hit
};

/// What the depth check needs besides the frame: its settings and the obstacles whose pixels are
/// not walls (the predict() call's own list: the swept obstacle and every other walker).
struct DepthSweep {
  const DepthEvidence* evidence = nullptr;  ///< nullptr: no depth check
  DepthCheckConfig config{};
  const ObstacleState* obstacles = nullptr;
  std::size_t count = 0;

  bool active() const noexcept { return config.enabled && evidence != nullptr; }
};

/// Sweeps the obstacle's footprint along `path` (map top view, from PathLibrary::sample) and
/// returns the arc length travelled before the first occupied voxel and, when `observed` is set
/// (and the map view has the query), before the first voxel not observed free. Work: at most
/// (samples - 1) x lines x height_levels segment queries (lines = clearance_lines()) per measure,
/// fewer where samples merge into chords, stopping at the first chord that hits.
/// With an active `depth`, the same lines' points at every sample (up to the map's hit) are also
/// looked up in the depth image: free_distance becomes the smaller of the two, and the path is
/// free only when neither meets anything. Extra work: at most samples x lines x height_levels
/// pixel lookups, plus depth.count disc tests for each lookup that finds a surface.
/// With a `far_field` layer (far_field_layer.hpp), the swept lines' points at every sample (up
/// to the map's hit, lines at most one layer cell apart) are also looked up in it: a remembered
/// far wall ends the free distance there and the path is not free (far_blocked). Extra work: at
/// most samples x (2 radius / cell + 2) cell lookups.
PathClearance sweep_path(const OccupancyQuery& map, const PathSamples& path,
                         const ObstacleState& obstacle, const ClearanceConfig& clearance,
                         bool observed = false, const DepthSweep& depth = DepthSweep{},
                         const FarFieldLayer* far_field = nullptr) noexcept;

}  // namespace dynamap
