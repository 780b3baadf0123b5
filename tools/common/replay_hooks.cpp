#include "common/replay_hooks.hpp"

#include <cstdlib>
#include <iostream>

namespace dynamap::tools {

bool parse_replay_extra(int argc, char** argv, int& i, ReplayExtras& x, bool& error) {
  const std::string a = argv[i];
  std::string* text = nullptr;
  if (a == "--depth-topic") text = &x.bag.depth_topic;
  if (a == "--info-topic") text = &x.bag.info_topic;
  if (a == "--pose-topic") text = &x.bag.pose_topic;
  if (a == "--camera-frame") text = &x.bag.camera_frame;
  if (a == "--pose-child") text = &x.bag.pose_child;
  if (a == "--world-frame") text = &x.bag.world_frame;
  if (a == "--mcap") text = &x.mcap;
  if (a == "--reference") text = &x.reference;
  const bool number = a == "--depth-factor" || a == "--world-z-up" || a == "--mcap-map-every";
  if (text == nullptr && !number) return false;
  if (i + 1 >= argc) {
    std::cerr << a << " needs a value\n";
    error = true;
    return true;
  }
  const std::string v = argv[++i];
  if (text != nullptr) {
    *text = v;
    return true;
  }
  char* end = nullptr;
  const double d = std::strtod(v.c_str(), &end);
  if (*end != '\0' || !(d >= 0)) {
    std::cerr << a << " takes a non-negative number, not '" << v << "'\n";
    error = true;
    return true;
  }
  if (a == "--depth-factor") {
    x.bag.depth_factor = d;
  } else if (a == "--world-z-up") {
    if (v != "0" && v != "1") {
      std::cerr << "--world-z-up takes 0 or 1\n";
      error = true;
    }
    x.bag.world_z_up = v == "1" ? 1 : 0;
  } else {
    x.mcap_map_every = static_cast<long>(d);
  }
  return true;
}

std::string bag_options_usage() {
  return "ROS 2 bags (SEQ a rosbag2 folder or a .mcap file; docs/tools.md, \"ROS 2 bags\"):\n"
         "  --depth-topic T  sensor_msgs/msg/Image, 16UC1 or 32FC1 (default: the only one)\n"
         "  --info-topic T   sensor_msgs/msg/CameraInfo (default: beside the depth topic)\n"
         "  --pose-topic T   PoseStamped, Odometry or TFMessage (default: the only pose topic,\n"
         "                   else /tf)\n"
         "  --camera-frame F the optical frame (default: the images' header.frame_id)\n"
         "  --pose-child F   the frame a PoseStamped gives the pose of (default: camera frame;\n"
         "                   another frame is chained to the camera through /tf, /tf_static)\n"
         "  --world-frame F  with /tf poses (default: the root of the camera's tree)\n"
         "  --depth-factor N 16UC1 units per metre (default: the bag's, else 1000 = mm)\n"
         "  --world-z-up 0|1 the world's z axis points up (default: the bag's, else 0)\n"
         "Foxglove output:\n"
         "  --mcap FILE      the replay as MCAP for Foxglove (poses, depth, tracks, paths, map)\n"
         "  --mcap-map-every N  occupied voxels every N frames (default 10)\n"
         "  --reference FILE reference people (obstacles.txt layout) drawn too\n";
}

}  // namespace dynamap::tools
