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
  bool far_blocked = false;    ///< the far-field layer met a wall before the map's first hit
};

/// Sweeps the obstacle's footprint along `path` (map top view, from PathLibrary::sample) and
/// returns the arc length travelled before the first occupied voxel. Work: at most
/// (samples - 1) x lines x height_levels segment queries (lines = clearance_lines()), fewer
/// where samples merge into chords, stopping at the first chord that hits.
/// With a `far_field` layer (far_field_layer.hpp), the swept lines' points at every sample (up
/// to the map's hit, lines at most one layer cell apart) are also looked up in it: a remembered
/// far wall ends the free distance there and the path is not free (far_blocked). Extra work: at
/// most samples x (2 radius / cell + 2) cell lookups.
PathClearance sweep_path(const OccupancyQuery& map, const PathSamples& path,
                         const ObstacleState& obstacle, const ClearanceConfig& clearance,
                         const FarFieldLayer* far_field = nullptr) noexcept;

}  // namespace dynamap
