// Map accuracy against the truth (docs/evaluation.md, "Map accuracy"), in the way of the KTH
// DynamicMap benchmark: SA (static accuracy), DA (dynamic accuracy), AA = sqrt(SA * DA), scored
// on the final map a replay wrote (map.ply) against the true static world (static_world.txt) and
// the walkers' boxes (obstacles.txt), over the voxels the camera observed; plus the per-frame
// erased-obstacle and free-through-obstacle counts of the replay's map_frames.csv.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <unordered_set>
#include <vector>

#include <Eigen/Core>

namespace dynamap::tools::eval {

using VoxelSet = std::unordered_set<std::int64_t>;  ///< pack_voxel() keys

/// What the camera observed, as voxels of the map's grid (see observe_sequence()).
struct MapObservation {
  double resolution = 0.1;
  VoxelSet static_surface;  ///< surface voxels of boxes and cylinders with an end point in them
  VoxelSet floor;           ///< floor voxels with an end point in them
  VoxelSet walker;          ///< voxels with an end point inside a walker's box at that frame
  std::size_t frames = 0, end_points = 0;
};

/// An axis-aligned box (a walker's at the final frame).
struct AlignedBox {
  Eigen::Vector3d min = Eigen::Vector3d::Zero(), max = Eigen::Vector3d::Zero();
};

struct MapAccuracy {
  bool available = false;  ///< scored (static_world.txt and map.ply were there)
  std::size_t static_observed = 0, static_held = 0, static_held_strict = 0;
  std::size_t shape_observed = 0, shape_held = 0;  ///< boxes and cylinders only
  std::size_t floor_observed = 0, floor_held = 0;
  std::size_t walker_observed = 0;  ///< after leaving out those in a final-frame walker box
  std::size_t walker_cleared = 0;   ///< of those, not held occupied
  std::size_t walker_in_final = 0;  ///< left out: in a walker's box at the final frame
  double sa = 0, sa_strict = 0, sa_shapes = 0, sa_floor = 0, da = 0, aa = 0;  ///< NaN: no data
  std::vector<Eigen::Vector3d> missing_static;  ///< observed static voxels not held (centres)
  std::vector<Eigen::Vector3d> held_walker;     ///< walker voxels still held (centres)
  // From map_frames.csv (frames_available false when absent).
  bool frames_available = false;
  std::size_t checked_frames = 0;
  std::size_t erased_max = 0, free_through_max = 0;  ///< within 3 m of the camera
  std::size_t erased_all_max = 0, free_through_all_max = 0;
  std::size_t free_through_final = 0, free_through_final_all = 0;
  /// Erased voxels with no occupied neighbour (columns absent in older files: not available).
  bool bare_available = false;
  std::size_t erased_bare_max = 0, erased_bare_all_max = 0;
  /// Free-through voxels wholly inside a shape (columns absent in older files: not available).
  bool whole_available = false;
  std::size_t free_through_whole_max = 0, free_through_whole_all_max = 0;
  std::string settings;  ///< where the sampling and range settings came from
};

/// SA, SA strict, DA, AA from the observed voxels and the map's occupied voxels (pack_voxel keys
/// on the same grid). A static voxel is held when it or one of its 26 neighbours is occupied
/// (strict: the voxel itself); a walker voxel counts unless it touches a box of `final_walkers`.
MapAccuracy score_map(const MapObservation& observed, const VoxelSet& occupied,
                      const std::vector<AlignedBox>& final_walkers);

/// How observe_sequence() samples depth images: the map's settings (map_summary.txt).
struct ObservationSettings {
  double resolution = 0.1, min_depth = 0.5, max_depth = 5.0;
  int pixel_stride = 2, pixel_margin = 2;
  Eigen::Vector3d local_half_extent{5, 5, 3};
  double floor_clearance = 0.15;  ///< m above the floor: lower walker end points are floor hits
};

/// The whole --map evaluation of dynamap-eval: reads RESULT/map.ply, RESULT/map_summary.txt
/// (else the map's defaults, said in `settings`), RESULT/map_frames.csv (optional),
/// RESULT/timing.csv (the replayed frames; else every frame), SEQ/static_world.txt,
/// SEQ/obstacles.txt (or `obstacles_file`) and the sequence's depth images. Throws ToolError
/// naming the file when SEQ/static_world.txt or RESULT/map.ply is missing or malformed.
MapAccuracy evaluate_map(const std::string& seq_dir, const std::string& result_dir,
                         const std::string& obstacles_file = "");

/// map_frames.csv's maxima and final values into `r`.
void read_map_frames(const std::string& path, MapAccuracy& r);

/// Lines for dynamap-eval's table.
std::string format_map_table(const MapAccuracy& r);

/// The picture: static world, map cells, missing static voxels (red), walker voxels still held
/// (orange).
void write_map_picture(const std::string& png_path, const std::string& seq_dir,
                       const std::string& result_dir, const MapAccuracy& r);

}  // namespace dynamap::tools::eval
