// Top-view (x-y plane, z up) picture of a scene, drawn with Cairo and written as PNG. Takes plain
// data so the simulator, the replay tool and the evaluator can all draw the same kind of picture:
// map cells, static world, obstacle boxes with velocity arrows, tracked / ground-truth / predicted
// paths, the camera trajectory and field of view, a legend, a scale bar and a title.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "common/png_io.hpp"
#include "common/static_world.hpp"

namespace dynamap::tools {

/// A polyline in the x-y plane with an optional id label drawn at its end (-1: none).
struct TopViewPath {
  std::vector<Eigen::Vector2d> points;
  int id = -1;
};

/// A box seen from above: centre and full size in x-y, velocity for the arrow.
struct TopViewObstacle {
  Eigen::Vector2d center = Eigen::Vector2d::Zero();
  Eigen::Vector2d size = Eigen::Vector2d::Zero();
  Eigen::Vector2d velocity = Eigen::Vector2d::Zero();
  bool dynamic = false;
  std::string label;  ///< drawn next to the box, e.g. "3  0.9 m/s"
};

/// Everything one picture shows; empty members are simply not drawn (nor listed in the legend).
struct TopViewScene {
  std::string title;
  std::string subtitle;
  double cell_size = 0.1;                       ///< edge of an occupied map cell (m)
  std::vector<Eigen::Vector3d> occupied_cells;  ///< cell centres (z unused except for filtering)
  StaticWorld static_world;                     ///< true static geometry (simulated data)
  /// Map errors (dynamap-eval --map): observed true static voxels the map does not hold (red)
  /// and voxels walkers occupied that the map still holds (orange); centres, drawn as cells.
  std::vector<Eigen::Vector3d> missing_static_cells;
  std::vector<Eigen::Vector3d> held_dynamic_cells;
  std::vector<TopViewObstacle> obstacles;           ///< tracked obstacles (dynamic and static)
  std::vector<TopViewObstacle> ground_truth_boxes;  ///< true obstacle boxes (simulated data)
  std::vector<TopViewPath> tracked_paths;           ///< history of dynamic tracks
  std::vector<TopViewPath> ground_truth_paths;      ///< true obstacle paths
  std::vector<TopViewPath> predicted_paths;         ///< chosen predicted paths
  std::vector<TopViewPath> linear_paths;            ///< constant-velocity baseline paths
  std::vector<Eigen::Vector2d> camera_trajectory;
  bool show_camera = false;  ///< draw the field of view at camera_position / camera_yaw
  Eigen::Vector2d camera_position = Eigen::Vector2d::Zero();
  double camera_yaw = 0.0;    ///< direction of the optical axis in the x-y plane (rad)
  double camera_hfov = 1.0;   ///< horizontal field of view (rad)
  double camera_range = 5.0;  ///< drawn length of the field-of-view wedge (m)
  bool fixed_bounds = false;  ///< else the bounds fit the contents with a margin
  Eigen::Vector2d bounds_min = Eigen::Vector2d::Zero();
  Eigen::Vector2d bounds_max = Eigen::Vector2d::Zero();
};

/// Draws the picture (about `plot_px` pixels along the longer side of the plot) and writes PNG.
/// Throws ToolError when the file cannot be written.
void render_top_view(const TopViewScene& scene, const std::string& png_path, int plot_px = 900);

/// Writes a depth image as a viewable 8-bit PNG: near = bright, far = dark (linear up to
/// max_depth metres), no measurement = dark red, with a caption. Throws ToolError.
void render_depth_preview(const Image16& depth, double depth_factor, double max_depth,
                          const std::string& caption, const std::string& png_path);

}  // namespace dynamap::tools
