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

namespace dynamap::tools {

/// One occupied voxel of a written map: its centre (world frame, m) and occupancy probability.
struct MapVoxel {
  Eigen::Vector3f centre = Eigen::Vector3f::Zero();
  float probability = 0.f;
};

void write_map_ply(const std::string& path, const std::vector<MapVoxel>& voxels);
std::vector<MapVoxel> read_map_ply(const std::string& path);

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
