// static_world.txt: the simulator's static geometry, an extra file of simulated sequences so the
// evaluator can test predicted paths against the true static world. One shape per line:
//   floor z
//   box xmin ymin zmin xmax ymax zmax                 (axis-aligned)
//   cylinder cx cy radius zmin zmax                   (vertical axis)
// A shape may end with the keyword `dark`: a dark or shiny surface on which a stereo depth camera
// loses pixels in patches (the simulator renders it so). Comments (#) and other trailing columns
// are ignored, so readers that do not know the keyword read the geometry unchanged.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

namespace dynamap::tools {

/// Axis-aligned static box (walls, crates).
struct StaticBox {
  Eigen::Vector3d min = Eigen::Vector3d::Zero();
  Eigen::Vector3d max = Eigen::Vector3d::Zero();
  bool dark = false;  ///< dark or shiny surface: depth lost in patches
};

/// Vertical static cylinder (pillars, people who only stand).
struct StaticCylinder {
  Eigen::Vector2d center = Eigen::Vector2d::Zero();
  double radius = 0.0;
  double zmin = 0.0, zmax = 0.0;
  bool dark = false;  ///< dark or shiny surface: depth lost in patches
};

/// The whole static world: a floor plane (z = floor_z, facing up) plus boxes and cylinders.
struct StaticWorld {
  bool has_floor = false;
  double floor_z = 0.0;
  std::vector<StaticBox> boxes;
  std::vector<StaticCylinder> cylinders;

  /// Top-view distance from p to the nearest shape whose vertical range overlaps [zlo, zhi]
  /// (0 inside a shape); +inf when there is none. The floor is not a shape here.
  double top_view_distance(const Eigen::Vector2d& p, double zlo, double zhi) const;
};

StaticWorld read_static_world(const std::string& path);
void write_static_world(const std::string& path, const StaticWorld& world);

}  // namespace dynamap::tools
