// dynamap-label: offline, non-causal reference labels of moving people in a depth sequence,
// built from the depth data alone (docs/reference_labels.md). Independent of the core library:
// its own voxel statistics, clustering and association, so that it can check the pipeline.
#pragma once

#include <cstddef>
#include <functional>
#include <string>
#include <vector>

#include "common/map_io.hpp"
#include "common/obstacles.hpp"

namespace dynamap::tools::label {

struct LabelOptions {
  // Pass 1: static model (per-voxel hit / free counts over the whole sequence).
  double voxel = 0.1;      ///< m, edge of the dense voxel grid
  double max_range = 8.0;  ///< m, depth beyond this carves free space only up to here
  int model_stride = 4;    ///< pixel step of the model's rays
  /// Pixels without depth inside a no-depth block (their 4 neighbours at model_stride too) say
  /// "nothing within range" (the simulator; Kinect beyond its range): carve free space to here.
  /// Isolated dropouts at edges are not used. 0: off.
  double no_return_range = 8.0;
  double end_margin = 0.15;  ///< m, free space stops this short of the measured point
  double max_extent = 40.0;  ///< m, cap of the grid's x / y extent
  double floor_z = 0.0;      ///< world z of the floor (z up)
  // Pass 2: dynamic points and person-like clusters.
  int detect_stride = 2;          ///< pixel step of the per-frame points
  double detect_range = 7.0;      ///< m (along the ray: 5 m deep at the image corner is ~6.5 m)
  double min_point_height = 0.2;  ///< m above the floor
  int min_observations = 8;       ///< frames a voxel must be seen in before it can be "free"
  double free_ratio = 0.25;       ///< hits / observations below this: space held free
  double static_ratio = 0.5;      ///< a neighbour this often hit vetoes the point (walls)
  /// A static voxel on the ray within behind_check + behind_check_quadratic * range^2 behind
  /// a point makes it depth noise of that surface, not a person.
  double behind_check = 0.1;              ///< m
  double behind_check_quadratic = 0.008;  ///< 1/m
  int min_free_neighbours = 5;  ///< of the 3x3 image neighbours (at detect_stride), self included
  double cell = 0.1;            ///< m, top-view clustering cell
  int min_points = 40;          ///< points (at detect_stride) of a person-like cluster
  double min_top = 0.9;         ///< m above the floor: highest point of a person
  double min_vertical_extent = 0.5;  ///< m
  double max_footprint = 1.6;        ///< m, larger top-view clusters are not one or two people
  // Pass 3: tracks.
  double gate = 0.5;          ///< m per associated frame (+0.1 m per missed frame)
  int max_gap = 12;           ///< frames filled by interpolation (visible 0)
  int min_track_frames = 15;  ///< detections of a kept track
  double min_travel = 0.8;    ///< m, diagonal of the track's top-view bounding box
  /// Tracks cut by the start or end of the sequence (first / last detection within max_gap
  /// frames of it) are kept with fewer detections when their fitted speed shows walking.
  int min_boundary_frames = 6;
  double min_boundary_speed = 0.4;  ///< m/s
  int position_half_window = 4;     ///< frames each side, local line fit for the position
  int velocity_half_window = 10;    ///< frames each side, local line fit for the velocity
  double min_radius = 0.15, max_radius = 0.35;  ///< m, clamp of the estimated body radius
  int first_frame = 0;                          ///< frames (with a pose) skipped at the start
  int max_frames = 0;                           ///< 0: all
  /// Optional check by eye: every overlay_every-th frame, a PNG in overlay_dir with the depth
  /// (grey), the points held free by the model (red) and the labelled boxes (green, with ids).
  std::string overlay_dir;
  int overlay_every = 0;
  /// Keep the pass 1 model's static voxels in LabelResult::static_model and have write_labels()
  /// write them to static_model.ply. Changes no label.
  bool keep_static_model = false;
  /// Progress lines (stderr in the tool); may be empty.
  std::function<void(const std::string&)> progress;
};

struct LabelSummary {
  std::size_t listed = 0;             ///< lines of depth.txt
  std::size_t without_pose = 0;       ///< images without a pose (skipped by read_sequence)
  std::size_t frames = 0;             ///< frames with a pose considered (after --max-frames)
  std::size_t frames_used = 0;        ///< of which the depth image could be read
  std::vector<std::string> skipped;   ///< depth files missing or unreadable (with the reason)
  std::vector<std::string> warnings;  ///< e.g. no world_z_up 1: the floor may not be at floor_z
  std::size_t detections = 0;         ///< person-like clusters over all frames
  std::size_t tracks = 0;             ///< moving people-tracks kept
  std::size_t rows = 0;               ///< rows written (observed + interpolated)
  std::size_t interpolated_rows = 0;
  double seconds = 0.0;
};

struct LabelResult {
  std::vector<ObstacleRecord> rows;  ///< sorted by frame, then id
  LabelSummary summary;
  /// With keep_static_model: the centre (world frame) of every static voxel of the pass 1 model
  /// (seen in >= min_observations frames, occupied in >= static_ratio of them); probability =
  /// its hit ratio (hits / observations).
  std::vector<MapVoxel> static_model;
};

/// Labels the sequence in seq_dir. Throws ToolError for an unreadable sequence (depth.txt,
/// groundtruth.txt); unreadable depth images are skipped and listed in the summary.
LabelResult label_sequence(const std::string& seq_dir, const LabelOptions& options = {});

/// Writes out_dir/obstacles.txt (with a header saying how the labels were made) and
/// out_dir/tracks.csv (the same rows, dynamic = 1, path = -1), and with keep_static_model
/// out_dir/static_model.ply (LabelResult::static_model, the map.ply layout). Creates out_dir.
void write_labels(const std::string& out_dir, const LabelResult& result,
                  const LabelOptions& options);

/// One line naming the method and its key parameters (for headers and summaries).
std::string describe(const LabelOptions& options);

}  // namespace dynamap::tools::label
