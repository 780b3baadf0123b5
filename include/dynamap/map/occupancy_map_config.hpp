// OccupancyMapConfig and the map's compile-time bounds and counters: what a user of
// OccupancyMap (include/dynamap/map/occupancy_map.hpp) sets and reads, apart from the map's
// parts so that they can name it too.
#pragma once

#include <cstddef>
#include <cstdint>

#include <Eigen/Core>

#include "dynamap/core/constants.hpp"

namespace dynamap {

/// Compile-time capacity of the per-frame ray list: a 640x480 image sampled with stride 2.
inline constexpr std::size_t kMaxRaysPerFrame =
    static_cast<std::size_t>(kMaxImageWidth) * static_cast<std::size_t>(kMaxImageHeight) / 4;

/// Upper bound of OccupancyMapConfig::max_voxel_visits_per_frame (DDA steps per frame): room for
/// the exact walk of every pixel of a 640x480 frame (offline measurements use up to 20 M); the
/// pipeline bounds it far lower (kMaxPipelineVoxelVisitsPerFrame).
inline constexpr std::size_t kMaxVoxelVisitsPerFrame = 32'000'000;

/// Half extent of the map's local region per axis, in voxels (local_half_extent / resolution):
/// bounds one ray's walk to about 3 x this many voxels (default 50 / 50 / 30).
inline constexpr float kMaxLocalHalfExtentVoxels = 1000.f;

/// Upper bound of OccupancyMapConfig::carve_tiles.
inline constexpr int kMaxCarveTiles = 8;
/// Tiled carving needs the local block grid to have at most this many cells (the default
/// region has 3179); each tile's scratch holds one 512-bit mark set per cell it touches.
inline constexpr std::size_t kMaxTileCells = 4096;

/// Edge (pixels) of the image cells in which map.no_return_free_depth looks for no-return
/// regions.
inline constexpr int kNoReturnCellPixels = 16;
inline constexpr int kNoReturnCellsX =
    (kMaxImageWidth + kNoReturnCellPixels - 1) / kNoReturnCellPixels;
inline constexpr int kNoReturnCellsY =
    (kMaxImageHeight + kNoReturnCellPixels - 1) / kNoReturnCellPixels;

/// What the map knows about a voxel: free (p < 0.5), occupied (p > prob_occupied), or unknown
/// (never observed, or the evidence undecided in between).
enum class Occupancy : std::uint8_t { kUnknown = 0, kFree, kOccupied };

/// Parameters of OccupancyMap; probabilities, depths and sampling are the paper's (docs/design.md
/// §4.1). Probabilities are turned into log-odds at init(); init() rejects inconsistent values.
struct OccupancyMapConfig {
  float resolution = 0.1f;  ///< voxel edge (m)
  float prob_hit = 0.70f, prob_miss = 0.35f, prob_min = 0.12f, prob_max = 0.97f,
        prob_occupied = 0.80f;
  float min_depth = 0.5f;  ///< closer measurements are dropped entirely
  float max_depth = 5.0f;  ///< deeper measurements -> free-space ray truncated here (camera z)
  /// A pixel with no measurement (raw 0) is unknown: it neither hits nor carves, because on a
  /// real camera 0 mostly means "no valid match" (dark, shiny, edge, too near), not "nothing
  /// there". d > 0: a 0 pixel inside a large no-return region (its kNoReturnCellPixels-square cell
  /// and the 8 around it nearly all 0, as sky or a hall beyond range) carves free space up to
  /// camera depth d (<= max_depth). Default 0: never (docs/occupancy_map.md, "No return").
  float no_return_free_depth = 0.f;
  /// A ray carves no voxel any part of which lies within carve_gap_quadratic * z^2 (m, z its
  /// measured camera depth) of its return, also when cut at max_depth just short of it. Depth
  /// noise puts returns behind their surface; the last stretch of such a ray runs through the
  /// surface's own voxels. Default: 2 sigma of a stereo camera's noise (0.0042 z^2; 13 cm at
  /// 4 m). 0: up to the end voxel (docs/occupancy_map.md).
  float carve_gap_quadratic = 0.0084f;
  /// A hit ray does not carve the occupied voxels it crosses next to its end (walked from the
  /// end, until its first voxel that is not occupied): at a grazing angle the last stretch of a
  /// ray runs along its own surface's voxel layer, whose voxels the surface only partly fills.
  bool keep_own_surface = true;
  /// A ray lowers an unknown voxel, or one occupied for 3 x own_surface_min_frames, only when
  /// it passes within this share of the voxel edge of the voxel's centre (0: every voxel it
  /// crosses). A ray clipping a pillar's corner, or skimming a box top inside the voxel layer,
  /// says little about the voxel's middle; younger occupied voxels (a walker's old place) and
  /// free ones take every miss.
  float miss_max_offset = 0.35f;
  /// ... or within this share of the voxel edge times t / L, whichever is larger (t: the voxel's
  /// distance from the camera along the ray, L: the ray's length): merged rays are about a
  /// voxel apart at their ends, so near a ray's end the allowance grows to the whole voxel.
  float miss_offset_spread = 0.71f;
  /// keep_own_surface spares only voxels occupied for at least this many frames (0: any).
  int own_surface_min_frames = 30;
  /// A miss does not lower an occupied voxel with a never-observed face neighbour that lies
  /// beyond this frame's image edge or hidden behind the surface this frame measured there: a
  /// box face whose inside the camera never saw, lowered by rays along it at the view's side
  /// edge. A walker leaving the view looks the same, so not where set_trail()'s grid says a
  /// dynamic track has been.
  bool keep_unknown_backed = true;
  int pixel_margin = 2, pixel_stride = 2;
  Eigen::Vector3f local_half_extent{5.f, 5.f, 3.f};    ///< only this region around the camera is
                                                       ///< updated (rays are clipped to it)
  std::size_t max_blocks = kMaxMapBlocks;              ///< runtime capacity <= kMaxMapBlocks
  std::size_t max_rays_per_frame = kMaxRaysPerFrame;   ///< work cap, <= kMaxRaysPerFrame
  std::size_t max_voxel_visits_per_frame = 1'000'000;  ///< work cap on DDA steps per frame,
                                                       ///< <= kMaxVoxelVisitsPerFrame
  /// Cast one representative ray per distinct end voxel per frame (the other pixels ending in
  /// the same voxel would carve nearly the same voxels). false casts every sampled pixel.
  bool merge_rays_per_voxel = true;
  /// Early-stop free-space carving: 0 walks every free ray from the camera to its end (exact).
  /// N > 0 walks each ray from its end back towards the camera (rays coarse to fine over the
  /// image) and stops it after N consecutive voxels that an earlier ray of this frame already
  /// marked missed (the near parts of the rays overlap). Approximate: a voxel that only the
  /// stopped part of a ray would cross misses this frame's update. Hits are never affected.
  /// Default 12; why, and what it costs against the exact walk: docs/occupancy_map.md.
  int free_ray_early_stop = 12;
  /// Free-space carving split into this many column strips of the image (tiles), each walked
  /// on its own against its own marks, the marks then merged as a set union and applied once
  /// per voxel. 0 (default): one walk over all rays, today's result. T in 1..kMaxCarveTiles:
  /// the result depends on T but not on the team that carves (docs/occupancy_map.md, "Tiled
  /// carving"). Only tiled carving runs on a lent team's several members. Needs the local
  /// block grid (at most kMaxTileCells cells).
  int carve_tiles = 0;
};

/// Counters of the last integrate() call (work done, work dropped by caps, pool churn).
struct IntegrationStats {
  std::size_t rays = 0;           ///< rays traversed (after merging)
  std::size_t rays_dropped = 0;   ///< rays not (fully) traversed: ray/visit cap or pool full
  std::size_t voxel_visits = 0;   ///< DDA steps
  std::size_t voxel_updates = 0;  ///< updates applied (hits + misses, <= 1 per voxel; a
                                  ///< clamped voxel counts even if its value stays)
  std::size_t blocks_allocated = 0;
  std::size_t blocks_evicted = 0;
  // Added beyond the shared contract:
  std::size_t pixels_sampled = 0;      ///< sampled pixels that produced a ray (hit or free)
  std::size_t rays_merged = 0;         ///< pixels whose ray was merged into another one
  std::size_t hits = 0;                ///< hit updates applied
  std::size_t updates_dropped = 0;     ///< voxel updates lost because no block could be allocated
  std::size_t rays_stopped_early = 0;  ///< free_ray_early_stop: rays stopped before the camera
};

}  // namespace dynamap
