// ROS 2 bags (rosbag2, MCAP storage) as sequences: a folder with metadata.yaml and *.mcap files,
// or one .mcap file. Depth from sensor_msgs/msg/Image (16UC1 / mono16 in units of 1/depth_factor
// m, default mm; 32FC1 in m), intrinsics from sensor_msgs/msg/CameraInfo, camera poses from
// geometry_msgs/msg/PoseStamped, nav_msgs/msg/Odometry or tf2_msgs/msg/TFMessage, chained through
// /tf and /tf_static to the camera's optical frame. docs/tools.md, "ROS 2 bags".
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "common/mcap_reader.hpp"
#include "common/ros2msg.hpp"
#include "common/sequence.hpp"

namespace dynamap::tools {

/// True for a .mcap file, or a folder without depth.txt holding metadata.yaml or *.mcap files.
bool is_ros2_bag(const std::string& path);

/// Reads a bag as a sequence (read_sequence() calls it for bag paths). Throws ToolError naming
/// the bag (and topic and time) on what makes the bag unusable; damage after some messages is a
/// warning in Sequence::warnings saying where it is.
Sequence read_ros2_bag(const std::string& path, const SequenceReadOptions& options);

/// The name dynamap-convert gives its metadata record (depth_factor, world_z_up, depth_stamps).
inline constexpr const char* kSequenceMetadata = "dynamap.sequence";

/// Exact decimal seconds <-> integer nanoseconds (at most 9 decimals; false otherwise).
bool stamp_text_to_ns(const std::string& text, std::int64_t* ns);
std::string ns_to_stamp_text(std::int64_t ns);

/// A ROS 2 bag's messages, decoded with the ros2msg schemas it carries.
class Ros2Bag {
 public:
  explicit Ros2Bag(const std::string& path);

  struct Topic {
    std::string name, type, encoding;
    std::size_t count = 0;
  };
  struct Message {
    std::size_t file = 0;
    const mcap::MessageRef* ref = nullptr;
  };
  const std::string& path() const { return path_; }
  const std::vector<Topic>& topics() const { return topics_; }
  const Topic* topic(const std::string& name) const;
  /// "  /a  sensor_msgs/msg/Image  (617 messages)" lines, for errors.
  std::string topic_list() const;
  /// The topics of a type ("pkg/msg/Type" or "pkg/Type").
  std::vector<std::string> topics_of_type(const std::string& type) const;
  /// A topic's messages in file order.
  std::vector<Message> messages(const std::string& topic) const;
  const std::string& topic_of(const Message& m) const;
  mcap::Bytes data(const Message& m);
  /// The first bytes at least (mcap::Reader::prefix), without decompressing.
  mcap::Bytes prefix(const Message& m) const { return files_[m.file]->prefix(*m.ref); }
  /// Decodes with the channel's schema (or the built-in one of a known type when the bag has
  /// none); throws ToolError naming bag, topic and log time.
  ros2msg::Value decode(const Message& m);
  /// Warnings and damage of every file.
  std::vector<std::string> problems() const;
  const std::vector<mcap::MetadataRecord> metadata() const;
  std::vector<std::unique_ptr<mcap::Reader>>& files() { return files_; }
  /// "BAG topic /x at t=..." for messages.
  std::string where(const Message& m) const;

 private:
  const std::map<std::string, ros2msg::Definition>& definitions(std::size_t file,
                                                                std::uint16_t channel);
  std::string path_;
  std::vector<std::unique_ptr<mcap::Reader>> files_;
  std::vector<Topic> topics_;
  std::map<std::pair<std::size_t, std::uint16_t>, std::map<std::string, ros2msg::Definition>>
      definitions_;
};

/// Built-in ros2msg schema texts (as rosbag2 writes them) of the types dynamap writes.
const std::string& builtin_schema(const std::string& type);

}  // namespace dynamap::tools
