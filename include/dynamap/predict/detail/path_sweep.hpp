// Internal: include/dynamap/detail/ is installed because the predictors hold these types in their
// private members, but it is not a stable API. The swept-footprint check both predictors use, so
// their failure definitions are identical (docs/predictor.md, "Footprint sweep").
#pragma once

#include <cstddef>
#include <cstdint>

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
  std::size_t hit_chord = 0;   ///< first sample of the chord where the map's first hit lies
  /// Arc length of the far-field layer's first wall within the map's free distance; infinity
  /// when none (or no layer).
  float far_distance = kInfDistance;
  static constexpr float kInfDistance = 1e30f;
};

/// Which part of a path the map sweep covers. Paths that turn the same way share their arc up
/// to where the gentler one goes straight (PathLibrary::turn_end_sample), so the Markov
/// predictor sweeps that arc once: chords end at the shared samples (`breaks`) and a path whose
/// shared part is known free is swept from `start` on.
struct SweepSpan {
  std::size_t start = 0;     ///< first sample swept; the part before it is free (not checked)
  std::uint32_t breaks = 0;  ///< bit k set: no chord runs past sample k
};
static_assert(kMaxPathSamples <= 32, "SweepSpan::breaks holds one bit per sample");

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
                         const FarFieldLayer* far_field = nullptr,
                         const SweepSpan& span = SweepSpan{}) noexcept;

/// The far-field part of sweep_path alone, on a map result already known (`map_result`: the
/// map's free distance, free flag and hit chord for this path), looking at samples from
/// `far_start` on (the ones before are known to hold no remembered wall).
PathClearance add_far_field(const PathClearance& map_result, const PathSamples& path,
                            const ObstacleState& obstacle, const ClearanceConfig& clearance,
                            const FarFieldLayer* far_field, std::size_t far_start = 0) noexcept;

/// Ends `result`'s free distance at a far-field wall `far_distance` along the path (as
/// add_far_field does when it finds one there).
void block_at_far_wall(float far_distance, PathClearance* result) noexcept;

}  // namespace dynamap
