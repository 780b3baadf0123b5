#include "common/ros2_bag.hpp"

#include <dirent.h>
#include <sys/stat.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <set>
#include <sstream>

#include "common/text_io.hpp"

namespace dynamap::tools {
namespace {

bool is_directory(const std::string& path) {
  struct stat st {};
  return ::stat(path.c_str(), &st) == 0 && S_ISDIR(st.st_mode);
}

bool ends_with(const std::string& s, const std::string& tail) {
  return s.size() >= tail.size() && s.compare(s.size() - tail.size(), tail.size(), tail) == 0;
}

// The .mcap files of a bag folder, sorted (rosbag2 numbers its splits _0, _1, ...).
std::vector<std::string> mcap_files(const std::string& path) {
  if (!is_directory(path)) return {path};
  std::vector<std::string> names;
  if (DIR* d = ::opendir(path.c_str())) {
    while (const dirent* e = ::readdir(d)) {
      const std::string n = e->d_name;
      if (ends_with(n, ".mcap")) names.push_back(n);
    }
    ::closedir(d);
  }
  std::sort(names.begin(), names.end(), [](const std::string& a, const std::string& b) {
    return a.size() != b.size() ? a.size() < b.size() : a < b;  // _2 before _10
  });
  std::vector<std::string> files;
  for (const std::string& n : names) files.push_back(join_path(path, n));
  if (files.empty()) throw ToolError(path + ": a bag folder without .mcap files");
  return files;
}

const std::string kHeader =
    "================================================================================\n"
    "MSG: std_msgs/Header\nbuiltin_interfaces/Time stamp\nstring frame_id\n"
    "================================================================================\n"
    "MSG: builtin_interfaces/Time\nint32 sec\nuint32 nanosec\n";
const std::string kQuaternion =
    "================================================================================\n"
    "MSG: geometry_msgs/Quaternion\nfloat64 x 0\nfloat64 y 0\nfloat64 z 0\nfloat64 w 1\n";
const std::string kPose =
    "================================================================================\n"
    "MSG: geometry_msgs/Pose\ngeometry_msgs/Point position\n"
    "geometry_msgs/Quaternion orientation\n"
    "================================================================================\n"
    "MSG: geometry_msgs/Point\nfloat64 x\nfloat64 y\nfloat64 z\n" +
    kQuaternion;
const std::string kVector3 =
    "================================================================================\n"
    "MSG: geometry_msgs/Vector3\nfloat64 x\nfloat64 y\nfloat64 z\n";

}  // namespace

const std::string& builtin_schema(const std::string& type) {
  static const std::map<std::string, std::string> schemas = {
      {"sensor_msgs/Image",
       "std_msgs/Header header\nuint32 height\nuint32 width\nstring encoding\n"
       "uint8 is_bigendian\nuint32 step\nuint8[] data\n" +
           kHeader},
      {"sensor_msgs/CameraInfo",
       "std_msgs/Header header\nuint32 height\nuint32 width\nstring distortion_model\n"
       "float64[] d\nfloat64[9] k\nfloat64[9] r\nfloat64[12] p\nuint32 binning_x\n"
       "uint32 binning_y\nsensor_msgs/RegionOfInterest roi\n" +
           kHeader +
           "================================================================================\n"
           "MSG: sensor_msgs/RegionOfInterest\nuint32 x_offset\nuint32 y_offset\n"
           "uint32 height\nuint32 width\nbool do_rectify\n"},
      {"geometry_msgs/PoseStamped",
       "std_msgs/Header header\ngeometry_msgs/Pose pose\n" + kHeader + kPose},
      {"tf2_msgs/TFMessage",
       "geometry_msgs/TransformStamped[] transforms\n"
       "================================================================================\n"
       "MSG: geometry_msgs/TransformStamped\nstd_msgs/Header header\nstring child_frame_id\n"
       "geometry_msgs/Transform transform\n"
       "================================================================================\n"
       "MSG: geometry_msgs/Transform\ngeometry_msgs/Vector3 translation\n"
       "geometry_msgs/Quaternion rotation\n" +
           kHeader + kVector3 + kQuaternion},
      {"nav_msgs/Odometry",
       "std_msgs/Header header\nstring child_frame_id\n"
       "geometry_msgs/PoseWithCovariance pose\ngeometry_msgs/TwistWithCovariance twist\n"
       "================================================================================\n"
       "MSG: geometry_msgs/PoseWithCovariance\ngeometry_msgs/Pose pose\nfloat64[36] covariance\n"
       "================================================================================\n"
       "MSG: geometry_msgs/TwistWithCovariance\ngeometry_msgs/Twist twist\n"
       "float64[36] covariance\n"
       "================================================================================\n"
       "MSG: geometry_msgs/Twist\ngeometry_msgs/Vector3 linear\ngeometry_msgs/Vector3 angular\n" +
           kHeader + kPose + kVector3},
  };
  static const std::string none;
  const auto it = schemas.find(ros2msg::normalise_type(type));
  return it == schemas.end() ? none : it->second;
}

bool is_ros2_bag(const std::string& path) {
  if (!is_directory(path)) return ends_with(path, ".mcap") && file_exists(path);
  if (file_exists(join_path(path, "depth.txt"))) return false;
  if (file_exists(join_path(path, "metadata.yaml"))) return true;
  try {
    return !mcap_files(path).empty();
  } catch (const ToolError&) {
    return false;
  }
}

bool stamp_text_to_ns(const std::string& text, std::int64_t* ns) {
  std::size_t i = 0;
  const bool negative = !text.empty() && text[0] == '-';
  if (negative) ++i;
  std::int64_t whole = 0, frac = 0;
  int digits = 0, frac_digits = 0;
  for (; i < text.size() && text[i] != '.'; ++i, ++digits) {
    if (text[i] < '0' || text[i] > '9' || digits >= 10) return false;
    whole = whole * 10 + (text[i] - '0');
  }
  if (i < text.size()) {
    for (++i; i < text.size(); ++i, ++frac_digits) {
      if (text[i] < '0' || text[i] > '9' || frac_digits >= 9) return false;
      frac = frac * 10 + (text[i] - '0');
    }
  }
  if ((digits == 0 && frac_digits == 0) || whole > 9223372035LL) return false;
  for (int k = frac_digits; k < 9; ++k) frac *= 10;
  const std::int64_t v = whole * 1000000000LL + frac;
  *ns = negative ? -v : v;
  return true;
}

std::string ns_to_stamp_text(std::int64_t ns) {
  const bool negative = ns < 0;
  const std::uint64_t a = negative ? static_cast<std::uint64_t>(-(ns + 1)) + 1 : ns;
  char buf[48];
  std::snprintf(buf, sizeof(buf), "%s%llu.%09llu", negative ? "-" : "",
                static_cast<unsigned long long>(a / 1000000000ULL),
                static_cast<unsigned long long>(a % 1000000000ULL));
  return buf;
}

Ros2Bag::Ros2Bag(const std::string& path) : path_(path) {
  for (const std::string& f : mcap_files(path)) files_.push_back(std::make_unique<mcap::Reader>(f));
  std::map<std::string, Topic> topics;
  for (const auto& file : files_) {
    for (const auto& [id, ch] : file->channels()) {
      Topic& t = topics[ch.topic];
      t.name = ch.topic;
      t.encoding = ch.message_encoding;
      const auto s = file->schemas().find(ch.schema_id);
      if (s != file->schemas().end()) t.type = s->second.name;
    }
    for (const mcap::MessageRef& m : file->messages()) {
      const auto ch = file->channels().find(m.channel_id);
      if (ch != file->channels().end()) ++topics[ch->second.topic].count;
    }
  }
  for (auto& [name, t] : topics) topics_.push_back(t);
}

const Ros2Bag::Topic* Ros2Bag::topic(const std::string& name) const {
  for (const Topic& t : topics_) {
    if (t.name == name) return &t;
  }
  return nullptr;
}

std::string Ros2Bag::topic_list() const {
  std::ostringstream os;
  os << "the bag's topics:";
  if (topics_.empty()) os << " none";
  for (const Topic& t : topics_) {
    os << "\n  " << t.name << "  " << (t.type.empty() ? "(no schema)" : t.type) << "  (" << t.count
       << " messages)";
  }
  return os.str();
}

std::vector<std::string> Ros2Bag::topics_of_type(const std::string& type) const {
  std::vector<std::string> out;
  for (const Topic& t : topics_) {
    if (ros2msg::normalise_type(t.type) == ros2msg::normalise_type(type)) out.push_back(t.name);
  }
  return out;
}

std::vector<Ros2Bag::Message> Ros2Bag::messages(const std::string& topic) const {
  std::vector<Message> out;
  for (std::size_t f = 0; f < files_.size(); ++f) {
    std::set<std::uint16_t> ids;
    for (const auto& [id, ch] : files_[f]->channels()) {
      if (ch.topic == topic) ids.insert(id);
    }
    for (const mcap::MessageRef& m : files_[f]->messages()) {
      if (ids.count(m.channel_id) != 0) out.push_back({f, &m});
    }
  }
  return out;
}

const std::string& Ros2Bag::topic_of(const Message& m) const {
  return files_[m.file]->channels().at(m.ref->channel_id).topic;
}

mcap::Bytes Ros2Bag::data(const Message& m) {
  return files_[m.file]->data(*m.ref);
}

std::string Ros2Bag::where(const Message& m) const {
  return path_ + " topic " + topic_of(m) + " at log time " +
         ns_to_stamp_text(static_cast<std::int64_t>(m.ref->log_time));
}

const std::map<std::string, ros2msg::Definition>& Ros2Bag::definitions(std::size_t file,
                                                                       std::uint16_t channel) {
  const auto key = std::make_pair(file, channel);
  const auto it = definitions_.find(key);
  if (it != definitions_.end()) return it->second;
  const mcap::Channel& ch = files_[file]->channels().at(channel);
  const auto s = files_[file]->schemas().find(ch.schema_id);
  if (s == files_[file]->schemas().end()) {
    throw ToolError(path_ + " topic " + ch.topic + ": the channel has no schema");
  }
  if (ch.message_encoding != "cdr" || s->second.encoding != "ros2msg") {
    throw ToolError(path_ + " topic " + ch.topic + ": message encoding '" + ch.message_encoding +
                    "' with schema encoding '" + s->second.encoding +
                    "' is not ROS 2 CDR with a ros2msg schema");
  }
  const std::string& text =
      s->second.data.empty() ? builtin_schema(s->second.name) : s->second.data;
  if (text.empty()) {
    throw ToolError(path_ + " topic " + ch.topic + ": type " + s->second.name +
                    " has an empty schema");
  }
  return definitions_[key] = ros2msg::parse_schema(s->second.name, text);
}

ros2msg::Value Ros2Bag::decode(const Message& m) {
  try {
    const auto& defs = definitions(m.file, m.ref->channel_id);
    const mcap::Channel& ch = files_[m.file]->channels().at(m.ref->channel_id);
    const std::string root =
        ros2msg::normalise_type(files_[m.file]->schemas().at(ch.schema_id).name);
    const mcap::Bytes b = data(m);
    cdr::Reader in(b.data, b.size);
    return ros2msg::decode(defs, root, in);
  } catch (const ToolError& e) {
    throw ToolError(where(m) + ": " + e.what());
  }
}

std::vector<std::string> Ros2Bag::problems() const {
  std::vector<std::string> out;
  for (const auto& f : files_) {
    out.insert(out.end(), f->warnings().begin(), f->warnings().end());
    if (!f->damage().empty()) {
      out.push_back(f->damage() + "; read " + std::to_string(f->messages().size()) +
                    " messages before it");
    }
  }
  return out;
}

const std::vector<mcap::MetadataRecord> Ros2Bag::metadata() const {
  std::vector<mcap::MetadataRecord> out;
  for (const auto& f : files_) out.insert(out.end(), f->metadata().begin(), f->metadata().end());
  return out;
}

}  // namespace dynamap::tools
