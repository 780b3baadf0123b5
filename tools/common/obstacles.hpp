// obstacles.txt (ground-truth obstacles of simulated sequences, docs/data_format.md):
//   # timestamp id x y z vx vy vz sx sy sz visible
#pragma once

#include <iosfwd>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace dynamap::tools {

/// One obstacle at one depth time stamp: world-frame axis-aligned box, velocity, visibility.
struct ObstacleRecord {
  double stamp = 0.0;
  std::string stamp_text;
  int id = 0;
  Eigen::Vector3d center = Eigen::Vector3d::Zero();
  Eigen::Vector3d velocity = Eigen::Vector3d::Zero();
  Eigen::Vector3d size = Eigen::Vector3d::Zero();
  double visible = 0.0;  ///< visible fraction of the projected area, [0, 1]
};

/// Reads obstacles.txt; comments and extra trailing columns are ignored; malformed lines
/// (too few fields, non-numbers, visible outside [0,1], negative sizes) throw "file:line: ...".
std::vector<ObstacleRecord> read_obstacles(const std::string& path);

/// The column comment; `what` says what the boxes are (the simulator's truth, or a reference).
void write_obstacles_header(std::ostream& out, const char* what = "ground-truth obstacles");
/// One line; the stamp is written as stamp_text when set, else with 6 decimals.
void write_obstacle_line(std::ostream& out, const ObstacleRecord& r);

}  // namespace dynamap::tools
