// A TUM/Bonn sequence folder as a ROS 2 bag (MCAP storage, CDR, ros2msg schemas) and back
// (dynamap-convert; docs/tools.md, "ROS 2 bags"). Folder -> bag -> folder keeps every depth
// pixel, stamp text and pose value, so the replays of all three give byte-identical results.
#pragma once

#include <string>

#include "common/sequence.hpp"

namespace dynamap::tools {

struct BagWriteOptions {
  /// "" (default: reading costs least), "zstd" (about 7x smaller) or "lz4" (4x)
  std::string compression;
  PoseConvention poses = PoseConvention::kTum;
  std::size_t chunk_size = 4u << 20;  ///< bytes of messages per chunk (before compression)
  std::string depth_topic = "/camera/depth/image_rect_raw";
  std::string info_topic = "/camera/depth/camera_info";
  std::string pose_topic = "/camera/pose";
  std::string camera_frame = "camera_depth_optical_frame";
  std::string world_frame = "world";
};

struct ConvertReport {
  std::size_t images = 0, poses = 0, skipped = 0;
  std::string output;  ///< the .mcap file written
};

/// Writes the sequence folder `dir` as a bag: `out` ending in .mcap is one file, else a rosbag2
/// folder (out/NAME_0.mcap + metadata.yaml). Listed depth files that are missing or unreadable
/// are skipped, counted and named on stderr. Throws ToolError.
ConvertReport folder_to_bag(const std::string& dir, const std::string& out,
                            const BagWriteOptions& options);

/// Writes a bag as a sequence folder (depth/*.png, depth.txt, groundtruth.txt, camera.txt).
/// Images the replay would skip are skipped and counted. Throws ToolError.
ConvertReport bag_to_folder(const std::string& bag, const std::string& out,
                            const BagReadOptions& options);

/// One JSON object per message of every topic: {"topic", "log_time", "message"}.
void dump_bag_json(const std::string& bag, std::FILE* out);

}  // namespace dynamap::tools
