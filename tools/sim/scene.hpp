// Scene model of the simulator: static world (floor, walls, boxes, pillars, people who only
// stand), walking people on smoothed waypoint loops, and the camera's motion.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "common/sequence.hpp"
#include "common/static_world.hpp"

namespace dynamap::tools::sim {

/// Polyline with its cumulative arc length; the shape walkers and the camera follow.
struct DensePath {
  std::vector<Eigen::Vector2d> points;
  std::vector<double> s;  ///< arc length at each point
  double length() const { return s.empty() ? 0.0 : s.back(); }
  Eigen::Vector2d at(double arc) const;  ///< clamped to [0, length]
};

/// Rounds every corner of a polyline with a quadratic Bezier (corner cut <= `cut` m on each
/// side). Closed paths round the wrap-around corner too. `corner_arc` receives the arc length of
/// each waypoint's rounded corner midpoint (the point a pause happens at).
DensePath smooth_path(const std::vector<Eigen::Vector2d>& waypoints, bool closed, double cut,
                      std::vector<double>* corner_arc = nullptr);

/// A waypoint of a walking person; `pause` seconds standing at this corner.
struct Waypoint {
  Eigen::Vector2d p = Eigen::Vector2d::Zero();
  double pause = 0.0;
};

/// A person walking a closed loop of waypoints (corners rounded) at `speed`, accelerating at
/// 1 m/s^2 into and out of pauses and turn backs (corners turning it by more than 115 deg). Shape:
/// upright cylinder (radius, height) standing on the floor. People walking side by side share one
/// loop (the group's centre line) and keep a lateral place in it; the group turns at the pace of
/// its outer member, so nobody walks faster than `speed`.
struct WalkerSpec {
  std::vector<Waypoint> waypoints;
  double speed = 1.0;  ///< cruise speed, 0.5-1.5 m/s
  double radius = 0.25;
  double height = 1.7;
  double time_offset = 0.0;  ///< seconds into its loop at t = 0
  double corner_cut = 0.7;   ///< m cut off each side of a corner by its rounding
  double lateral = 0.0;      ///< m to the left of the loop's centre line (place in a group)
  double half_width = 0.0;   ///< m, largest |lateral| of the group: paces its turns
  int lane = 0;   ///< > 0: walkers sharing a lane share the seed's speed jitter (no catching up)
  int group = 0;  ///< > 0: members of a group also share the start-time jitter (keep formation)
};

/// Precomputed motion of one walker.
class WalkerMotion {
 public:
  explicit WalkerMotion(const WalkerSpec& spec);
  Eigen::Vector2d position(double t) const;
  Eigen::Vector2d velocity(double t) const;  ///< central difference of position()
  const DensePath& path() const { return path_; }
  const WalkerSpec& spec() const { return spec_; }
  double period() const { return period_; }  ///< seconds per loop, pauses included

 private:
  struct Leg {
    double s0 = 0, length = 0, duration = 0, pause = 0;
  };
  double leg_distance(const Leg& leg, double tau) const;  // distance covered after tau seconds
  Eigen::Vector2d point(double pace) const;  // where the walker is at `pace` along its loop
  WalkerSpec spec_;
  DensePath path_;
  // Groups: pace (the outer member's distance) at each path point; empty = pace is arc length.
  std::vector<double> pace_;
  std::vector<Eigen::Vector2d> normals_;  // left normal at each path point (groups only)
  double loop_pace_ = 0.0;
  std::vector<Leg> legs_;
  bool endless_ = false;  // no pause and no turn back: one leg at cruise speed
  double period_ = 0.0;
};

/// How the camera moves: hovering in place with a slow yaw sweep, carried along a path, or
/// flying along a path like a multirotor (`fly`: speed profile, sway, tilt into accelerations).
struct CameraSpec {
  bool hover = true;
  bool fly = false;                        ///< flying along `path` (with hover = false)
  Eigen::Vector3d position = {0, 0, 1.3};  ///< hover position (path: z is the height)
  double yaw = 0.0;                        ///< hover heading (rad, 0 = +x)
  double yaw_sweep = 0.0;                  ///< hover: amplitude of a sine yaw sweep (rad)
  double sweep_period = 10.0;              ///< hover: period of the sweep (s)
  std::vector<Eigen::Vector2d> path;       ///< carried: waypoints, corners rounded
  double speed = 0.5;                      ///< carried: walking speed (m/s); stops at the end
  double pitch = 0.12;                     ///< downward tilt of the optical axis (rad)
  double bob = 0.015;                      ///< carried: vertical bob amplitude (m)
  /// fly: (time s, speed m/s) knots, linear in between, the last speed held; the camera slows
  /// at 0.5 m/s^2 to stop at the end of the path.
  std::vector<Eigen::Vector2d> speed_profile;
};

/// A complete built-in scene.
struct Scene {
  std::string name;
  std::string description;
  StaticWorld world;
  std::vector<WalkerSpec> walkers;
  CameraSpec camera;
  int default_frames = 300;
  double fps = 30.0;
};

/// Camera pose T_world_camera (optical frame: x right, y down, z forward) at time t.
class CameraMotion {
 public:
  explicit CameraMotion(const CameraSpec& spec);
  PoseD pose(double t) const;
  Eigen::Vector2d position_xy(double t) const;
  double yaw(double t) const;
  double speed(double t) const;  ///< fly: speed along the path (m/s)

 private:
  double flown(double t) const;  // fly: arc length at time t
  PoseD fly_pose(double t) const;
  CameraSpec spec_;
  DensePath path_;
  std::vector<double> flown_;  // fly: arc length every kFlyStep seconds
};

/// Optical-frame rotation for a camera looking along yaw (about +z) tilted down by pitch.
Eigen::Quaterniond camera_rotation(double yaw, double pitch);

/// The simulated D435i-like depth camera (see docs/tools.md).
CameraModel sim_camera_model();

/// Names of the built-in scenes, in order.
std::vector<std::string> scene_names();

/// Builds a built-in scene; `seed` jitters walker speeds (+-8 %, kept in 0.5-1.5 m/s; one draw
/// per lane), sizes and start times (one draw per group) a little. Throws ToolError for an unknown
/// name.
Scene make_scene(const std::string& name, std::uint64_t seed);

/// Deterministic random numbers (splitmix64): same seed, same sequence on every platform.
class SplitMix64 {
 public:
  explicit SplitMix64(std::uint64_t seed) : state_(seed) {}
  std::uint64_t next();
  double uniform(double lo, double hi);  ///< [lo, hi)

 private:
  std::uint64_t state_;
};

/// Stateless hash of (a, b, c) -> 64 bits, for per-pixel noise independent of render order.
std::uint64_t hash3(std::uint64_t a, std::uint64_t b, std::uint64_t c);

}  // namespace dynamap::tools::sim
