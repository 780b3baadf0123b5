// The true static world (static_world.txt) as voxels of the map's grid, for the map accuracy
// figures of docs/evaluation.md ("Map accuracy"). Voxel (i, j, k) is the cube
// [i, i+1) x [j, j+1) x [k, k+1) times the resolution, centre (i + 0.5) * resolution, as in
// OccupancyMap (key_of / center_of). Definitions (eps = 0.1 mm, so that a face lying on a voxel
// boundary does not make the voxel beyond it count):
//   surface voxel   of a box or cylinder: more than a sliver of the voxel lies inside the shape
//                   and the voxel does not lie in the shape's interior more than eps from every
//                   face (it holds part of the shape's boundary, possibly on its own face);
//   interior voxel  its centre lies inside a box or cylinder (by more than eps);
//   floor voxel     its closed z interval contains the floor plane (two layers when the plane
//                   lies on a voxel boundary, as the simulator's z = 0 does). The floor is not a
//                   box or cylinder: it is neither surface nor interior above.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "common/static_world.hpp"
#include "dynamap/map/occupancy_map.hpp"

namespace dynamap::tools {

/// Voxel index of a point: floor(p / resolution) per axis.
Eigen::Vector3i voxel_of(const Eigen::Vector3d& p, double resolution);
Eigen::Vector3d voxel_centre(const Eigen::Vector3i& v, double resolution);
/// A voxel index as one integer (21 bits per axis), for hash sets.
std::int64_t pack_voxel(const Eigen::Vector3i& v);
Eigen::Vector3i unpack_voxel(std::int64_t key);

struct StaticTruthVoxels {
  std::vector<Eigen::Vector3i> surface;   ///< of boxes and cylinders (not the floor)
  std::vector<Eigen::Vector3i> interior;  ///< centre inside a box or cylinder
};

/// Surface and interior voxels of every box and cylinder (a voxel listed once).
StaticTruthVoxels static_truth_voxels(const StaticWorld& world, double resolution);

bool is_floor_voxel(const StaticWorld& world, const Eigen::Vector3i& v, double resolution);

/// True when the voxel, grown by `margin` (m) on every side, touches a box or cylinder.
bool near_static_shape(const StaticWorld& world, const Eigen::Vector3i& v, double resolution,
                       double margin);

/// Per-frame checks of the map against the true static world (dynamap-replay's map_frames.csv):
/// erased obstacle = a surface voxel the map held occupied at some earlier check and now holds
/// free; free through obstacle = an interior voxel the map holds free. Each is counted within
/// `near_radius` of the camera (3-D distance to the voxel centre) and over the whole world.
/// An erased voxel is *bare* when none of its 26 neighbours is held occupied either: there the
/// surface is gone, not thinned by a voxel (a planner inflating obstacles by a voxel or more
/// still sees a thinned surface). A free-through voxel is *whole* when its whole cube lies inside
/// a shape (it is an interior voxel and no surface voxel): there the map holds a hole a voxel
/// deep, not a boundary voxel the shape only partly fills (the top layer of a box whose top lies
/// inside that layer, crossed by rays just above the top).
class MapFrameChecker {
 public:
  /// The truth voxels on `map`'s grid (its resolution; centres through key_of / center_of).
  MapFrameChecker(const StaticWorld& world, const OccupancyMap& map);

  struct Counts {
    std::size_t erased_near = 0, free_through_near = 0;
    std::size_t erased_all = 0, free_through_all = 0;
    std::size_t erased_bare_near = 0, erased_bare_all = 0;
    std::size_t free_through_whole_near = 0, free_through_whole_all = 0;
  };
  /// Reads the map only (const queries); remembers which surface voxels are held occupied now.
  Counts check(const OccupancyMap& map, const Eigen::Vector3f& camera, float near_radius);

  std::size_t surface_voxels() const { return surface_.size(); }
  std::size_t interior_voxels() const { return interior_.size(); }

 private:
  bool has_occupied_neighbour(const OccupancyMap& map, const Eigen::Vector3f& centre) const;

  std::vector<Eigen::Vector3f> surface_, interior_;
  std::vector<std::uint8_t> whole_;  ///< interior voxel that is no surface voxel
  float resolution_ = 0.f;
  std::vector<std::uint8_t> held_;  ///< surface voxel held occupied at some check so far
};

}  // namespace dynamap::tools
