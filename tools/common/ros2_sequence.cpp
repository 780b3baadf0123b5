// read_ros2_bag(): a ROS 2 bag as a Sequence (declared in common/ros2_bag.hpp).
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <set>
#include <sstream>

#include "common/ros2_bag.hpp"
#include "common/text_io.hpp"

namespace dynamap::tools {
namespace {

using ros2msg::Value;

std::string strip_slash(const std::string& frame) {
  return !frame.empty() && frame[0] == '/' ? frame.substr(1) : frame;
}

// An integer field (int32 sec, uint32 nanosec): any other kind is an error, not a cast.
std::int64_t integer(const Value& v, const char* name) {
  if (v.kind == Value::Kind::kInt && v.i >= INT32_MIN && v.i <= INT32_MAX) return v.i;
  if (v.kind == Value::Kind::kUInt && v.u <= UINT32_MAX) return static_cast<std::int64_t>(v.u);
  throw ToolError(std::string("header stamp field ") + name + " is not a 32-bit integer");
}

std::int64_t stamp_ns_of(const Value& header) {
  const Value& st = header["stamp"];
  return integer(st["sec"], "sec") * 1000000000LL + integer(st["nanosec"], "nanosec");
}

// The depth.txt-like seconds of a stamp: the double of its exact decimal text.
double seconds_of(std::int64_t ns) {
  return std::strtod(ns_to_stamp_text(ns).c_str(), nullptr);
}

PoseD compose(const PoseD& a, const PoseD& b) {
  PoseD c;
  c.translation = a.translation + a.rotation * b.translation;
  c.rotation = (a.rotation * b.rotation).normalized();
  return c;
}

// A pose from {position|translation, orientation|rotation} (quaternion normalised as
// read_groundtruth() does); false for a quaternion far from unit length.
bool pose_of(const Value& t, const Value& q, PoseD* out, bool raw = false) {
  out->translation = {t["x"].number(), t["y"].number(), t["z"].number()};
  Eigen::Quaterniond r(q["w"].number(), q["x"].number(), q["y"].number(), q["z"].number());
  if (!(r.norm() >= 0.5) || !r.coeffs().allFinite() || !out->translation.allFinite()) {
    return false;
  }
  if (!raw) r.normalize();
  out->rotation = r;
  return true;
}

// /tf and /tf_static: child frame -> parent, static or with samples in time.
struct TfTree {
  struct Edge {
    std::string parent;
    bool is_static = false;
    std::vector<StampedPose> samples;
  };
  std::map<std::string, Edge> edges;
  std::vector<std::string> topics;
  enum class Result { kOk, kNoPath, kNoSample };

  // T_target_frame at t through the chain of parents; `missing` names the broken link.
  Result lookup(const std::string& target, const std::string& frame, double t, double gap,
                PoseD* out, std::string* missing) const {
    PoseD acc;
    std::string cur = frame;
    for (int hops = 0; cur != target; ++hops) {
      const auto e = edges.find(cur);
      if (e == edges.end() || hops > 64) {
        *missing = "no transform from '" + cur + "' towards '" + target + "'";
        return Result::kNoPath;
      }
      PoseD step;
      if (e->second.is_static) {
        step = e->second.samples.back().pose;
      } else if (!interpolate_pose(e->second.samples, t, gap, &step)) {
        *missing = "no transform " + e->second.parent + " -> " + cur + " within the gap";
        return Result::kNoSample;
      }
      acc = compose(step, acc);
      cur = e->second.parent;
    }
    *out = acc;
    return Result::kOk;
  }
  std::string root_of(const std::string& frame) const {
    std::string cur = frame;
    for (int hops = 0; hops < 64; ++hops) {
      const auto e = edges.find(cur);
      if (e == edges.end()) break;
      cur = e->second.parent;
    }
    return cur;
  }
};

TfTree read_tf(Ros2Bag& bag, std::vector<std::string>* warnings) {
  TfTree tree;
  for (const std::string& topic : bag.topics_of_type("tf2_msgs/msg/TFMessage")) {
    tree.topics.push_back(topic);
    const bool is_static = topic.find("static") != std::string::npos;
    for (const Ros2Bag::Message& m : bag.messages(topic)) {
      const Value msg = bag.decode(m);
      if (!msg.has("transforms")) throw ToolError(bag.where(m) + ": not a tf2_msgs/TFMessage");
      for (const Value& ts : msg["transforms"].items) {
        if (!ts.has("child_frame_id") || !ts.has("transform") || !ts.has("header")) {
          throw ToolError(bag.where(m) +
                          ": a transform without child_frame_id, header or "
                          "transform");
        }
        const std::string child = strip_slash(ts["child_frame_id"].s);
        TfTree::Edge& e = tree.edges[child];
        e.parent = strip_slash(ts["header"]["frame_id"].s);
        e.is_static = e.is_static || is_static;
        StampedPose p;
        p.stamp = seconds_of(stamp_ns_of(ts["header"]));
        if (!pose_of(ts["transform"]["translation"], ts["transform"]["rotation"], &p.pose)) {
          warnings->push_back(bag.where(m) + ": transform to " + child +
                              " has a degenerate quaternion; ignored");
          continue;
        }
        e.samples.push_back(p);
      }
    }
  }
  for (auto& [child, e] : tree.edges) {
    std::stable_sort(e.samples.begin(), e.samples.end(),
                     [](const StampedPose& a, const StampedPose& b) { return a.stamp < b.stamp; });
    if (e.samples.empty())
      e.is_static = true;  // all degenerate: identity is no better; see warnings
    if (e.samples.empty()) e.samples.push_back(StampedPose{});
  }
  return tree;
}

// A topic given by flag (checked to exist with the type) or the only one of the types.
std::string choose_topic(const Ros2Bag& bag, const std::string& flag, const char* what,
                         const std::vector<std::string>& types, const char* option,
                         const std::string& prefer) {
  if (!flag.empty()) {
    const Ros2Bag::Topic* t = bag.topic(flag);
    if (t == nullptr) {
      throw ToolError(bag.path() + ": no topic " + flag + " (" + option + "); " + bag.topic_list());
    }
    for (const std::string& type : types) {
      if (ros2msg::normalise_type(t->type) == ros2msg::normalise_type(type)) return flag;
    }
    throw ToolError(bag.path() + ": topic " + flag + " has type " + t->type + ", not " +
                    types.front() + (types.size() > 1 ? " (or another pose type)" : "") + "; " +
                    bag.topic_list());
  }
  for (const std::string& type : types) {
    std::vector<std::string> found = bag.topics_of_type(type);
    if (found.size() > 1 && !prefer.empty()) {
      std::vector<std::string> preferred;
      for (const std::string& f : found) {
        if (f.find(prefer) != std::string::npos) preferred.push_back(f);
      }
      if (preferred.size() == 1) found = preferred;
    }
    if (found.size() == 1) return found.front();
    if (found.size() > 1) {
      throw ToolError(bag.path() + ": several " + what + " topics of type " + type +
                      ": choose one with " + option + "; " + bag.topic_list());
    }
  }
  throw ToolError(bag.path() + ": no " + what + " topic (type " + types.front() +
                  (types.size() > 1 ? " or another pose type" : "") + "); " + bag.topic_list());
}

}  // namespace

namespace {

// A sensor_msgs/msg/Image without a copy of its pixels (the layout every ROS 2 distribution
// shares: header, height, width, encoding, is_bigendian, step, data).
struct ImageView {
  std::int64_t stamp_ns = 0;
  std::string frame_id, encoding;
  std::uint64_t width = 0, height = 0, step = 0;
  bool big = false;
  const std::uint8_t* data = nullptr;
  std::size_t size = 0;
};

// Decodes the image's fields; with `pixels` false, stops before the data. Throws ToolError.
ImageView decode_image(Ros2Bag& bag, const Ros2Bag::Message& m, bool pixels) {
  try {
    const mcap::Bytes b = pixels ? bag.data(m) : bag.prefix(m);
    cdr::Reader in(b.data, b.size);
    ImageView v;
    const std::int32_t sec = in.read<std::int32_t>();
    v.stamp_ns = static_cast<std::int64_t>(sec) * 1000000000LL + in.read<std::uint32_t>();
    v.frame_id = in.string();
    v.height = in.read<std::uint32_t>();
    v.width = in.read<std::uint32_t>();
    v.encoding = in.string();
    if (!pixels) return v;
    v.big = in.read<std::uint8_t>() != 0;
    v.step = in.read<std::uint32_t>();
    v.size = in.length(1);
    v.data = in.bytes(v.size);
    return v;
  } catch (const ToolError& e) {
    throw ToolError(bag.where(m) + ": " + e.what());
  }
}

// An image as depth in units of 1/cam.depth_factor m.
DepthProblem image_to_depth(const ImageView& img, const CameraModel& cam, Image16* out,
                            std::string* why) {
  const std::string& enc = img.encoding;
  const std::uint64_t width = img.width, height = img.height, step = img.step;
  const bool big = img.big;
  const bool u16 = enc == "16UC1" || enc == "mono16";
  if (!u16 && enc != "32FC1") {
    *why = "encoding '" + enc + "' is not a depth encoding (16UC1, mono16 or 32FC1)";
    return DepthProblem::kUnreadable;
  }
  const std::uint64_t pixel = u16 ? 2 : 4;
  if (step < width * pixel || (height > 0 && img.size / height < step)) {
    *why = "step " + std::to_string(step) + " and " + std::to_string(img.size) +
           " data bytes do not hold " + std::to_string(width) + "x" + std::to_string(height) + " " +
           enc + " pixels";
    return DepthProblem::kUnreadable;
  }
  if (width != static_cast<std::uint64_t>(cam.width) ||
      height != static_cast<std::uint64_t>(cam.height)) {
    *why = "image is " + std::to_string(width) + "x" + std::to_string(height) +
           " but the camera info says " + std::to_string(cam.width) + "x" +
           std::to_string(cam.height);
    return DepthProblem::kWrongSize;
  }
  out->width = cam.width;
  out->height = cam.height;
  out->pixels.resize(width * height);
  const std::uint8_t* bytes = img.data;
  for (std::uint64_t v = 0; v < height; ++v) {
    const std::uint8_t* row = bytes + v * step;
    std::uint16_t* dst = out->pixels.data() + v * width;
    if (u16 && !big) {
      std::memcpy(dst, row, width * 2);
    } else if (u16) {
      for (std::uint64_t u = 0; u < width; ++u)
        dst[u] = static_cast<std::uint16_t>(row[2 * u] << 8 | row[2 * u + 1]);
    } else {
      for (std::uint64_t u = 0; u < width; ++u) {
        std::uint8_t b[4];
        std::memcpy(b, row + 4 * u, 4);
        if (big) std::reverse(b, b + 4);
        float m = 0.0f;
        std::memcpy(&m, b, 4);
        const double units = std::round(static_cast<double>(m) * cam.depth_factor);
        dst[u] =
            std::isfinite(m) && units > 0 && units < 65536 ? static_cast<std::uint16_t>(units) : 0;
      }
    }
  }
  return DepthProblem::kNone;
}

/// A depth file the source folder could not give (dynamap-convert's skipped_depth list).
struct SkippedDepth {
  DepthProblem problem = DepthProblem::kMissing;
  std::string message;
};

class BagDepthSource : public DepthSourceBase {
 public:
  BagDepthSource(std::shared_ptr<Ros2Bag> bag, std::vector<Ros2Bag::Message> images,
                 std::vector<SkippedDepth> skipped)
      : bag_(std::move(bag)), images_(std::move(images)), skipped_(std::move(skipped)) {}
  DepthProblem load(const Sequence& seq, const SequenceFrame& frame, Image16* out,
                    std::string* message) override {
    if (frame.source_index >= images_.size()) {
      const SkippedDepth& s = skipped_.at(frame.source_index - images_.size());
      *message = s.message;
      return s.problem;
    }
    std::string why;
    DepthProblem p = DepthProblem::kUnreadable;
    try {
      p = image_to_depth(decode_image(*bag_, images_.at(frame.source_index), true), seq.camera, out,
                         &why);
    } catch (const ToolError& e) {
      why = e.what();
    }
    if (p != DepthProblem::kNone) *message = frame.depth_path + ": " + why;
    return p;
  }

 private:
  std::shared_ptr<Ros2Bag> bag_;
  std::vector<Ros2Bag::Message> images_;
  std::vector<SkippedDepth> skipped_;
};

// dynamap-convert's records merged (the skipped_depth lists of both appended).
std::map<std::string, std::string> sequence_metadata(const Ros2Bag& bag) {
  std::map<std::string, std::string> merged;
  for (const mcap::MetadataRecord& r : bag.metadata()) {
    if (r.name != kSequenceMetadata) continue;
    for (const auto& [k, v] : r.values) {
      if (k == "skipped_depth") {
        merged[k] += v;
      } else {
        merged.emplace(k, v);
      }
    }
  }
  return merged;
}

void read_camera_info(Ros2Bag& bag, const std::string& topic, CameraModel* cam) {
  const auto msgs = bag.messages(topic);
  if (msgs.empty()) throw ToolError(bag.path() + " topic " + topic + ": no camera info message");
  const Value info = bag.decode(msgs.front());
  if (!info.has("k") || !info.has("width") || !info.has("height")) {
    throw ToolError(bag.where(msgs.front()) + ": camera info without k, width or height");
  }
  const Value& k = info["k"];
  if (k.items.size() != 9) throw ToolError(bag.where(msgs.front()) + ": k is not 3x3");
  cam->fx = k.items[0].number();
  cam->fy = k.items[4].number();
  cam->cx = k.items[2].number();
  cam->cy = k.items[5].number();
  const double w = info["width"].number(), h = info["height"].number();
  if (!(cam->fx > 0 && cam->fy > 0 && std::isfinite(cam->fx) && std::isfinite(cam->fy) &&
        std::isfinite(cam->cx) && std::isfinite(cam->cy) && w >= 1 && h >= 1 && w <= 8192 &&
        h <= 8192)) {
    throw ToolError(bag.where(msgs.front()) + ": camera info has fx " + std::to_string(cam->fx) +
                    ", fy " + std::to_string(cam->fy) + ", " + std::to_string(w) + "x" +
                    std::to_string(h) + ": not a usable camera");
  }
  cam->width = static_cast<int>(w);
  cam->height = static_cast<int>(h);
}

struct ImageScan {
  std::vector<SequenceFrame> candidates;
  std::vector<Ros2Bag::Message> images;
  std::vector<SkippedDepth> skipped;
  std::string frame_id;
  std::string encoding;
};

// The depth files dynamap-convert could not put in the bag, as listed frames whose loading
// reports what the folder's replay reported.
void add_skipped(const std::map<std::string, std::string>& meta, ImageScan* scan, Sequence* seq) {
  const auto it = meta.find("skipped_depth");
  if (it == meta.end() || it->second.empty()) return;
  std::istringstream is(it->second);
  std::string line;
  while (std::getline(is, line)) {
    const auto a = line.find('\t');
    const auto b = a == std::string::npos ? a : line.find('\t', a + 1);
    if (b == std::string::npos) continue;
    SequenceFrame f;
    f.stamp_text = line.substr(0, a);
    char* end = nullptr;
    f.stamp = std::strtod(f.stamp_text.c_str(), &end);
    const int kind = std::atoi(line.substr(a + 1, b - a - 1).c_str());
    if (end == f.stamp_text.c_str() || !std::isfinite(f.stamp) || kind < 1 || kind > 3) continue;
    f.depth_path = line.substr(b + 1);
    f.source_index = scan->images.size() + scan->skipped.size();
    scan->skipped.push_back({static_cast<DepthProblem>(kind), line.substr(b + 1)});
    scan->candidates.push_back(std::move(f));
    ++seq->images_listed;
  }
  std::stable_sort(
      scan->candidates.begin(), scan->candidates.end(),
      [](const SequenceFrame& x, const SequenceFrame& y) { return x.stamp < y.stamp; });
}

// Every image's header (stamp, frame, encoding), sorted by stamp; the stamp texts of
// dynamap-convert's metadata when they name the same nanosecond.
ImageScan scan_images(Ros2Bag& bag, const std::string& topic,
                      const std::map<std::string, std::string>& meta, Sequence* seq) {
  std::map<std::int64_t, std::string> texts;
  const auto st = meta.find("depth_stamps");
  if (st != meta.end()) {
    std::istringstream is(st->second);
    std::string line;
    std::int64_t ns = 0;
    while (std::getline(is, line)) {
      if (stamp_text_to_ns(line, &ns)) texts[ns] = line;
    }
  }
  ImageScan scan;
  std::vector<std::pair<std::int64_t, Ros2Bag::Message>> stamped;
  for (const Ros2Bag::Message& m : bag.messages(topic)) {
    ImageView img;
    try {
      img = decode_image(bag, m, false);
    } catch (const ToolError& e) {
      seq->warnings.push_back(std::string(e.what()) + ": image skipped");
      continue;
    }
    stamped.emplace_back(img.stamp_ns, m);
    if (scan.frame_id.empty()) scan.frame_id = strip_slash(img.frame_id);
    if (scan.encoding.empty()) scan.encoding = img.encoding;
  }
  std::stable_sort(stamped.begin(), stamped.end(),
                   [](const auto& a, const auto& b) { return a.first < b.first; });
  for (std::size_t k = 0; k < stamped.size(); ++k) {
    if (k > 0 && stamped[k].first == stamped[k - 1].first) {
      seq->warnings.push_back(bag.where(stamped[k].second) + ": a second image with stamp " +
                              ns_to_stamp_text(stamped[k].first) + "; skipped");
      continue;
    }
    SequenceFrame f;
    const auto t = texts.find(stamped[k].first);
    f.stamp_text = t != texts.end() ? t->second : ns_to_stamp_text(stamped[k].first);
    f.stamp = std::strtod(f.stamp_text.c_str(), nullptr);
    f.depth_path = bag.path() + " topic " + topic + " image at " + f.stamp_text;
    f.source_index = scan.images.size();
    scan.images.push_back(stamped[k].second);
    scan.candidates.push_back(std::move(f));
  }
  seq->images_listed = stamped.size();
  add_skipped(meta, &scan, seq);
  return scan;
}

}  // namespace

namespace {

struct PoseTrack {
  std::vector<StampedPose> poses;
  std::string child;  ///< the frame whose pose the topic gives
};

// One PoseStamped or Odometry message into the track.
void add_pose(const Ros2Bag& bag, const Ros2Bag::Message& m, const Value& msg, bool raw,
              PoseTrack* track, std::size_t* zero, std::vector<std::string>* warnings) {
  const bool odometry = msg.has("child_frame_id");
  const Value& pose = odometry ? msg["pose"]["pose"] : msg["pose"];
  if (odometry && !msg["child_frame_id"].s.empty() && track->poses.empty()) {
    track->child = strip_slash(msg["child_frame_id"].s);
  }
  StampedPose p;
  const std::int64_t ns = stamp_ns_of(msg["header"]);
  *zero += ns == 0;
  p.stamp = seconds_of(ns);
  if (!pose_of(pose["position"], pose["orientation"], &p.pose, raw)) {
    warnings->push_back(bag.where(m) +
                        ": pose with a degenerate quaternion or a non-finite position; ignored");
    return;
  }
  track->poses.push_back(p);
}

PoseTrack read_pose_topic(Ros2Bag& bag, const std::string& topic, const std::string& child,
                          bool raw, std::vector<std::string>* warnings) {
  PoseTrack track;
  track.child = child;
  std::size_t zero = 0;
  for (const Ros2Bag::Message& m : bag.messages(topic)) {
    const Value msg = bag.decode(m);
    try {
      add_pose(bag, m, msg, raw, &track, &zero, warnings);
    } catch (const ToolError& e) {
      throw ToolError(bag.where(m) + ": " + e.what());
    }
  }
  if (track.poses.empty()) throw ToolError(bag.path() + " topic " + topic + ": no usable pose");
  if (zero == track.poses.size()) {
    throw ToolError(bag.path() + " topic " + topic +
                    ": every header stamp is 0 (the publisher does not stamp its poses), so "
                    "no pose can be matched to a depth image");
  }
  std::stable_sort(track.poses.begin(), track.poses.end(),
                   [](const StampedPose& a, const StampedPose& b) { return a.stamp < b.stamp; });
  return track;
}

// The pose topic: by flag, else the only PoseStamped or Odometry topic, else /tf ("" returned).
std::string choose_pose_topic(const Ros2Bag& bag, const std::string& flag) {
  const std::vector<std::string> types = {"geometry_msgs/msg/PoseStamped", "nav_msgs/msg/Odometry",
                                          "tf2_msgs/msg/TFMessage"};
  if (!flag.empty()) return choose_topic(bag, flag, "pose", types, "--pose-topic", "");
  for (std::size_t k = 0; k < 2; ++k) {
    const auto found = bag.topics_of_type(types[k]);
    if (found.size() == 1) return found.front();
    if (found.size() > 1) {
      throw ToolError(bag.path() + ": several pose topics of type " + types[k] +
                      ": choose one with --pose-topic; " + bag.topic_list());
    }
  }
  if (bag.topics_of_type(types[2]).empty()) {
    throw ToolError(bag.path() + ": no pose topic (PoseStamped, Odometry or /tf); " +
                    bag.topic_list());
  }
  return "";
}

// Per image: T_world_camera = T_world_child(t) * T_child_camera(t) (or the tf chain alone when
// `track` is null); images without every link within the gap are counted as without pose.
std::vector<SequenceFrame> chain_poses(const Ros2Bag& bag, const TfTree& tf, const PoseTrack* track,
                                       const std::string& world, const std::string& camera,
                                       std::vector<SequenceFrame> candidates, double gap,
                                       Sequence* seq) {
  std::vector<SequenceFrame> kept;
  for (SequenceFrame& f : candidates) {
    PoseD base, link;
    std::string missing;
    if (track != nullptr && !interpolate_pose(track->poses, f.stamp, gap, &base)) {
      ++seq->images_without_pose;
      continue;
    }
    const std::string from = track != nullptr ? track->child : world;
    const TfTree::Result r = tf.lookup(from, camera, f.stamp, gap, &link, &missing);
    if (r == TfTree::Result::kNoPath) {
      std::string topics;
      for (const std::string& t : tf.topics) topics += (topics.empty() ? "" : ", ") + t;
      throw ToolError(bag.path() + ": pose chain from '" + from + "' to the camera frame '" +
                      camera + "' at " + f.stamp_text + ": " + missing + " on " +
                      (topics.empty() ? std::string("(no /tf topics)") : topics));
    }
    if (r == TfTree::Result::kNoSample) {
      ++seq->images_without_pose;
      continue;
    }
    seq->poses.push_back({f.stamp, track != nullptr ? compose(base, link) : link});
    kept.push_back(std::move(f));
  }
  return kept;
}

void set_camera(Ros2Bag& bag, const std::string& depth_topic, const std::string& encoding,
                const std::map<std::string, std::string>& meta, const SequenceReadOptions& o,
                Sequence* seq) {
  const std::string info_topic =
      choose_topic(bag, o.bag.info_topic, "camera info", {"sensor_msgs/msg/CameraInfo"},
                   "--info-topic", depth_topic.substr(0, depth_topic.rfind('/') + 1));
  read_camera_info(bag, info_topic, &seq->camera);
  seq->has_camera_file = true;
  const auto f = meta.find("depth_factor");
  const auto z = meta.find("world_z_up");
  // 16UC1: millimetres unless told; 32FC1 metres are stored as millimetres (1 mm steps).
  seq->camera.depth_factor = 1000.0;
  if (f != meta.end() && encoding != "32FC1") {
    seq->camera.depth_factor = std::strtod(f->second.c_str(), nullptr);
  }
  if (o.bag.depth_factor > 0 && encoding != "32FC1") seq->camera.depth_factor = o.bag.depth_factor;
  if (!(seq->camera.depth_factor > 0)) throw ToolError(bag.path() + ": depth_factor must be > 0");
  seq->camera.world_z_up = 0;
  if (z != meta.end()) seq->camera.world_z_up = z->second == "1" ? 1 : 0;
  if (o.bag.world_z_up >= 0) seq->camera.world_z_up = o.bag.world_z_up;
}

}  // namespace

Sequence read_ros2_bag(const std::string& path, const SequenceReadOptions& options) {
  auto bag = std::make_shared<Ros2Bag>(path);
  Sequence seq;
  seq.dir = path;
  seq.warnings = bag->problems();
  const auto meta = sequence_metadata(*bag);
  const BagReadOptions& o = options.bag;
  const std::string depth_topic = choose_topic(*bag, o.depth_topic, "depth image",
                                               {"sensor_msgs/msg/Image"}, "--depth-topic", "depth");
  ImageScan scan = scan_images(*bag, depth_topic, meta, &seq);
  if (scan.candidates.empty()) {
    throw ToolError(path + " topic " + depth_topic + ": no readable depth image" +
                    (seq.warnings.empty() ? std::string() : " (" + seq.warnings.front() + ")"));
  }
  set_camera(*bag, depth_topic, scan.encoding, meta, options, &seq);
  const std::string camera = o.camera_frame.empty() ? scan.frame_id : strip_slash(o.camera_frame);
  const std::string pose_topic = choose_pose_topic(*bag, o.pose_topic);
  const bool tf_topic =
      pose_topic.empty() ||
      ros2msg::normalise_type(bag->topic(pose_topic)->type) == "tf2_msgs/TFMessage";
  seq.pose_file = path + " topic " + (tf_topic ? std::string("/tf") : pose_topic);
  seq.source = std::make_shared<BagDepthSource>(bag, scan.images, scan.skipped);
  if (!tf_topic) {
    const PoseTrack track =
        read_pose_topic(*bag, pose_topic, o.pose_child.empty() ? camera : strip_slash(o.pose_child),
                        o.raw_poses, &seq.warnings);
    if (track.child == camera || camera.empty()) {
      seq.poses = track.poses;  // the optical frame's own poses: interpolated as for a folder
      const auto conv = meta.find("poses");
      const bool bonn =
          options.poses == PoseConvention::kBonn || (conv != meta.end() && conv->second == "bonn");
      if (bonn && !o.raw_poses) {
        for (auto& p : seq.poses) p.pose = bonn_marker_to_optical(p.pose);
        seq.camera.world_z_up = 1;
      }
      finish_sequence(seq, std::move(scan.candidates), options, path);
      return seq;
    }
    const TfTree tf = read_tf(*bag, &seq.warnings);
    seq.pose_file += " and " + track.child + " -> " + camera + " from /tf";
    auto kept = chain_poses(*bag, tf, &track, "", camera, std::move(scan.candidates),
                            options.max_pose_gap, &seq);
    finish_sequence(seq, std::move(kept), options, path);
    return seq;
  }
  const TfTree tf = read_tf(*bag, &seq.warnings);
  const std::string world = o.world_frame.empty() ? tf.root_of(camera) : strip_slash(o.world_frame);
  seq.pose_file += " (" + world + " -> " + camera + ")";
  auto kept = chain_poses(*bag, tf, nullptr, world, camera, std::move(scan.candidates),
                          options.max_pose_gap, &seq);
  finish_sequence(seq, std::move(kept), options, path);
  return seq;
}

}  // namespace dynamap::tools
