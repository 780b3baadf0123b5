#include "common/ros2_convert.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <map>

#include "common/cdr.hpp"
#include "common/mcap_writer.hpp"
#include "common/png_io.hpp"
#include "common/ros2_bag.hpp"
#include "common/text_io.hpp"

namespace dynamap::tools {
namespace {

struct RawPose {
  std::int64_t ns = 0;
  double v[7] = {};  ///< tx ty tz qx qy qz qw as written
};

std::int64_t text_ns(const std::string& text, const TextLocation& at) {
  std::int64_t ns = 0;
  if (!stamp_text_to_ns(text, &ns) || ns < 0 || ns / 1000000000LL > 2147483647LL) {
    fail_at(at, "time stamp '" + text +
                    "' is not a ROS time (seconds >= 0 below 2^31 with at most 9 decimals)");
  }
  return ns;
}

std::vector<RawPose> read_raw_poses(const std::string& path) {
  std::vector<RawPose> poses;
  const auto lines = read_lines(path);
  for (std::size_t i = 0; i < lines.size(); ++i) {
    const TextLocation at{path, i + 1};
    const std::string body = strip_comment(lines[i]);
    if (body.empty()) continue;
    const auto f = split_ws(body);
    if (f.size() < 8) fail_at(at, "expected 'timestamp tx ty tz qx qy qz qw'");
    RawPose p;
    p.ns = text_ns(f[0], at);
    const char* names[] = {"tx", "ty", "tz", "qx", "qy", "qz", "qw"};
    for (int k = 0; k < 7; ++k) p.v[k] = parse_double(f[k + 1], at, names[k]);
    poses.push_back(p);
  }
  std::stable_sort(poses.begin(), poses.end(),
                   [](const RawPose& a, const RawPose& b) { return a.ns < b.ns; });
  return poses;
}

void header(cdr::Writer& w, std::int64_t ns, const std::string& frame) {
  w.write<std::int32_t>(static_cast<std::int32_t>(ns / 1000000000LL));
  w.write<std::uint32_t>(static_cast<std::uint32_t>(ns % 1000000000LL));
  w.string(frame);
}

std::vector<std::uint8_t> image_message(const Image16& img, std::int64_t ns,
                                        const std::string& frame) {
  cdr::Writer w;
  header(w, ns, frame);
  w.write<std::uint32_t>(static_cast<std::uint32_t>(img.height));
  w.write<std::uint32_t>(static_cast<std::uint32_t>(img.width));
  w.string("16UC1");
  w.write<std::uint8_t>(0);
  w.write<std::uint32_t>(static_cast<std::uint32_t>(img.width * 2));
  w.write<std::uint32_t>(static_cast<std::uint32_t>(img.pixels.size() * 2));
  w.bytes(img.pixels.data(), img.pixels.size() * 2);  // little-endian host, as is_bigendian 0
  return w.data();
}

std::vector<std::uint8_t> info_message(const CameraModel& c, std::int64_t ns,
                                       const std::string& frame) {
  cdr::Writer w;
  header(w, ns, frame);
  w.write<std::uint32_t>(static_cast<std::uint32_t>(c.height));
  w.write<std::uint32_t>(static_cast<std::uint32_t>(c.width));
  w.string("plumb_bob");
  w.write<std::uint32_t>(5);
  for (int k = 0; k < 5; ++k) w.write<double>(0.0);
  const double k[9] = {c.fx, 0, c.cx, 0, c.fy, c.cy, 0, 0, 1};
  const double r[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  const double p[12] = {c.fx, 0, c.cx, 0, 0, c.fy, c.cy, 0, 0, 0, 1, 0};
  for (double v : k) w.write<double>(v);
  for (double v : r) w.write<double>(v);
  for (double v : p) w.write<double>(v);
  w.write<std::uint32_t>(0);
  w.write<std::uint32_t>(0);
  for (int i = 0; i < 4; ++i) w.write<std::uint32_t>(0);
  w.write<std::uint8_t>(0);
  return w.data();
}

std::vector<std::uint8_t> pose_message(const RawPose& p, const std::string& frame) {
  cdr::Writer w;
  header(w, p.ns, frame);
  for (double v : p.v) w.write<double>(v);
  return w.data();
}

std::string basename_of(std::string path) {
  while (path.size() > 1 && path.back() == '/') path.pop_back();
  const auto slash = path.rfind('/');
  return slash == std::string::npos ? path : path.substr(slash + 1);
}

void write_metadata_yaml(const std::string& dir, const std::string& file, const BagWriteOptions& o,
                         std::int64_t start, std::int64_t end, const ConvertReport& r) {
  std::ofstream y(join_path(dir, "metadata.yaml"));
  y << "rosbag2_bagfile_information:\n  version: 5\n  storage_identifier: mcap\n"
    << "  duration:\n    nanoseconds: " << end - start << "\n  starting_time:\n"
    << "    nanoseconds_since_epoch: " << start << "\n  message_count: " << 2 * r.images + r.poses
    << "\n  topics_with_message_count:\n";
  const std::pair<std::string, std::string> topics[] = {
      {o.depth_topic, "sensor_msgs/msg/Image"},
      {o.info_topic, "sensor_msgs/msg/CameraInfo"},
      {o.pose_topic, "geometry_msgs/msg/PoseStamped"}};
  for (const auto& [name, type] : topics) {
    y << "    - topic_metadata:\n        name: " << name << "\n        type: " << type
      << "\n        serialization_format: cdr\n        offered_qos_profiles: \"\"\n"
      << "      message_count: " << (name == o.pose_topic ? r.poses : r.images) << "\n";
  }
  y << "  compression_format: \"\"\n  compression_mode: \"\"\n  relative_file_paths:\n    - "
    << file << "\n  files:\n    - path: " << file << "\n      starting_time:\n"
    << "        nanoseconds_since_epoch: " << start
    << "\n      duration:\n        nanoseconds: " << end - start
    << "\n      message_count: " << 2 * r.images + r.poses << "\n";
  if (!y) throw ToolError(join_path(dir, "metadata.yaml") + ": write error");
}

}  // namespace

namespace {

struct DepthEntry {
  std::string text, file;
  std::int64_t ns = 0;
};

std::vector<DepthEntry> read_depth_entries(const std::string& dir) {
  const std::string list = join_path(dir, "depth.txt");
  if (!file_exists(list)) throw ToolError(list + ": missing (not a sequence directory?)");
  std::vector<DepthEntry> out;
  const auto lines = read_lines(list);
  for (std::size_t i = 0; i < lines.size(); ++i) {
    const TextLocation at{list, i + 1};
    const std::string body = strip_comment(lines[i]);
    if (body.empty()) continue;
    const auto f = split_ws(body);
    if (f.size() < 2) fail_at(at, "expected 'timestamp filename'");
    out.push_back({f[0], f[1], text_ns(f[0], at)});
    if (out.size() > 1 && out.back().ns <= out[out.size() - 2].ns) {
      fail_at(at, "time stamps must increase");
    }
  }
  return out;
}

std::string format_double(double v) {
  char buf[40];
  std::snprintf(buf, sizeof(buf), "%.17g", v);
  return buf;
}

// dynamap-convert's metadata record. Listed depth files the folder lacks are listed too, so
// the bag's replay skips, counts and names them as the folder's does (unreadable ones follow in
// a second record at the end, once known).
std::map<std::string, std::string> sequence_record(const std::string& dir, const CameraModel& cam,
                                                   bool bonn,
                                                   const std::vector<DepthEntry>& depth) {
  std::string stamps, missing;
  for (const DepthEntry& d : depth) {
    stamps += d.text + "\n";
    const std::string path = join_path(dir, d.file);
    if (!file_exists(path)) {
      missing += d.text + "\t" + std::to_string(static_cast<int>(DepthProblem::kMissing)) + "\t" +
                 path + ": listed in depth.txt but missing\n";
    }
  }
  return {{"depth_factor", format_double(cam.depth_factor)},
          {"world_z_up", std::to_string(cam.world_z_up)},
          {"poses", bonn ? "bonn" : "tum"},
          {"depth_stamps", stamps},
          {"skipped_depth", missing},
          {"source", dir}};
}

}  // namespace

ConvertReport folder_to_bag(const std::string& dir, const std::string& out,
                            const BagWriteOptions& o) {
  const bool bonn = o.poses == PoseConvention::kBonn;
  bool has_camera = false;
  CameraModel cam = read_camera_file(join_path(dir, "camera.txt"), &has_camera, nullptr);
  if (bonn && !has_camera) cam = bonn_camera();
  std::string gt = join_path(dir, "groundtruth.txt");
  if (bonn && file_exists(join_path(dir, "groundtruth_bonn.txt"))) {
    gt = join_path(dir, "groundtruth_bonn.txt");
  }
  const std::vector<DepthEntry> depth = read_depth_entries(dir);
  const std::vector<RawPose> poses = read_raw_poses(gt);
  Sequence stub;  // try_load_depth() checks each image as the folder's replay would
  stub.camera = cam;
  ConvertReport report;
  std::string file = out;
  const bool folder = out.size() < 5 || out.compare(out.size() - 5, 5, ".mcap") != 0;
  if (folder) {
    make_directories(out, "cannot create the bag folder");
    file = basename_of(out) + "_0.mcap";
    report.output = join_path(out, file);
  } else {
    report.output = out;
  }
  mcap::Writer w(report.output, "ros2", o.compression, o.chunk_size);
  auto channel = [&](const std::string& topic, const std::string& type) {
    const std::uint16_t s = w.add_schema(type, "ros2msg", builtin_schema(type));
    return w.add_channel(s, topic, "cdr", {{"offered_qos_profiles", ""}});
  };
  const auto image_ch = channel(o.depth_topic, "sensor_msgs/msg/Image");
  const auto info_ch = channel(o.info_topic, "sensor_msgs/msg/CameraInfo");
  const auto pose_ch = channel(o.pose_topic, "geometry_msgs/msg/PoseStamped");
  std::size_t next_pose = 0;
  auto poses_until = [&](std::int64_t ns) {
    for (; next_pose < poses.size() && poses[next_pose].ns <= ns; ++next_pose) {
      const auto m = pose_message(poses[next_pose], o.world_frame);
      const auto t = static_cast<std::uint64_t>(poses[next_pose].ns);
      w.write(pose_ch, t, t, m.data(), m.size());
      ++report.poses;
    }
  };
  // The metadata first: a bag cut short (a killed recording) keeps it.
  w.add_metadata(kSequenceMetadata, sequence_record(dir, cam, bonn, depth));
  std::string unusable;
  for (const DepthEntry& d : depth) {
    poses_until(d.ns);
    Image16 img;
    std::string message;
    SequenceFrame frame;
    frame.depth_path = join_path(dir, d.file);
    const DepthProblem problem = try_load_depth(stub, frame, &img, &message);
    if (problem != DepthProblem::kNone) {
      std::cerr << "warning: skipped: " << message << "\n";
      ++report.skipped;
      if (problem != DepthProblem::kMissing) {
        unusable +=
            d.text + "\t" + std::to_string(static_cast<int>(problem)) + "\t" + message + "\n";
      }
      continue;
    }
    const auto t = static_cast<std::uint64_t>(d.ns);
    const auto im = image_message(img, d.ns, o.camera_frame);
    w.write(image_ch, t, t, im.data(), im.size());
    const auto ci = info_message(cam, d.ns, o.camera_frame);
    w.write(info_ch, t, t, ci.data(), ci.size());
    ++report.images;
  }
  poses_until(INT64_MAX);
  if (!unusable.empty()) w.add_metadata(kSequenceMetadata, {{"skipped_depth", unusable}});
  w.close();
  if (folder) {
    const std::int64_t start = std::min(depth.empty() ? 0 : depth.front().ns,
                                        poses.empty() ? INT64_MAX : poses.front().ns);
    const std::int64_t end =
        std::max(depth.empty() ? 0 : depth.back().ns, poses.empty() ? 0 : poses.back().ns);
    write_metadata_yaml(out, file, o, start, end, report);
  }
  return report;
}

ConvertReport bag_to_folder(const std::string& bag, const std::string& out,
                            const BagReadOptions& options) {
  SequenceReadOptions ro;
  ro.bag = options;
  ro.bag.raw_poses = true;
  ro.align_gravity = false;
  ro.level_floor = false;
  ro.max_pose_gap = 1e300;  // keep every image between the first and last pose
  const Sequence seq = read_ros2_bag(bag, ro);
  for (const std::string& w : seq.warnings) std::cerr << "warning: " << w << "\n";
  make_directories(join_path(out, "depth"), "cannot create the output folder");
  ConvertReport report;
  report.output = out;
  std::ofstream list(join_path(out, "depth.txt"));
  list << "# depth maps from " << bag << "\n# timestamp filename\n";
  for (const SequenceFrame& f : seq.frames) {
    Image16 img;
    std::string problem;
    const std::string name = "depth/" + f.stamp_text + ".png";
    const DepthProblem p = try_load_depth(seq, f, &img, &problem);
    if (p != DepthProblem::kNone) {
      std::cerr << "warning: skipped: " << problem << "\n";
      ++report.skipped;
      // Listed but missing in the bag's source folder: listed, and missing, here too.
      if (p == DepthProblem::kMissing) list << f.stamp_text << " " << name << "\n";
      continue;
    }
    write_png16(join_path(out, name), img);
    list << f.stamp_text << " " << name << "\n";
    ++report.images;
  }
  std::ofstream gt(join_path(out, "groundtruth.txt"));
  gt << "# timestamp tx ty tz qx qy qz qw  (from " << seq.pose_file << ")\n";
  for (const StampedPose& p : seq.poses) {
    const auto& t = p.pose.translation;
    const auto& q = p.pose.rotation;
    char stamp[48];
    std::snprintf(stamp, sizeof(stamp), "%.17g", p.stamp);
    gt << stamp;
    for (double v : {t.x(), t.y(), t.z(), q.x(), q.y(), q.z(), q.w()})
      gt << " " << format_double(v);
    gt << "\n";
    ++report.poses;
  }
  write_camera_file(join_path(out, "camera.txt"), seq.camera);
  if (!list || !gt) throw ToolError(out + ": write error");
  return report;
}

void dump_bag_json(const std::string& path, std::FILE* out) {
  Ros2Bag bag(path);
  for (const std::string& w : bag.problems()) std::fprintf(stderr, "warning: %s\n", w.c_str());
  for (const Ros2Bag::Topic& t : bag.topics()) {
    for (const Ros2Bag::Message& m : bag.messages(t.name)) {
      std::string line = "{\"topic\":\"" + t.name + "\",\"log_time\":\"" +
                         std::to_string(m.ref->log_time) + "\",\"message\":";
      ros2msg::append_json(bag.decode(m), &line);
      line += "}\n";
      std::fputs(line.c_str(), out);
    }
  }
}

}  // namespace dynamap::tools
