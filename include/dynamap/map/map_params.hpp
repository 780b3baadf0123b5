// Parameter tables of the map stage: Occupancy map, map refiner, ever-free grid and dynamic-region
// cleaner. One row per config field (core/parameter.hpp): member path, unit, valid range, tier,
// help; the default is the struct's member initialiser. The configs' validate() checks these
// ranges; the pipeline assembles the tables into PipelineConfig's (src/pipeline/parameters.cpp).
#pragma once

#include "dynamap/core/parameter.hpp"
#include "dynamap/map/dynamic_region_cleaner.hpp"
#include "dynamap/map/ever_free_grid.hpp"
#include "dynamap/map/map_refiner.hpp"
#include "dynamap/map/occupancy_map.hpp"
#include "dynamap/map/trail_grid.hpp"

namespace dynamap::params {
using namespace param_rows;  // NOLINT(google-build-using-namespace): U, C, X, kOpen, ...

/// Map voxel size range (m).
inline constexpr float kMinMapResolution = 0.01f;
inline constexpr float kMaxMapResolution = 10.f;

/// The parameters of OccupancyMapConfig, one row per field (PipelineConfig prefix "map.").
inline constexpr Param<OccupancyMapConfig> kOccupancyMap[] = {
    // clang-format off
    {DYNAMAP_PARAM(OccupancyMapConfig, resolution), U, "m", kMinMapResolution, kMaxMapResolution, kClosed, kClosed, "voxel edge"},
    {DYNAMAP_PARAM(OccupancyMapConfig, prob_hit), X, "", 0.5, 1, kOpen, kOpen, "occupancy probability of a hit"},
    {DYNAMAP_PARAM(OccupancyMapConfig, prob_miss), X, "", 0, 0.5, kOpen, kOpen, "occupancy probability of a miss (ray passes through)"},
    {DYNAMAP_PARAM(OccupancyMapConfig, prob_min), X, "", 0x1p-20, 0.5, kClosed, kOpen, "lower clamp of a voxel's probability"},
    {DYNAMAP_PARAM(OccupancyMapConfig, prob_max), X, "", 0.5, 1, kOpen, kOpen, "upper clamp of a voxel's probability"},
    {DYNAMAP_PARAM(OccupancyMapConfig, prob_occupied), X, "", 0, 1, kOpen, kOpen, "a voxel at or above this is occupied"},
    {DYNAMAP_PARAM(OccupancyMapConfig, min_depth), X, "m", 0, kInf, kClosed, kOpen, "nearer measurements are dropped"},
    {DYNAMAP_PARAM(OccupancyMapConfig, max_depth), U, "m", 0, kInf, kOpen, kOpen, "map range: deeper pixels carve free space up to this depth only"},
    {DYNAMAP_PARAM(OccupancyMapConfig, no_return_free_depth), X, "m", 0, kInf, kClosed, kOpen, "0: a pixel with no measurement (0) is unknown; d > 0: 0 pixels inside large no-return regions (sky, a hall beyond range) carve free space up to d (<= map.max_depth)"},
    {DYNAMAP_PARAM(OccupancyMapConfig, carve_gap_quadratic), U, "1/m", 0, kInf, kClosed, kOpen, "a ray carves no voxel within this x depth^2 of its measured return, also one cut at map.max_depth: two sigma of the camera's depth noise (0: up to the end voxel)"},
    {DYNAMAP_PARAM(OccupancyMapConfig, keep_own_surface), X, "", 0, 1, kClosed, kClosed, "a hit ray does not carve the occupied voxels next to its end (its own surface seen at a grazing angle)"},
    {DYNAMAP_PARAM(OccupancyMapConfig, miss_max_offset), X, "voxel", 0, 0.87f, kClosed, kClosed, "a ray lowers an unknown voxel, or one occupied for 3 x map.own_surface_min_frames, only when it passes this close to the voxel's centre, in voxel edges (0: every voxel it crosses)"},
    {DYNAMAP_PARAM(OccupancyMapConfig, miss_offset_spread), X, "voxel", 0, 0.87f, kClosed, kClosed, "... or this close times (distance from the camera / ray length), whichever is larger: merged rays are about a voxel apart at their ends"},
    {DYNAMAP_PARAM(OccupancyMapConfig, keep_unknown_backed), X, "", 0, 1, kClosed, kClosed, "a miss does not lower an occupied voxel with a never-observed face neighbour beyond the image's edge or hidden behind this frame's surface (a box face whose inside the camera never saw), except where a dynamic track has been (trail.*)"},
    {DYNAMAP_PARAM(OccupancyMapConfig, own_surface_min_frames), X, "frames", 0, 65535, kClosed, kClosed, "map.keep_own_surface spares only voxels occupied at least this long (0: any)"},
    {DYNAMAP_PARAM(OccupancyMapConfig, pixel_margin), X, "px", 0, kMaxImageHeight, kClosed, kClosed, "image border left out of the map update"},
    {DYNAMAP_PARAM(OccupancyMapConfig, pixel_stride), C, "px", 1, kMaxImageWidth, kClosed, kClosed, "every n-th pixel of every n-th row is a ray"},
    {DYNAMAP_PARAM(OccupancyMapConfig, local_half_extent), U, "m", 0, kInf, kOpen, kOpen, "only this box around the camera is updated (per axis, <= 1000 voxels)"},
    {DYNAMAP_PARAM(OccupancyMapConfig, max_blocks), C, "", 1, kMaxMapBlocks, kClosed, kClosed, "voxel blocks the hashed grid may hold (memory is reserved for kMaxMapBlocks)"},
    {DYNAMAP_PARAM(OccupancyMapConfig, max_rays_per_frame), C, "", 1, kMaxRaysPerFrame, kClosed, kClosed, "work cap: rays cast per frame"},
    {DYNAMAP_PARAM(OccupancyMapConfig, max_voxel_visits_per_frame), C, "", 1, kMaxVoxelVisitsPerFrame, kClosed, kClosed, "work cap: voxel steps of all rays per frame"},
    {DYNAMAP_PARAM(OccupancyMapConfig, merge_rays_per_voxel), X, "", 0, 1, kClosed, kClosed, "cast one ray per distinct end voxel instead of one per pixel"},
    {DYNAMAP_PARAM(OccupancyMapConfig, free_ray_early_stop), X, "voxels", 0, kInf, kClosed, kOpen, "stop a free ray after this many voxels an earlier ray marked (0: exact walk)"},
    {DYNAMAP_PARAM(OccupancyMapConfig, carve_tiles), X, "", 0, kMaxCarveTiles, kClosed, kClosed, "free-space carving in this many image column strips (0: one walk; the map depends on it, not on team.members)"},
    // clang-format on
};
static_assert(paths_unique(kOccupancyMap));

/// Relations between OccupancyMapConfig fields, checked by OccupancyMap::init() after the ranges
/// and named by the pipeline's validate(). The tiled-carving grid bound (kMaxTileCells) stays in
/// init() and pipeline_config.cpp.
inline constexpr Relation<OccupancyMapConfig> kOccupancyMapRelations[] = {
    {"prob_min", "must be < map.prob_miss",
     [](const OccupancyMapConfig& c) noexcept { return c.prob_min < c.prob_miss; }},
    {"prob_max", "must be > map.prob_hit",
     [](const OccupancyMapConfig& c) noexcept { return c.prob_hit < c.prob_max; }},
    {"prob_occupied", "must be in [map.prob_min, map.prob_max)",
     [](const OccupancyMapConfig& c) noexcept {
       return c.prob_min <= c.prob_occupied && c.prob_occupied < c.prob_max;
     }},
    {"max_depth", "must be > map.min_depth",
     [](const OccupancyMapConfig& c) noexcept { return c.max_depth > c.min_depth; }},
    {"no_return_free_depth", "must be <= map.max_depth",
     [](const OccupancyMapConfig& c) noexcept { return c.no_return_free_depth <= c.max_depth; }},
    // Keeps the whole local region far inside the key range and bounds every ray's walk.
    {"local_half_extent",
     "must be <= kMaxLocalHalfExtentVoxels (1000) x map.resolution on every axis "
     "(bounds the length of every ray)",
     [](const OccupancyMapConfig& c) noexcept {
       return (c.local_half_extent.array() <= kMaxLocalHalfExtentVoxels * c.resolution).all();
     }},
    // Each tile's scratch holds a mark set per cell of the local block grid.
    {"local_half_extent",
     "too large for tiled carving: the local block grid must have at most kMaxTileCells "
     "(4096) cells when map.carve_tiles > 0",
     [](const OccupancyMapConfig& c) noexcept {
       return c.carve_tiles == 0 || OccupancyMap::local_grid_cells(c) <= kMaxTileCells;
     }},
};

/// The parameters of MapRefinerConfig, one row per field (PipelineConfig prefix "refiner.").
inline constexpr Param<MapRefinerConfig> kMapRefiner[] = {
    // clang-format off
    {DYNAMAP_PARAM(MapRefinerConfig, inflate), X, "", 1, 10, kClosed, kClosed, "raw box extents are grown by this before the map search"},
    {DYNAMAP_PARAM(MapRefinerConfig, floor_margin), X, "m", 0, kInf, kClosed, kOpen, "voxels below ground_height + this are floor"},
    {DYNAMAP_PARAM(MapRefinerConfig, max_voxels_per_box), C, "", 1, kMaxRefinerVoxelsPerBox, kClosed, kClosed, "work cap: voxels examined per box and pass"},
    {DYNAMAP_PARAM(MapRefinerConfig, min_support_voxels), X, "", 1, kInf, kClosed, kOpen, "fewer occupied voxels keep the raw box"},
    {DYNAMAP_PARAM(MapRefinerConfig, static_frames), X, "frames", 0, kMaxStaticFrames, kClosed, kClosed, "a voxel occupied this long counts as long-seen for Detection::static_share"},
    // clang-format on
};
static_assert(paths_unique(kMapRefiner));

/// The parameters of EverFreeConfig, one row per field (PipelineConfig prefix "ever_free.").
inline constexpr Param<EverFreeConfig> kEverFree[] = {
    // clang-format off
    {DYNAMAP_PARAM(EverFreeConfig, enabled), X, "", 0, 1, kClosed, kClosed, "keep the ever-free grid and use it as dynamic evidence"},
    {DYNAMAP_PARAM(EverFreeConfig, resolution), X, "m", 0.05, 1, kClosed, kClosed, "cell edge"},
    {DYNAMAP_PARAM(EverFreeConfig, z_min), X, "m", -10, 10, kClosed, kClosed, "bottom of the lowest layer above the ground"},
    {DYNAMAP_PARAM(EverFreeConfig, layers), C, "", 1, kEverFreeMaxLayers, kClosed, kClosed, "vertical layers"},
    {DYNAMAP_PARAM(EverFreeConfig, pixel_step), C, "px", 1, 64, kClosed, kClosed, "one ray every this many pixels in u and v"},
    {DYNAMAP_PARAM(EverFreeConfig, max_range), X, "m", 0, 20, kOpen, kClosed, "rays are walked at most this far"},
    {DYNAMAP_PARAM(EverFreeConfig, surface_margin), X, "m", 0, kInf, kClosed, kOpen, "free marking stops this far short of the surface"},
    {DYNAMAP_PARAM(EverFreeConfig, margin_per_range2), X, "1/m", 0, kInf, kClosed, kOpen, "plus this times range^2"},
    {DYNAMAP_PARAM(EverFreeConfig, burn_in_frames), X, "frames", 1, 255, kClosed, kClosed, "observed-free frames in a row to become ever free"},
    {DYNAMAP_PARAM(EverFreeConfig, forget_frames), X, "frames", 1, 255, kClosed, kClosed, "hit frames in a row to stop being ever free"},
    {DYNAMAP_PARAM(EverFreeConfig, whole_in_view), X, "", 0, 4, kClosed, kClosed, "a cell's free run makes it ever free only once the whole cell was seen free inside these sides of the view: 0 off, 2 left and right, 4 all four; 1 and 3 are refused (a cell the image border cuts may hold something just beyond it)"},
    // clang-format on
};
static_assert(paths_unique(kEverFree));

/// The parameters of TrailGridConfig, one row per field (PipelineConfig prefix "trail.").
inline constexpr Param<TrailGridConfig> kTrailGrid[] = {
    // clang-format off
    {DYNAMAP_PARAM(TrailGridConfig, resolution), X, "m", 0.05, 2, kClosed, kClosed, "cell edge of the grid of where dynamic tracks have been (the grid spans 64 cells per axis and wraps)"},
    {DYNAMAP_PARAM(TrailGridConfig, frames), X, "frames", 1, 100000, kClosed, kClosed, "a dynamic track's box keeps map.keep_unknown_backed off under it this long"},
    {DYNAMAP_PARAM(TrailGridConfig, margin), X, "m", 0, 2, kClosed, kClosed, "added around each box"},
    // clang-format on
};
static_assert(paths_unique(kTrailGrid));

/// The parameters of DynamicRegionCleanerConfig, one row per field (PipelineConfig prefix
/// "cleaner.").
inline constexpr Param<DynamicRegionCleanerConfig> kDynamicRegionCleaner[] = {
    // clang-format off
    {DYNAMAP_PARAM(DynamicRegionCleanerConfig, frames), X, "frames", 1, kMaxBoxHistory, kClosed, kClosed, "f: past boxes per dynamic track that are cleared"},
    {DYNAMAP_PARAM(DynamicRegionCleanerConfig, inflation), X, "", 1, kInf, kClosed, kOpen, "horizontal growth of a cleared box about its centre"},
    {DYNAMAP_PARAM(DynamicRegionCleanerConfig, z_margin), X, "m", 0, kInf, kClosed, kOpen, "added below and above a cleared box"},
    {DYNAMAP_PARAM(DynamicRegionCleanerConfig, older_boxes_per_frame), X, "", 0, kMaxBoxHistory, kClosed, kClosed, "older boxes revisited per track and frame"},
    {DYNAMAP_PARAM(DynamicRegionCleanerConfig, keep_static), X, "", 0, 1, kClosed, kClosed, "never clear voxels occupied since before a dynamic track started (static structure)"},
    {DYNAMAP_PARAM(DynamicRegionCleanerConfig, static_margin_frames), X, "frames", 0, 100000, kClosed, kClosed, "occupied this many frames before the track started counts as static"},
    {DYNAMAP_PARAM(DynamicRegionCleanerConfig, min_dynamic_frames), X, "frames", 1, kMaxBoxHistory, kClosed, kClosed, "a track clears only once it has been dynamic this many frames in a row (its boxes wait in the history)"},
    {DYNAMAP_PARAM(DynamicRegionCleanerConfig, early_min_dynamic_frames), X, "frames", 1, kMaxBoxHistory, kClosed, kClosed, "the same for a track started in the run's first static_margin_frames frames (nothing there is old enough for keep_static)"},
    {DYNAMAP_PARAM(DynamicRegionCleanerConfig, max_voxels_per_frame), C, "", 1, kMaxCleanerVoxelsPerFrame, kClosed, kClosed, "work cap: voxels examined per frame"},
    {DYNAMAP_PARAM(DynamicRegionCleanerConfig, max_purge_per_frame), C, "", 1, kCleanHistoryCapacity, kClosed, kClosed, "work cap: expired history entries purged per frame"},
    // clang-format on
};
static_assert(paths_unique(kDynamicRegionCleaner));

/// Relations between DynamicRegionCleanerConfig fields, checked by its validate() after the
/// ranges and named by the pipeline's validate().
inline constexpr Relation<DynamicRegionCleanerConfig> kDynamicRegionCleanerRelations[] = {
    {"min_dynamic_frames", "must be < cleaner.frames (the boxes must still be there)",
     [](const DynamicRegionCleanerConfig& c) noexcept { return c.min_dynamic_frames < c.frames; }},
    {"early_min_dynamic_frames", "must be < cleaner.frames (the boxes must still be there)",
     [](const DynamicRegionCleanerConfig& c) noexcept {
       return c.early_min_dynamic_frames < c.frames;
     }},
};

}  // namespace dynamap::params
