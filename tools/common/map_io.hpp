// The final occupancy map as files (docs/tools.md, "dynamap-replay"):
//   map.ply          one vertex per occupied voxel centre: x y z probability (float32), binary
//                    little-endian PLY, which point-cloud viewers (MeshLab, CloudCompare) open;
//   map_summary.txt  key value lines: the map's grid and sampling parameters and its counts.
// The reader takes ASCII or binary little-endian PLY with any scalar vertex properties, as long
// as x, y, z and probability are among them; bad input throws ToolError naming the file (and the
// line of an ASCII body or header).
#pragma once

#include <cstddef>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

namespace dynamap {
class OccupancyMap;  // dynamap/map/occupancy_map.hpp; only count_model_holes() takes one
}  // namespace dynamap

namespace dynamap::tools {

/// One occupied voxel of a written map: its centre (world frame, m) and occupancy probability.
struct MapVoxel {
  Eigen::Vector3f centre = Eigen::Vector3f::Zero();
  float probability = 0.f;
};

/// `comment` is the header's comment line (what the vertices are).
void write_map_ply(const std::string& path, const std::vector<MapVoxel>& voxels,
                   const std::string& comment =
                       "dynamap occupied voxel centres (world frame, m) and occupancy probability");
std::vector<MapVoxel> read_map_ply(const std::string& path);

/// A map read against a static model (e.g. dynamap-label --static-model's static_model.ply):
/// the final map's state at each model voxel's centre (looked up with the map's key_of, so each
/// map voxel counts once). "Holes" are model surface voxels the map holds free
/// (docs/evaluation.md, "Map accuracy").
struct ModelHoleCounts {
  struct States {
    std::size_t voxels = 0, occupied = 0, free = 0, unknown = 0;
    double free_percent() const {
      return voxels > 0 ? 100.0 * static_cast<double>(free) / static_cast<double>(voxels) : 0.0;
    }
  };
  States region;               ///< model voxels whose centre lies in camera +- half_extent
  States depth;                ///< of those, the ones within max_depth (Euclidean) of the camera
  std::size_t misaligned = 0;  ///< model centres more than res / 4 from the map's centre
  std::vector<Eigen::Vector3f> holes;  ///< map voxel centres of region's free voxels
};

/// Counts the map's states at the model voxels in the local region camera +- half_extent.
ModelHoleCounts count_model_holes(const OccupancyMap& map, const std::vector<MapVoxel>& model,
                                  const Eigen::Vector3f& camera, const Eigen::Vector3f& half_extent,
                                  float max_depth);

/// map_summary.txt: "key value..." lines, '#' comments. Values are kept as text.
struct MapSummary {
  std::map<std::string, std::vector<std::string>> values;
  std::string path;  ///< where it was read from, for messages ("" when built in memory)
  bool has(const std::string& key) const { return values.count(key) != 0; }
  /// The value of a one-number key, or `fallback` when the key is absent; a key present with a
  /// value that is not a number throws ToolError naming the file and the key.
  double number(const std::string& key, double fallback) const;
};

/// Writes `entries` (key, value text) in order after a comment header.
void write_map_summary(const std::string& path,
                       const std::vector<std::pair<std::string, std::string>>& entries);
MapSummary read_map_summary(const std::string& path);

}  // namespace dynamap::tools
