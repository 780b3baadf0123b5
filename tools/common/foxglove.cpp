#include "common/foxglove.hpp"

#include <cmath>
#include <cstdio>
#include <cstring>
#include <map>

#include "common/text_io.hpp"

namespace dynamap::tools {
namespace {

// JSON Schema pieces of the foxglove.* messages (field names as Foxglove defines them).
const std::string kNum = R"({"type":"number"})";
const std::string kInt = R"({"type":"integer"})";
const std::string kStr = R"({"type":"string"})";
const std::string kBool = R"({"type":"boolean"})";
const std::string kBytes = R"({"type":"string","contentEncoding":"base64"})";

std::string object(const std::vector<std::pair<std::string, std::string>>& props,
                   const std::string& title = "") {
  std::string s = "{" + (title.empty() ? std::string() : "\"title\":\"" + title + "\",") +
                  "\"type\":\"object\",\"properties\":{";
  std::string required;
  for (std::size_t k = 0; k < props.size(); ++k) {
    s += (k > 0 ? "," : "") + ("\"" + props[k].first + "\":") + props[k].second;
    required += (k > 0 ? ",\"" : "\"") + props[k].first + "\"";
  }
  return s + "},\"required\":[" + required + "]}";
}
std::string array(const std::string& items) {
  return R"({"type":"array","items":)" + items + "}";
}

const std::string kTime = object({{"sec", kInt}, {"nsec", kInt}});
const std::string kVec3 = object({{"x", kNum}, {"y", kNum}, {"z", kNum}});
const std::string kQuat = object({{"x", kNum}, {"y", kNum}, {"z", kNum}, {"w", kNum}});
const std::string kPose = object({{"position", kVec3}, {"orientation", kQuat}});
const std::string kColor = object({{"r", kNum}, {"g", kNum}, {"b", kNum}, {"a", kNum}});

std::string entity_schema() {
  const std::string arrow = object({{"pose", kPose},
                                    {"shaft_length", kNum},
                                    {"shaft_diameter", kNum},
                                    {"head_length", kNum},
                                    {"head_diameter", kNum},
                                    {"color", kColor}});
  const std::string cube = object({{"pose", kPose}, {"size", kVec3}, {"color", kColor}});
  const std::string line = object({{"type", kInt},
                                   {"pose", kPose},
                                   {"thickness", kNum},
                                   {"scale_invariant", kBool},
                                   {"points", array(kVec3)},
                                   {"color", kColor},
                                   {"colors", array(kColor)},
                                   {"indices", array(kInt)}});
  const std::string text = object({{"pose", kPose},
                                   {"billboard", kBool},
                                   {"font_size", kNum},
                                   {"scale_invariant", kBool},
                                   {"color", kColor},
                                   {"text", kStr}});
  const std::string any = R"({"type":"object"})";
  return object({{"timestamp", kTime},
                 {"frame_id", kStr},
                 {"id", kStr},
                 {"lifetime", kTime},
                 {"frame_locked", kBool},
                 {"metadata", array(object({{"key", kStr}, {"value", kStr}}))},
                 {"arrows", array(arrow)},
                 {"cubes", array(cube)},
                 {"spheres", array(any)},
                 {"cylinders", array(any)},
                 {"lines", array(line)},
                 {"triangles", array(any)},
                 {"texts", array(text)},
                 {"models", array(any)}});
}

std::string num(double v) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.9g", std::isfinite(v) ? v : 0.0);
  return buf;
}

std::string time_json(std::uint64_t ns) {
  return "{\"sec\":" + std::to_string(ns / 1000000000ULL) +
         ",\"nsec\":" + std::to_string(ns % 1000000000ULL) + "}";
}

std::string vec3(double x, double y, double z) {
  return "{\"x\":" + num(x) + ",\"y\":" + num(y) + ",\"z\":" + num(z) + "}";
}

std::string pose_json(const Eigen::Vector3d& p, const Eigen::Quaterniond& q) {
  return "{\"position\":" + vec3(p.x(), p.y(), p.z()) + ",\"orientation\":{\"x\":" + num(q.x()) +
         ",\"y\":" + num(q.y()) + ",\"z\":" + num(q.z()) + ",\"w\":" + num(q.w()) + "}}";
}

std::string color(double r, double g, double b, double a) {
  return "{\"r\":" + num(r) + ",\"g\":" + num(g) + ",\"b\":" + num(b) + ",\"a\":" + num(a) + "}";
}

std::string base64(const std::uint8_t* p, std::size_t n) {
  static const char* t = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((n + 2) / 3 * 4);
  for (std::size_t i = 0; i < n; i += 3) {
    const std::uint32_t v = static_cast<std::uint32_t>(p[i]) << 16 |
                            (i + 1 < n ? static_cast<std::uint32_t>(p[i + 1]) << 8 : 0u) |
                            (i + 2 < n ? p[i + 2] : 0u);
    out.push_back(t[v >> 18 & 63]);
    out.push_back(t[v >> 12 & 63]);
    out.push_back(i + 1 < n ? t[v >> 6 & 63] : '=');
    out.push_back(i + 2 < n ? t[v & 63] : '=');
  }
  return out;
}

// One scene entity in the world frame; `body` holds its primitive arrays (others empty).
std::string entity(std::uint64_t t, const std::string& id,
                   std::map<std::string, std::string> body) {
  std::string s = "{\"timestamp\":" + time_json(t) + ",\"frame_id\":\"world\",\"id\":\"" + id +
                  "\",\"lifetime\":{\"sec\":0,\"nsec\":0},\"frame_locked\":false,\"metadata\":[]";
  for (const char* k :
       {"arrows", "cubes", "spheres", "cylinders", "lines", "triangles", "texts", "models"}) {
    s += ",\"" + std::string(k) + "\":[" + body[k] + "]";
  }
  return s + "}";
}

// A scene update that first deletes every earlier entity of the channel.
std::string scene(std::uint64_t t, const std::vector<std::string>& entities) {
  std::string s =
      "{\"deletions\":[{\"timestamp\":" + time_json(t) + ",\"type\":1,\"id\":\"\"}],\"entities\":[";
  for (std::size_t k = 0; k < entities.size(); ++k) s += (k > 0 ? "," : "") + entities[k];
  return s + "]}";
}

std::string cube(const Eigen::Vector3d& c, const Eigen::Vector3d& size, const std::string& col) {
  return "{\"pose\":" + pose_json(c, Eigen::Quaterniond::Identity()) +
         ",\"size\":" + vec3(size.x(), size.y(), size.z()) + ",\"color\":" + col + "}";
}

std::string text(const Eigen::Vector3d& at, const std::string& s) {
  return "{\"pose\":" + pose_json(at, Eigen::Quaterniond::Identity()) +
         ",\"billboard\":true,\"font_size\":14,\"scale_invariant\":true,\"color\":" +
         color(1, 1, 1, 1) + ",\"text\":\"" + s + "\"}";
}

}  // namespace

std::string foxglove_schema(const std::string& name) {
  if (name == "foxglove.FrameTransform") {
    return object({{"timestamp", kTime},
                   {"parent_frame_id", kStr},
                   {"child_frame_id", kStr},
                   {"translation", kVec3},
                   {"rotation", kQuat}},
                  name);
  }
  if (name == "foxglove.RawImage") {
    return object({{"timestamp", kTime},
                   {"frame_id", kStr},
                   {"width", kInt},
                   {"height", kInt},
                   {"encoding", kStr},
                   {"step", kInt},
                   {"data", kBytes}},
                  name);
  }
  if (name == "foxglove.PointCloud") {
    return object({{"timestamp", kTime},
                   {"frame_id", kStr},
                   {"pose", kPose},
                   {"point_stride", kInt},
                   {"fields", array(object({{"name", kStr}, {"offset", kInt}, {"type", kInt}}))},
                   {"data", kBytes}},
                  name);
  }
  if (name == "foxglove.SceneUpdate") {
    const std::string deletion = object({{"timestamp", kTime}, {"type", kInt}, {"id", kStr}});
    return object({{"deletions", array(deletion)}, {"entities", array(entity_schema())}}, name);
  }
  return "";
}

FoxgloveOutput::FoxgloveOutput(const std::string& path, const CameraModel& camera, long map_every,
                               std::vector<ObstacleRecord> reference)
    : writer_(path, "", "zstd"),
      camera_(camera),
      map_every_(map_every),
      reference_(std::move(reference)) {
  auto channel = [&](const std::string& topic, const std::string& type) {
    const std::uint16_t s = writer_.add_schema(type, "jsonschema", foxglove_schema(type));
    return writer_.add_channel(s, topic, "json");
  };
  pose_ = channel("/camera/pose", "foxglove.FrameTransform");
  image_ = channel("/camera/depth", "foxglove.RawImage");
  tracks_ = channel("/tracks", "foxglove.SceneUpdate");
  paths_ = channel("/predictions", "foxglove.SceneUpdate");
  map_ = channel("/map", "foxglove.PointCloud");
  if (!reference_.empty()) people_ = channel("/reference", "foxglove.SceneUpdate");
}

void FoxgloveOutput::write(std::uint16_t channel, std::uint64_t t, const std::string& json) {
  writer_.write(channel, t, t, json.data(), json.size());
}

void FoxgloveOutput::frame(const SequenceFrame& f, std::uint64_t t, const Image16& depth,
                           const Pose& camera, const Pipeline& pipeline, const FrameOutput& out) {
  const Eigen::Vector3d p = camera.translation.cast<double>();
  const Eigen::Quaterniond q = camera.rotation.cast<double>();
  write(pose_, t,
        "{\"timestamp\":" + time_json(t) +
            ",\"parent_frame_id\":\"world\",\"child_frame_id\":\"camera\",\"translation\":" +
            vec3(p.x(), p.y(), p.z()) + ",\"rotation\":{\"x\":" + num(q.x()) +
            ",\"y\":" + num(q.y()) + ",\"z\":" + num(q.z()) + ",\"w\":" + num(q.w()) + "}}");
  const auto* bytes = reinterpret_cast<const std::uint8_t*>(depth.pixels.data());
  write(image_, t,
        "{\"timestamp\":" + time_json(t) + ",\"frame_id\":\"camera\",\"width\":" +
            std::to_string(depth.width) + ",\"height\":" + std::to_string(depth.height) +
            ",\"encoding\":\"16UC1\",\"step\":" + std::to_string(depth.width * 2) + ",\"data\":\"" +
            base64(bytes, depth.pixels.size() * 2) + "\"}");
  write_tracks(t, out);
  write_paths(t, pipeline, out);
  if (map_every_ > 0 && frames_ % static_cast<std::size_t>(map_every_) == 0) {
    write_map(t, pipeline, camera);
  }
  if (!reference_.empty()) write_reference(t, f.stamp);
  ++frames_;
}

void FoxgloveOutput::write_tracks(std::uint64_t t, const FrameOutput& out) {
  std::vector<std::string> entities;
  for (std::size_t i = 0; i < out.num_obstacles; ++i) {
    const TrackedObstacle& o = out.obstacles[i];
    const Eigen::Vector3d c = o.box.center().cast<double>();
    const Eigen::Vector3d size = o.box.size().cast<double>();
    const std::string col = o.dynamic ? color(0.9, 0.15, 0.1, 0.6) : color(0.2, 0.4, 0.9, 0.4);
    std::map<std::string, std::string> body;
    body["cubes"] = cube(c, size, col);
    char label[64];
    std::snprintf(label, sizeof(label), "%u%s %.2f m/s", o.id, o.dynamic ? " dynamic" : "",
                  static_cast<double>(o.speed));
    body["texts"] = text(c + Eigen::Vector3d(0, 0, 0.5 * size.z() + 0.2), label);
    const Eigen::Vector3d v = o.velocity.cast<double>();
    if (o.dynamic && v.norm() > 1e-3) {
      const Eigen::Quaterniond dir =
          Eigen::Quaterniond::FromTwoVectors(Eigen::Vector3d::UnitX(), v.normalized());
      body["arrows"] = "{\"pose\":" + pose_json(c, dir) + ",\"shaft_length\":" + num(v.norm()) +
                       ",\"shaft_diameter\":0.05,\"head_length\":0.15,\"head_diameter\":0.12,"
                       "\"color\":" +
                       color(1, 0.8, 0, 1) + "}";
    }
    entities.push_back(entity(t, "track/" + std::to_string(o.id), body));
  }
  write(tracks_, t, scene(t, entities));
}

void FoxgloveOutput::write_paths(std::uint64_t t, const Pipeline& pipeline,
                                 const FrameOutput& out) {
  std::vector<std::string> entities;
  auto line = [&](const PathPrediction& p, const std::string& col) {
    std::string points;
    for (std::size_t k = 0; k < p.num_samples; ++k) {
      const Eigen::Vector3f& x = p.position[k];
      points += (k > 0 ? "," : "") + vec3(x.x(), x.y(), x.z());
    }
    return "{\"type\":0,\"pose\":" +
           pose_json(Eigen::Vector3d::Zero(), Eigen::Quaterniond::Identity()) +
           ",\"thickness\":0.05,\"scale_invariant\":false,\"points\":[" + points +
           "],\"color\":" + col + ",\"colors\":[],\"indices\":[]}";
  };
  for (std::size_t i = 0; i < out.num_predictions; ++i) {
    const PathPrediction& p = out.predictions[i];
    std::map<std::string, std::string> body;
    body["lines"] = line(p, color(0.85, 0.1, 0.85, 1));
    if (pipeline.config().run_linear_baseline) {
      body["lines"] += "," + line(out.linear_predictions[i], color(0.55, 0.35, 0.15, 1));
    }
    entities.push_back(entity(t, "path/" + std::to_string(p.track_id), body));
  }
  write(paths_, t, scene(t, entities));
}

void FoxgloveOutput::write_map(std::uint64_t t, const Pipeline& pipeline, const Pose& camera) {
  constexpr float kRadius = 6.0f;  // m around the camera
  std::vector<float> xyz;
  pipeline.map().for_each_occupied([&](std::uint64_t, const Eigen::Vector3f& c) {
    if ((c - camera.translation).norm() <= kRadius) xyz.insert(xyz.end(), {c.x(), c.y(), c.z()});
  });
  const auto* bytes = reinterpret_cast<const std::uint8_t*>(xyz.data());
  write(map_, t,
        "{\"timestamp\":" + time_json(t) + ",\"frame_id\":\"world\",\"pose\":" +
            pose_json(Eigen::Vector3d::Zero(), Eigen::Quaterniond::Identity()) +
            ",\"point_stride\":12,\"fields\":[{\"name\":\"x\",\"offset\":0,\"type\":7},"
            "{\"name\":\"y\",\"offset\":4,\"type\":7},{\"name\":\"z\",\"offset\":8,\"type\":7}],"
            "\"data\":\"" +
            base64(bytes, xyz.size() * sizeof(float)) + "\"}");
}

void FoxgloveOutput::write_reference(std::uint64_t t, double stamp) {
  std::vector<std::string> entities;
  for (const ObstacleRecord& r : reference_) {
    if (std::fabs(r.stamp - stamp) > 1e-6) continue;
    std::map<std::string, std::string> body;
    body["cubes"] = cube(r.center, r.size, color(0.1, 0.8, 0.2, 0.35));
    body["texts"] = text(r.center + Eigen::Vector3d(0, 0, 0.5 * r.size.z() + 0.4),
                         "ref " + std::to_string(r.id));
    entities.push_back(entity(t, "ref/" + std::to_string(r.id), body));
  }
  write(people_, t, scene(t, entities));
}

std::unique_ptr<FoxgloveOutput> make_foxglove_output(const ReplayExtras& extras,
                                                     const Sequence& seq,
                                                     const std::vector<ObstacleRecord>& truth) {
  if (extras.mcap.empty()) return nullptr;
  std::vector<ObstacleRecord> people = truth;
  if (!extras.reference.empty()) people = read_obstacles(extras.reference);
  return std::make_unique<FoxgloveOutput>(extras.mcap, seq.camera, extras.mcap_map_every,
                                          std::move(people));
}

}  // namespace dynamap::tools
