#include "common/sequence.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iomanip>
#include <limits>

#include <Eigen/Eigenvalues>
#include <Eigen/SVD>

#include "common/ros2_bag.hpp"
#include "common/text_io.hpp"

namespace dynamap::tools {
namespace {

/// Largest image side camera.txt may give.
constexpr long long kMaxCameraSide = 8192;

/// An image side, range-checked before it is narrowed to int (4294967936 is not 640).
int image_side(const std::string& field, const TextLocation& at, const char* name) {
  const long long v = parse_int(field, at, name);
  if (v < 1 || v > kMaxCameraSide) {
    fail_at(at, std::string(name) + " must be in 1.." + std::to_string(kMaxCameraSide) + ", got " +
                    field);
  }
  return static_cast<int>(v);
}

}  // namespace

CameraModel read_camera_file(const std::string& path, bool* present,
                             std::vector<std::string>* warnings) {
  CameraModel cam;
  if (present != nullptr) *present = file_exists(path);
  if (!file_exists(path)) return cam;
  const auto lines = read_lines(path);
  for (std::size_t i = 0; i < lines.size(); ++i) {
    const TextLocation at{path, i + 1};
    const std::string body = strip_comment(lines[i]);
    if (body.empty()) continue;
    const auto f = split_ws(body);
    if (f.size() < 2) fail_at(at, "expected 'key value', got '" + lines[i] + "'");
    const std::string& key = f[0];
    if (key == "fx") {
      cam.fx = parse_double(f[1], at, "fx");
    } else if (key == "fy") {
      cam.fy = parse_double(f[1], at, "fy");
    } else if (key == "cx") {
      cam.cx = parse_double(f[1], at, "cx");
    } else if (key == "cy") {
      cam.cy = parse_double(f[1], at, "cy");
    } else if (key == "width") {
      cam.width = image_side(f[1], at, "width");
    } else if (key == "height") {
      cam.height = image_side(f[1], at, "height");
    } else if (key == "depth_factor") {
      cam.depth_factor = parse_double(f[1], at, "depth_factor");
    } else if (key == "world_z_up") {
      const long long v = parse_int(f[1], at, "world_z_up");
      if (v != 0 && v != 1) fail_at(at, "world_z_up must be 0 or 1");
      cam.world_z_up = static_cast<int>(v);
    } else if (warnings != nullptr) {
      warnings->push_back(at.str() + ": unknown key '" + key + "' ignored");
    }
  }
  const TextLocation whole{path, 0};
  if (cam.fx <= 0 || cam.fy <= 0) fail_at(whole, "fx and fy must be positive");
  if (cam.width <= 0 || cam.height <= 0 || cam.width > 8192 || cam.height > 8192) {
    fail_at(whole, "width/height out of range");
  }
  if (cam.depth_factor <= 0) fail_at(whole, "depth_factor must be positive");
  return cam;
}

void write_camera_file(const std::string& path, const CameraModel& c) {
  std::ofstream out(path);
  if (!out) throw ToolError(path + ": cannot create file");
  out << std::setprecision(10);
  out << "fx " << c.fx << "\nfy " << c.fy << "\ncx " << c.cx << "\ncy " << c.cy << "\nwidth "
      << c.width << "\nheight " << c.height << "\ndepth_factor " << c.depth_factor
      << "     # depth units per metre\nworld_z_up " << c.world_z_up << "\n";
  if (!out) throw ToolError(path + ": write error");
}

std::vector<StampedPose> read_groundtruth(const std::string& path) {
  const auto lines = read_lines(path);
  std::vector<StampedPose> poses;
  for (std::size_t i = 0; i < lines.size(); ++i) {
    const TextLocation at{path, i + 1};
    const std::string body = strip_comment(lines[i]);
    if (body.empty()) continue;
    const auto f = split_ws(body);
    if (f.size() < 8) {
      fail_at(at, "expected 'timestamp tx ty tz qx qy qz qw', got " + std::to_string(f.size()) +
                      " fields");
    }
    StampedPose p;
    p.stamp = parse_double(f[0], at, "timestamp");
    p.pose.translation = {parse_double(f[1], at, "tx"), parse_double(f[2], at, "ty"),
                          parse_double(f[3], at, "tz")};
    const double qx = parse_double(f[4], at, "qx"), qy = parse_double(f[5], at, "qy"),
                 qz = parse_double(f[6], at, "qz"), qw = parse_double(f[7], at, "qw");
    Eigen::Quaterniond q(qw, qx, qy, qz);
    if (q.norm() < 0.5) fail_at(at, "quaternion is far from unit length");
    q.normalize();
    p.pose.rotation = q;
    poses.push_back(p);
  }
  std::stable_sort(poses.begin(), poses.end(),
                   [](const StampedPose& a, const StampedPose& b) { return a.stamp < b.stamp; });
  return poses;
}

bool interpolate_pose(const std::vector<StampedPose>& poses, double t, double max_gap, PoseD* out) {
  // First pose with stamp >= t.
  const auto hi = std::lower_bound(poses.begin(), poses.end(), t,
                                   [](const StampedPose& p, double s) { return p.stamp < s; });
  if (hi != poses.end() && hi->stamp == t) {
    *out = hi->pose;
    return true;
  }
  if (hi == poses.end() || hi == poses.begin()) return false;
  const auto lo = hi - 1;
  if (t - lo->stamp > max_gap || hi->stamp - t > max_gap) return false;
  const double a = (t - lo->stamp) / (hi->stamp - lo->stamp);
  out->translation = (1.0 - a) * lo->pose.translation + a * hi->pose.translation;
  out->rotation = lo->pose.rotation.slerp(a, hi->pose.rotation).normalized();
  return true;
}

PoseD bonn_marker_to_optical(const PoseD& marker_pose) {
  // The dataset's published transforms (its README / tools): T_ros swaps the ROS and the
  // motion-capture axis conventions (it is its own inverse); T_m takes the camera to the marker.
  Eigen::Matrix4d t_ros;
  t_ros << -1, 0, 0, 0, 0, 0, 1, 0, 0, 1, 0, 0, 0, 0, 0, 1;
  Eigen::Matrix4d t_m;
  t_m << 1.0157, 0.1828, -0.2389, 0.0113, 0.0009, -0.8431, -0.6413, -0.0098, -0.3009, 0.6147,
      -0.8085, 0.0111, 0, 0, 0, 1;
  // T_m's rotation block carries a uniform scale of ~1.059 (a calibration artefact): a pose needs
  // a rotation, so take the nearest one (polar decomposition), keeping the translation.
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(t_m.topLeftCorner<3, 3>(),
                                              Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d r_m = svd.matrixU() * svd.matrixV().transpose();
  if (r_m.determinant() < 0) {
    Eigen::Matrix3d u = svd.matrixU();
    u.col(2) = -u.col(2);
    r_m = u * svd.matrixV().transpose();
  }
  t_m.topLeftCorner<3, 3>() = r_m;
  // The dataset's world is y up; a +90 deg turn about x makes it z up (floor at z ~ 0).
  Eigen::Matrix4d rx = Eigen::Matrix4d::Identity();
  rx.topLeftCorner<3, 3>() = Eigen::AngleAxisd(0.5 * M_PI, Eigen::Vector3d::UnitX()).matrix();
  Eigen::Matrix4d t_gt = Eigen::Matrix4d::Identity();
  t_gt.topLeftCorner<3, 3>() = marker_pose.rotation.normalized().toRotationMatrix();
  t_gt.topRightCorner<3, 1>() = marker_pose.translation;
  const Eigen::Matrix4d t = rx * t_ros * t_gt * t_ros * t_m;
  PoseD out;
  out.translation = t.topRightCorner<3, 1>();
  out.rotation = Eigen::Quaterniond(Eigen::Matrix3d(t.topLeftCorner<3, 3>())).normalized();
  return out;
}

CameraModel bonn_camera() {
  CameraModel cam;
  cam.fx = 542.822841;
  cam.fy = 542.576870;
  cam.cx = 315.593520;
  cam.cy = 237.756098;
  cam.depth_factor = 5000.0;
  cam.world_z_up = 1;
  return cam;
}

namespace {

// splitmix64: a small deterministic generator, so that the floor fit (and every tool's world)
// is the same on every run.
std::uint64_t next_random(std::uint64_t& state) {
  std::uint64_t z = (state += 0x9e3779b97f4a7c15ULL);
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  return z ^ (z >> 31);
}

// Moves every pose (and the frames' interpolated poses) by the rigid motion x -> R x + t.
void transform_world(Sequence& seq, const Eigen::Quaterniond& r, const Eigen::Vector3d& t) {
  auto apply = [&](PoseD& p) {
    p.translation = r * p.translation + t;
    p.rotation = (r * p.rotation).normalized();
  };
  for (StampedPose& p : seq.poses) apply(p.pose);
  for (SequenceFrame& f : seq.frames) apply(f.pose);
}

// The floor of a gravity-aligned sequence: depth points of up to kFloorFrames readable frames
// among the first ones, below the cameras, fitted with fit_floor_plane(); then the world is
// rotated so the normal is +z and moved so the floor is z = 0.
void level_on_floor(Sequence& seq) {
  constexpr std::size_t kFloorFrames = 8;   // spread over the first kFloorSpan frames
  constexpr std::size_t kFloorSpan = 120;   // 4 s at 30 Hz
  constexpr int kPixelStep = 8;             // ~4800 points per 640x480 frame
  constexpr std::size_t kMinInliers = 400;  // a floor seen, not a stray patch
  const std::size_t span = std::min(kFloorSpan, seq.frames.size());
  std::vector<Eigen::Vector3d> points;
  double lowest_camera = 1e300;
  for (std::size_t k = 0; k < kFloorFrames && span > 0; ++k) {
    const SequenceFrame& f = seq.frames[k * span / kFloorFrames];
    Image16 depth;
    std::string problem;
    if (try_load_depth(seq, f, &depth, &problem) != DepthProblem::kNone) continue;
    lowest_camera = std::min(lowest_camera, f.pose.translation.z());
    const Eigen::Matrix3d r = f.pose.rotation.toRotationMatrix();
    for (int v = 0; v < depth.height; v += kPixelStep) {
      for (int u = 0; u < depth.width; u += kPixelStep) {
        const double z = depth.at(u, v) / seq.camera.depth_factor;
        if (z < 0.3 || z > 6.0) continue;  // beyond ~6 m a Kinect-class floor is too noisy
        const Eigen::Vector3d c((u - seq.camera.cx) * z / seq.camera.fx,
                                (v - seq.camera.cy) * z / seq.camera.fy, z);
        points.push_back(r * c + f.pose.translation);
      }
    }
  }
  if (points.empty()) {
    seq.warnings.push_back(seq.dir +
                           ": no readable depth in the first frames: floor not found, "
                           "the world is only gravity-aligned (origin at the first pose)");
    return;
  }
  Eigen::Vector3d normal;
  double offset = 0.0;
  // The floor is at least 0.3 m below the lowest camera (a camera lying on the floor is no use).
  if (!fit_floor_plane(points, lowest_camera - 0.3, kMinInliers, &normal, &offset,
                       &seq.floor_points)) {
    seq.warnings.push_back(seq.dir +
                           ": no floor plane found in the first frames' depth: the "
                           "world is only gravity-aligned (origin at the first pose)");
    return;
  }
  const Eigen::Quaterniond tilt =
      Eigen::Quaterniond::FromTwoVectors(normal, Eigen::Vector3d::UnitZ());
  // A floor point p (n.p = offset) goes to tilt * p, whose z is offset: move it down by that.
  transform_world(seq, tilt, Eigen::Vector3d(0, 0, -offset));
  seq.world_alignment = (tilt * seq.world_alignment).normalized();
  seq.world_offset = Eigen::Vector3d(0, 0, -offset);
  seq.floor_levelled = true;
}

// depth.txt as candidate frames (stamps checked: finite, increasing, within the clock's span).
std::vector<SequenceFrame> read_depth_list(const std::string& dir, const std::string& depth_list,
                                           std::size_t* listed) {
  const auto lines = read_lines(depth_list);
  std::vector<SequenceFrame> frames;
  double previous = -std::numeric_limits<double>::infinity();
  double first_stamp = 0.0;
  std::size_t first_line = 0;
  for (std::size_t i = 0; i < lines.size(); ++i) {
    const TextLocation at{depth_list, i + 1};
    const std::string body = strip_comment(lines[i]);
    if (body.empty()) continue;
    const auto f = split_ws(body);
    if (f.size() < 2) fail_at(at, "expected 'timestamp filename', got '" + lines[i] + "'");
    SequenceFrame frame;
    frame.stamp = parse_double(f[0], at, "timestamp");
    if (!std::isfinite(frame.stamp)) fail_at(at, "time stamp must be finite");
    if (frame.stamp <= previous) fail_at(at, "time stamps must increase");
    if (first_line == 0) {
      first_line = i + 1;
      first_stamp = frame.stamp;
    }
    if (frame.stamp - first_stamp > kMaxStampSeconds) {
      fail_at(at, "time stamps span more than 9.2e9 s from the first one (line " +
                      std::to_string(first_line) + "): beyond the replay's nanosecond clock");
    }
    previous = frame.stamp;
    frame.stamp_text = f[0];
    frame.depth_path = join_path(dir, f[1]);
    ++*listed;
    frames.push_back(std::move(frame));
  }
  return frames;
}

}  // namespace

bool fit_floor_plane(const std::vector<Eigen::Vector3d>& points, double max_height,
                     std::size_t min_inliers, Eigen::Vector3d* normal, double* offset,
                     std::size_t* inliers) {
  constexpr double kInlierDistance = 0.03;  // m: Kinect-class noise at 1-4 m, small pose error
  constexpr int kTrials = 300;
  const double min_up = std::cos(30.0 * M_PI / 180.0);
  std::vector<Eigen::Vector3d> low;
  for (const Eigen::Vector3d& p : points) {
    if (p.z() < max_height) low.push_back(p);
  }
  *inliers = 0;
  if (low.size() < std::max<std::size_t>(min_inliers, 3)) return false;
  std::uint64_t state = 0x5eed;
  struct Candidate {
    Eigen::Vector3d n;
    double d;
    std::size_t count;
  };
  std::vector<Candidate> candidates;
  std::size_t most = 0;
  for (int trial = 0; trial < kTrials; ++trial) {
    const Eigen::Vector3d& a = low[next_random(state) % low.size()];
    const Eigen::Vector3d& b = low[next_random(state) % low.size()];
    const Eigen::Vector3d& c = low[next_random(state) % low.size()];
    Eigen::Vector3d n = (b - a).cross(c - a);
    if (n.norm() < 1e-6) continue;
    n.normalize();
    if (n.z() < 0) n = -n;
    if (n.z() < min_up) continue;
    const double d = n.dot(a);
    std::size_t count = 0;
    for (const Eigen::Vector3d& p : low) count += std::fabs(n.dot(p) - d) < kInlierDistance;
    candidates.push_back({n, d, count});
    most = std::max(most, count);
  }
  // The floor is the lowest well-supported horizontal plane: a table top or a bed seen from
  // close may hold more points, but not less than half as many as the floor when both are seen.
  // Heights are compared below the points' centroid (the origin may be far away, where a small
  // tilt moves a plane a lot).
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3d& p : low) mean += p;
  mean /= static_cast<double>(low.size());
  auto height_at_mean = [&](const Candidate& c) {
    return (c.d - c.n.x() * mean.x() - c.n.y() * mean.y()) / c.n.z();
  };
  std::size_t best = 0;
  Eigen::Vector3d best_n = Eigen::Vector3d::UnitZ();
  double best_d = 0.0, best_height = 0.0;
  for (const Candidate& c : candidates) {
    if (c.count < most / 2) continue;
    const double height = height_at_mean(c);
    if (best == 0 || height < best_height - kInlierDistance ||
        (std::fabs(height - best_height) <= kInlierDistance && c.count > best)) {
      best = c.count;
      best_n = c.n;
      best_d = c.d;
      best_height = height;
    }
  }
  if (best < min_inliers) return false;
  // Least-squares refinement: the plane through the inliers' centroid along their smallest
  // principal direction.
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  std::vector<const Eigen::Vector3d*> in;
  for (const Eigen::Vector3d& p : low) {
    if (std::fabs(best_n.dot(p) - best_d) < kInlierDistance) {
      in.push_back(&p);
      centroid += p;
    }
  }
  centroid /= static_cast<double>(in.size());
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (const Eigen::Vector3d* p : in) cov += (*p - centroid) * (*p - centroid).transpose();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(cov);
  Eigen::Vector3d n = eig.eigenvectors().col(0);
  if (n.z() < 0) n = -n;
  *normal = n.normalized();
  *offset = normal->dot(centroid);
  *inliers = in.size();
  return true;
}

Sequence read_sequence(const std::string& dir, const SequenceReadOptions& options) {
  if (is_ros2_bag(dir)) return read_ros2_bag(dir, options);
  Sequence seq;
  seq.dir = dir;
  const bool bonn = options.poses == PoseConvention::kBonn;
  seq.camera = read_camera_file(join_path(dir, "camera.txt"), &seq.has_camera_file, &seq.warnings);
  if (bonn && !seq.has_camera_file) seq.camera = bonn_camera();
  const std::string depth_list = join_path(dir, "depth.txt");
  std::string gt_path = join_path(dir, "groundtruth.txt");
  if (bonn && file_exists(join_path(dir, "groundtruth_bonn.txt"))) {
    gt_path = join_path(dir, "groundtruth_bonn.txt");
  }
  if (!file_exists(depth_list))
    throw ToolError(depth_list + ": missing (not a sequence directory?)");
  if (!file_exists(gt_path)) throw ToolError(gt_path + ": missing (camera poses are required)");
  seq.poses = read_groundtruth(gt_path);
  seq.pose_file = gt_path;
  if (bonn) {
    for (auto& p : seq.poses) p.pose = bonn_marker_to_optical(p.pose);
    seq.camera.world_z_up = 1;
  }
  finish_sequence(seq, read_depth_list(dir, depth_list, &seq.images_listed), options, depth_list);
  return seq;
}

void finish_sequence(Sequence& seq, std::vector<SequenceFrame> candidates,
                     const SequenceReadOptions& options, const std::string& what) {
  if (seq.camera.world_z_up == 0 && options.align_gravity && !seq.poses.empty()) {
    const Eigen::Vector3d down = seq.poses.front().pose.rotation * Eigen::Vector3d::UnitY();
    seq.world_alignment = Eigen::Quaterniond::FromTwoVectors(down, -Eigen::Vector3d::UnitZ());
    seq.gravity_aligned = true;
    for (auto& p : seq.poses) {
      p.pose.translation = seq.world_alignment * p.pose.translation;
      p.pose.rotation = (seq.world_alignment * p.pose.rotation).normalized();
    }
  }
  for (SequenceFrame& frame : candidates) {
    if (!interpolate_pose(seq.poses, frame.stamp, options.max_pose_gap, &frame.pose)) {
      ++seq.images_without_pose;
      continue;
    }
    seq.frames.push_back(std::move(frame));
  }
  // Stamps in [0, kMaxStampSeconds] convert as they are; others relative to the first one.
  if (!candidates.empty() &&
      (candidates.front().stamp < 0.0 || candidates.back().stamp > kMaxStampSeconds)) {
    seq.stamp_origin = std::floor(candidates.front().stamp);
  }
  // Distinct stamps must stay distinct (and in order) in whole nanoseconds.
  for (std::size_t k = 1; k < seq.frames.size(); ++k) {
    if (seq.stamp_ns(seq.frames[k].stamp) <= seq.stamp_ns(seq.frames[k - 1].stamp)) {
      throw ToolError(what + ": time stamps " + seq.frames[k - 1].stamp_text + " and " +
                      seq.frames[k].stamp_text + " are less than 1 ns apart");
    }
  }
  if (seq.gravity_aligned && options.level_floor) level_on_floor(seq);
}

std::uint64_t Sequence::stamp_ns(double seconds) const {
  const double ns = std::round((seconds - stamp_origin) * 1e9);
  // read_sequence() keeps every stamp of the sequence in [0, kMaxStampSeconds] of the origin.
  if (!(ns >= 0.0 && ns <= (kMaxStampSeconds + 1.0) * 1e9)) {
    throw ToolError(dir + ": time stamp " + std::to_string(seconds) +
                    " s is outside the replay's nanosecond clock");
  }
  return static_cast<std::uint64_t>(ns);
}

Image16 load_depth(const Sequence& seq, const SequenceFrame& frame) {
  if (seq.source) {
    Image16 img;
    std::string message;
    if (seq.source->load(seq, frame, &img, &message) != DepthProblem::kNone) {
      throw ToolError(message);
    }
    return img;
  }
  Image16 img = read_png16(frame.depth_path);
  if (img.width != seq.camera.width || img.height != seq.camera.height) {
    throw ToolError(frame.depth_path + ": image is " + std::to_string(img.width) + "x" +
                    std::to_string(img.height) + " but camera.txt says " +
                    std::to_string(seq.camera.width) + "x" + std::to_string(seq.camera.height));
  }
  return img;
}

const char* to_string(DepthProblem problem) {
  switch (problem) {
    case DepthProblem::kNone:
      return "ok";
    case DepthProblem::kMissing:
      return "missing";
    case DepthProblem::kUnreadable:
      return "unreadable";
    case DepthProblem::kWrongSize:
      return "wrong size";
  }
  return "?";
}

DepthProblem try_load_depth(const Sequence& seq, const SequenceFrame& frame, Image16* out,
                            std::string* message) {
  if (seq.source) return seq.source->load(seq, frame, out, message);
  if (!file_exists(frame.depth_path)) {
    *message = frame.depth_path + ": listed in depth.txt but missing";
    return DepthProblem::kMissing;
  }
  try {
    *out = read_png16(frame.depth_path);
  } catch (const ToolError& e) {
    *message = e.what();
    return DepthProblem::kUnreadable;
  }
  if (out->width != seq.camera.width || out->height != seq.camera.height) {
    *message = frame.depth_path + ": image is " + std::to_string(out->width) + "x" +
               std::to_string(out->height) + " but camera.txt says " +
               std::to_string(seq.camera.width) + "x" + std::to_string(seq.camera.height);
    return DepthProblem::kWrongSize;
  }
  return DepthProblem::kNone;
}

}  // namespace dynamap::tools
