// dynamap-replay's map outputs (docs/tools.md, "dynamap-replay"): the final map as map.ply and
// map_summary.txt, and, when the sequence has static_world.txt, the per-frame checks of the map
// against the true static world in map_frames.csv (docs/evaluation.md, "Map accuracy"). Both only
// read the map: the other outputs of the replay do not change.
#pragma once

#include <cstddef>
#include <fstream>
#include <memory>
#include <string>

#include "common/map_io.hpp"
#include "common/map_truth.hpp"
#include "common/static_world.hpp"
#include "dynamap/core/types.hpp"
#include "dynamap/map/occupancy_map.hpp"
#include "dynamap/pipeline/pipeline_config.hpp"

namespace dynamap::tools {

/// Radius (m) around the camera of the "near" columns of map_frames.csv.
inline constexpr float kMapCheckNearRadius = 3.0f;

/// map_frames.csv, one row per replayed frame.
class MapFrameLog {
 public:
  /// Precomputes the truth voxels on the map's grid and writes the header of DIR/map_frames.csv.
  MapFrameLog(const StaticWorld& world, const OccupancyMap& map, const std::string& out_dir);
  void record(const OccupancyMap& map, const std::string& stamp_text,
              const Eigen::Vector3f& camera);
  /// One line for the replay's summary: voxels checked, worst frames and the time it took.
  std::string summary() const;

 private:
  double setup_seconds_;  ///< first the start time, then the construction's duration
  MapFrameChecker checker_;
  std::ofstream csv_;
  std::string path_;
  MapFrameChecker::Counts max_;
  std::size_t frames_ = 0;
  double seconds_ = 0.0;
};

/// Counts of the final map written to map_summary.txt.
struct FinalMapCounts {
  std::size_t occupied = 0;  ///< whole map
  std::size_t region = 0, region_occupied = 0, region_free = 0, region_unknown = 0;
  bool has_model = false;  ///< a static model was given
  ModelHoleCounts model;   ///< the map against it (holes: model voxels held free)
  double seconds = 0.0;    ///< time write_final_map() took
};

/// Writes DIR/map.ply (every occupied voxel centre and its probability) and
/// DIR/map_summary.txt (grid, sampling and range parameters, counts; the local region is the
/// map's box around the last camera position). With `static_model` (e.g. dynamap-label
/// --static-model's static_model.ply): the map's states at its voxels in the local region
/// (and within max_depth of the camera) go to map_summary.txt, the held-free ones ("holes")
/// to DIR/model_holes.ply. Returns the counts.
FinalMapCounts write_final_map(const OccupancyMap& map, const PipelineConfig& config,
                               const Pose& last_pose, std::size_t frames,
                               const std::string& out_dir,
                               const std::vector<MapVoxel>* static_model = nullptr);

}  // namespace dynamap::tools
