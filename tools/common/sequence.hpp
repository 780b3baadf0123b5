// Reader of a sequence directory in the TUM RGB-D layout of docs/data_format.md: depth.txt,
// groundtruth.txt (poses interpolated to the depth time stamps), optional camera.txt.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "common/png_io.hpp"

namespace dynamap::tools {

/// camera.txt contents; defaults are the TUM fr3 values (used for any key that is absent).
struct CameraModel {
  double fx = 535.4, fy = 539.2, cx = 320.1, cy = 247.6;
  int width = 640, height = 480;
  double depth_factor = 5000.0;  ///< depth units per metre
  int world_z_up = 0;            ///< TUM recordings: 0 (unknown); simulated data writes 1
};

/// Camera pose T_world_camera (optical frame), double precision.
struct PoseD {
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();
  Eigen::Quaterniond rotation = Eigen::Quaterniond::Identity();
};

/// One timestamped pose from groundtruth.txt.
struct StampedPose {
  double stamp = 0.0;
  PoseD pose;
};

/// One depth image that has a pose.
struct SequenceFrame {
  double stamp = 0.0;
  std::string stamp_text;  ///< exactly as in depth.txt, for output with the same precision
  std::string depth_path;  ///< SEQ joined with the file name of depth.txt (a bag: bag, topic, time)
  std::size_t source_index = 0;  ///< a bag's frames: the image message (Sequence::source)
  PoseD pose;                    ///< interpolated, in the (possibly gravity-aligned) world frame
};

/// How the camera poses of a sequence are written.
enum class PoseConvention {
  kTum,   ///< groundtruth.txt: the optical frame (x right, y down, z forward) in the world (TUM)
  kBonn,  ///< Bonn RGB-D Dynamic as published: the motion-capture marker frame, y-up world
};

/// How a ROS 2 bag is read as a sequence (docs/tools.md, "ROS 2 bags"): topics by flag or found
/// by type; empty / negative values mean "from the bag" (dynamap-convert's metadata record or the
/// messages themselves).
struct BagReadOptions {
  std::string depth_topic;    ///< sensor_msgs/msg/Image, 16UC1 (units of 1/depth_factor m) or 32FC1
  std::string info_topic;     ///< sensor_msgs/msg/CameraInfo
  std::string pose_topic;     ///< PoseStamped, Odometry or TFMessage (/tf)
  std::string camera_frame;   ///< the optical frame; default: the depth images' header.frame_id
  std::string pose_child;     ///< the frame a PoseStamped gives the pose of; default: camera_frame
  std::string world_frame;    ///< with /tf poses: default the root of the camera frame's tree
  double depth_factor = 0.0;  ///< 16UC1 units per metre; 0: the bag's metadata, else 1000 (mm)
  int world_z_up = -1;        ///< -1: the bag's metadata, else 0 (levelled on the floor)
  /// Keep the pose messages' quaternions as written (not normalised): dynamap-convert writes
  /// them back to groundtruth.txt unchanged.
  bool raw_poses = false;
};

struct DepthSourceBase;

struct SequenceReadOptions {
  /// Largest gap (s) between an image and the nearest pose on each side (docs/data_format.md:
  /// 0.05).
  double max_pose_gap = 0.05;
  /// kBonn reads groundtruth_bonn.txt (or, when absent, groundtruth.txt as the dataset publishes
  /// it) and converts every pose with bonn_marker_to_optical(); the world is then z up, so
  /// camera.world_z_up is set to 1, and a missing camera.txt means the Bonn camera's intrinsics.
  PoseConvention poses = PoseConvention::kTum;
  /// A ROS 2 bag (a folder with metadata.yaml or *.mcap files, or one .mcap file) is read with
  /// these; read_sequence() recognises it by its path.
  BagReadOptions bag;
  /// With world_z_up 0: rotate the world so that the first camera's "down" (+y of the optical
  /// frame) becomes -z. See Sequence::gravity_aligned.
  bool align_gravity = true;
  /// After align_gravity: find the floor plane in the first frames' depth and level the world
  /// on it (floor normal = +z, floor at z = 0). See Sequence::floor_levelled.
  bool level_floor = true;
};

/// A read sequence: camera model and the frames that have a pose, in time order.
struct Sequence {
  std::string dir;
  CameraModel camera;
  bool has_camera_file = false;
  std::vector<SequenceFrame> frames;
  std::size_t images_listed = 0;        ///< lines in depth.txt
  std::size_t images_without_pose = 0;  ///< skipped: no pose within max_pose_gap on both sides
  std::vector<StampedPose> poses;       ///< groundtruth.txt, sorted, in the output world frame
  std::string pose_file;                ///< the file the poses came from
  /// When camera.txt says world_z_up 0 and align_gravity is on, every pose (translations and
  /// rotations) was moved by x -> world_alignment * x + world_offset: first the smallest
  /// rotation taking the first pose's camera +y axis (image down) to world -z, then, when the
  /// floor was found (floor_levelled), the tilt from the floor's normal to +z and the shift that
  /// puts the floor at z = 0. Identity and zero otherwise.
  Eigen::Quaterniond world_alignment = Eigen::Quaterniond::Identity();
  Eigen::Vector3d world_offset = Eigen::Vector3d::Zero();
  bool gravity_aligned = false;
  /// After the gravity alignment, the floor plane found in the first frames' depth was made the
  /// plane z = 0 with +z its normal: every pose was rotated by the small tilt between the
  /// camera-down guess and the floor normal and moved so the floor is at z = 0. With
  /// `floor_levelled`, a world_z_up 0 sequence is in a z-up world with the floor at 0, like
  /// simulated data, and every tool that reads it with the default options computes the same
  /// world (their outputs share it). `floor_points` is the plane fit's inlier count.
  bool floor_levelled = false;
  std::size_t floor_points = 0;
  std::vector<std::string> warnings;  ///< e.g. unknown camera.txt keys (ignored)
  /// Where the depth images come from when they are not PNG files (a ROS 2 bag); null for a
  /// folder. try_load_depth() and load_depth() go through it.
  std::shared_ptr<DepthSourceBase> source;
  /// Seconds subtracted from depth.txt stamps before they become the pipeline's nanoseconds
  /// (stamp_ns): 0 when every stamp lies in [0, kMaxStampSeconds] (the stamps convert as they
  /// are), else the first stamp rounded down to a whole second. read_sequence() refuses a
  /// sequence whose stamps span more than kMaxStampSeconds or come closer than 1 ns.
  double stamp_origin = 0.0;
  /// A depth.txt stamp as the pipeline's nanosecond stamp (only differences matter to it).
  std::uint64_t stamp_ns(double seconds) const;
};

/// Longest span of depth.txt stamps the replay's unsigned nanosecond clock holds with margin
/// (2^63 ns is 9.22e9 s).
inline constexpr double kMaxStampSeconds = 9.2e9;

/// Reads camera.txt; a missing file gives the defaults. Throws ToolError naming file:line.
CameraModel read_camera_file(const std::string& path, bool* present,
                             std::vector<std::string>* warnings);

/// Writes camera.txt with every key.
void write_camera_file(const std::string& path, const CameraModel& camera);

/// Reads groundtruth.txt (timestamp tx ty tz qx qy qz qw [extra columns ignored]); sorted by
/// time. Quaternions are normalised; a (near-)zero or non-finite one is an error.
std::vector<StampedPose> read_groundtruth(const std::string& path);

/// Pose at time t: linear translation + slerp between the two nearest poses; false when there is
/// no pose within max_gap on both sides (an exact time match needs only that one pose).
bool interpolate_pose(const std::vector<StampedPose>& poses, double t, double max_gap, PoseD* out);

/// The Bonn RGB-D Dynamic dataset's published pose (marker frame, y-up world) as a TUM pose of
/// the optical frame in a z-up world: T = Rx(+90 deg) * T_ros * T_gt * T_ros * T_m, with the
/// dataset's T_ros and marker-to-camera T_m (whose 3x3 block, scaled by about 1.06, is replaced by
/// its nearest rotation). docs/tools.md, "Real sequences".
PoseD bonn_marker_to_optical(const PoseD& marker_pose);

/// The Bonn RGB-D Dynamic dataset's depth camera (used when a Bonn sequence has no camera.txt).
CameraModel bonn_camera();

/// Reads SEQ/depth.txt, SEQ/groundtruth.txt and SEQ/camera.txt (optional). Throws ToolError
/// with "file:line: what" for malformed lines and missing files.
Sequence read_sequence(const std::string& dir, const SequenceReadOptions& options = {});

/// The floor plane in a set of world points (z roughly up): normal (unit, +z side) and offset d
/// of n.p = d, fitted by a deterministic RANSAC among points below `max_height` whose normal is
/// within 30 degrees of +z, refined by least squares on its 3 cm inliers. False when fewer
/// than `min_inliers` points support a plane.
bool fit_floor_plane(const std::vector<Eigen::Vector3d>& points, double max_height,
                     std::size_t min_inliers, Eigen::Vector3d* normal, double* offset,
                     std::size_t* inliers);

/// Loads the depth image of a frame, checking its size against the camera model. Throws
/// ToolError naming the file.
Image16 load_depth(const Sequence& seq, const SequenceFrame& frame);

/// Why a listed depth image could not be used (published datasets have such gaps).
enum class DepthProblem { kNone, kMissing, kUnreadable, kWrongSize };
const char* to_string(DepthProblem problem);

/// A source of depth images other than PNG files (ROS 2 bags: common/ros2_bag.hpp).
struct DepthSourceBase {
  virtual ~DepthSourceBase() = default;
  virtual DepthProblem load(const Sequence& seq, const SequenceFrame& frame, Image16* out,
                            std::string* message) = 0;
};

/// The shared second half of reading a sequence (folder or bag): with seq.poses and seq.camera
/// set, aligns the world (world_z_up 0), interpolates a pose for each candidate frame (those
/// without one are counted in images_without_pose), sets stamp_origin and checks the
/// nanosecond stamps (`what` names the source in errors), and levels the world on its floor.
void finish_sequence(Sequence& seq, std::vector<SequenceFrame> candidates,
                     const SequenceReadOptions& options, const std::string& what);

/// load_depth() without the throw: kNone and the image in `out`, or the problem and a message
/// naming the file in `message` (`out` is then unspecified). Missing: the file does not exist;
/// unreadable: not a complete 16-bit single-channel PNG (truncated, 8-bit, RGB, ...); wrong size:
/// not camera.txt's width x height.
DepthProblem try_load_depth(const Sequence& seq, const SequenceFrame& frame, Image16* out,
                            std::string* message);

}  // namespace dynamap::tools
