#include "sim/scene.hpp"

#include <algorithm>
#include <cmath>

#include <Eigen/Geometry>

namespace dynamap::tools::sim {

Eigen::Vector2d DensePath::at(double arc) const {
  if (points.empty()) return Eigen::Vector2d::Zero();
  if (arc <= 0.0) return points.front();
  if (arc >= length()) return points.back();
  const auto it = std::upper_bound(s.begin(), s.end(), arc);
  const std::size_t i = static_cast<std::size_t>(it - s.begin());  // s[i-1] <= arc < s[i]
  const double seg = s[i] - s[i - 1];
  const double a = seg > 0 ? (arc - s[i - 1]) / seg : 0.0;
  return (1.0 - a) * points[i - 1] + a * points[i];
}

namespace {

void append(DensePath* path, const Eigen::Vector2d& p) {
  if (path->points.empty()) {
    path->points.push_back(p);
    path->s.push_back(0.0);
    return;
  }
  const double d = (p - path->points.back()).norm();
  if (d < 1e-9) return;
  path->points.push_back(p);
  path->s.push_back(path->s.back() + d);
}

void append_line(DensePath* path, const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  const int n = std::max(1, static_cast<int>(std::ceil((b - a).norm() / 0.05)));
  for (int i = 0; i <= n; ++i) append(path, a + (b - a) * (static_cast<double>(i) / n));
}

}  // namespace

DensePath smooth_path(const std::vector<Eigen::Vector2d>& w, bool closed, double cut,
                      std::vector<double>* corner_arc) {
  DensePath path;
  const std::size_t n = w.size();
  if (corner_arc != nullptr) corner_arc->assign(n, 0.0);
  if (n == 0) return path;
  if (n == 1) {
    append(&path, w[0]);
    return path;
  }
  // Corner i is replaced by a Bezier from a[i] (before) to b[i] (after) with control w[i].
  std::vector<Eigen::Vector2d> a(n), b(n);
  std::vector<bool> rounded(n, false);
  for (std::size_t i = 0; i < n; ++i) {
    a[i] = b[i] = w[i];
    const bool has_neighbours = closed || (i > 0 && i + 1 < n);
    if (!has_neighbours) continue;
    const Eigen::Vector2d prev = w[(i + n - 1) % n], next = w[(i + 1) % n];
    const double lp = (prev - w[i]).norm(), ln = (next - w[i]).norm();
    if (lp < 1e-9 || ln < 1e-9) continue;
    const double d = std::min({cut, 0.45 * lp, 0.45 * ln});
    a[i] = w[i] + d * (prev - w[i]) / lp;
    b[i] = w[i] + d * (next - w[i]) / ln;
    rounded[i] = true;
  }
  const std::size_t corners = closed ? n + 1 : n;  // closed: end where we started
  for (std::size_t k = 0; k < corners; ++k) {
    const std::size_t i = k % n;
    if (k > 0) append_line(&path, b[(k - 1) % n], a[i]);
    if (rounded[i]) {
      // A closed path starts and ends at the middle of corner 0, so it joins up exactly.
      const int steps = 24;
      const int j_begin = (closed && k == 0) ? steps / 2 : 0;
      const int j_end = (closed && k == n) ? steps / 2 : steps;
      for (int j = j_begin; j <= j_end; ++j) {
        const double t = static_cast<double>(j) / steps;
        const Eigen::Vector2d p = (1 - t) * (1 - t) * a[i] + 2 * (1 - t) * t * w[i] + t * t * b[i];
        append(&path, p);
        if (j == steps / 2 && corner_arc != nullptr && k < n) (*corner_arc)[i] = path.s.back();
      }
    } else {
      append(&path, w[i]);
      if (corner_arc != nullptr && k < n) (*corner_arc)[i] = path.s.back();
    }
  }
  return path;
}

namespace {
constexpr double kWalkerAccel = 1.0;  // m/s^2 into and out of pauses
// A corner turning the heading by more than this is a turn back: the walker slows to a stop and
// walks off again (at kWalkerAccel) instead of reversing at cruise speed within a frame, which
// no person does (1.2 m/s reversed in 1/30 s is 72 m/s^2).
constexpr double kTurnBackHeading = 2.0;  // rad (115 deg)

// True at each waypoint of a closed loop whose heading change exceeds kTurnBackHeading,
// measured between the nearest waypoints at least kTurnBackReach away on either side (two
// waypoints a few centimetres apart turn back between them).
constexpr double kTurnBackReach = 0.5;  // m
std::vector<bool> turn_backs(const std::vector<Waypoint>& w) {
  const std::size_t n = w.size();
  std::vector<bool> out(n, false);
  if (n < 2) return out;
  const auto reach = [&](std::size_t i, std::size_t step) {
    std::size_t j = i;
    for (std::size_t k = 1; k < n; ++k) {
      j = (j + step) % n;
      if ((w[j].p - w[i].p).norm() >= kTurnBackReach) return j;
    }
    return i;
  };
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector2d in = w[i].p - w[reach(i, n - 1)].p, on = w[reach(i, 1)].p - w[i].p;
    if (in.norm() < 1e-9 || on.norm() < 1e-9) continue;
    const double c = std::clamp(in.normalized().dot(on.normalized()), -1.0, 1.0);
    out[i] = std::acos(c) > kTurnBackHeading;
  }
  return out;
}
}  // namespace

namespace {

// Left normal at each point of a closed dense path: the bisector of the two segments meeting
// there, so a lateral offset turns as smoothly as the path.
std::vector<Eigen::Vector2d> vertex_normals(const DensePath& path) {
  const auto& p = path.points;
  const std::size_t n = p.size();
  std::vector<Eigen::Vector2d> normals(n, Eigen::Vector2d(0, 1));
  if (n < 3) return normals;
  for (std::size_t i = 0; i < n; ++i) {
    // The first and last points coincide (closed loop): their neighbours wrap around.
    const Eigen::Vector2d prev = i > 0 ? p[i - 1] : p[n - 2];
    const Eigen::Vector2d next = i + 1 < n ? p[i + 1] : p[1];
    const Eigen::Vector2d t = (p[i] - prev).normalized() + (next - p[i]).normalized();
    if (t.norm() > 1e-9) normals[i] = Eigen::Vector2d(-t.y(), t.x()).normalized();
  }
  return normals;
}

// Pace along a closed dense path for a group of half width w: arc length plus w times the
// heading change, i.e. the distance the outer member walks. Timing the walk by pace keeps
// every member at or below the cruise speed in turns.
std::vector<double> group_pace(const DensePath& path, const std::vector<Eigen::Vector2d>& normals,
                               double w) {
  std::vector<double> pace(path.points.size(), 0.0);
  for (std::size_t i = 1; i < pace.size(); ++i) {
    const double turn = std::acos(std::clamp(normals[i - 1].dot(normals[i]), -1.0, 1.0));
    pace[i] = pace[i - 1] + (path.s[i] - path.s[i - 1]) + w * turn;
  }
  return pace;
}

}  // namespace

WalkerMotion::WalkerMotion(const WalkerSpec& spec) : spec_(spec) {
  std::vector<Eigen::Vector2d> pts;
  for (const auto& w : spec.waypoints) pts.push_back(w.p);
  std::vector<double> corner_s;
  path_ = smooth_path(pts, true, spec.corner_cut, &corner_s);
  double L = path_.length();
  const double w = std::max(spec.half_width, std::fabs(spec.lateral));
  if (w > 0.0 && path_.points.size() >= 3) {
    normals_ = vertex_normals(path_);
    pace_ = group_pace(path_, normals_, w);
    for (auto& c : corner_s) {
      // Corners (pause points) are path points: convert their arc length to pace.
      const auto it = std::lower_bound(path_.s.begin(), path_.s.end(), c - 1e-9);
      c = pace_[static_cast<std::size_t>(it - path_.s.begin())];
    }
    L = pace_.back();
  }
  loop_pace_ = L;
  // Legs run between pause points and turn backs (a stop without a pause); without either the
  // whole loop is one leg at cruise speed.
  const std::vector<bool> turns_back = turn_backs(spec.waypoints);
  std::vector<std::size_t> pauses;
  for (std::size_t i = 0; i < spec.waypoints.size(); ++i) {
    if (spec.waypoints[i].pause > 0.0 || turns_back[i]) pauses.push_back(i);
  }
  endless_ = pauses.empty();
  if (endless_) {
    legs_.push_back(Leg{0.0, L, L / spec.speed, 0.0});
  } else {
    for (std::size_t k = 0; k < pauses.size(); ++k) {
      const double s0 = corner_s[pauses[k]];
      double s1 = corner_s[pauses[(k + 1) % pauses.size()]];
      if (s1 <= s0) s1 += L;
      Leg leg{s0, s1 - s0, 0.0, spec.waypoints[pauses[k]].pause};
      const double v = spec.speed, d_acc = v * v / (2 * kWalkerAccel);
      leg.duration = leg.length >= 2 * d_acc ? 2 * v / kWalkerAccel + (leg.length - 2 * d_acc) / v
                                             : 2 * std::sqrt(leg.length / kWalkerAccel);
      legs_.push_back(leg);
    }
  }
  for (const auto& leg : legs_) period_ += leg.pause + leg.duration;
}

double WalkerMotion::leg_distance(const Leg& leg, double tau) const {
  if (endless_) return spec_.speed * tau;  // a loop without stops
  const double a = kWalkerAccel;
  const double v = std::min(spec_.speed, std::sqrt(leg.length * a));
  const double t_acc = v / a;
  const double d_acc = 0.5 * v * t_acc;
  if (tau <= t_acc) return 0.5 * a * tau * tau;
  const double t_cruise = leg.duration - 2 * t_acc;
  if (tau <= t_acc + t_cruise) return d_acc + v * (tau - t_acc);
  const double r = std::max(0.0, leg.duration - tau);
  return leg.length - 0.5 * a * r * r;
}

Eigen::Vector2d WalkerMotion::point(double pace) const {
  if (pace_.empty()) return path_.at(pace);
  const auto& p = path_.points;
  const auto it = std::upper_bound(pace_.begin(), pace_.end(), pace);
  if (it == pace_.begin()) return p.front() + spec_.lateral * normals_.front();
  if (it == pace_.end()) return p.back() + spec_.lateral * normals_.back();
  const std::size_t i = static_cast<std::size_t>(it - pace_.begin());  // pace_[i-1] <= pace
  const double seg = pace_[i] - pace_[i - 1];
  const double a = seg > 0 ? (pace - pace_[i - 1]) / seg : 0.0;
  const Eigen::Vector2d n = ((1.0 - a) * normals_[i - 1] + a * normals_[i]).normalized();
  return (1.0 - a) * p[i - 1] + a * p[i] + spec_.lateral * n;
}

Eigen::Vector2d WalkerMotion::position(double t) const {
  const double L = loop_pace_;
  if (L <= 0.0 || period_ <= 0.0) return point(0.0);
  double tau = std::fmod(t + spec_.time_offset, period_);
  if (tau < 0) tau += period_;
  for (const auto& leg : legs_) {
    // Each leg starts with the pause at its first corner, then walks to the next pause point.
    if (tau < leg.pause) return point(std::fmod(leg.s0, L));
    tau -= leg.pause;
    if (tau < leg.duration || &leg == &legs_.back()) {
      return point(std::fmod(leg.s0 + leg_distance(leg, std::min(tau, leg.duration)), L));
    }
    tau -= leg.duration;
  }
  return point(0.0);
}

Eigen::Vector2d WalkerMotion::velocity(double t) const {
  const double h = 1e-3;
  return (position(t + h) - position(t - h)) / (2 * h);
}

Eigen::Quaterniond camera_rotation(double yaw, double pitch) {
  const Eigen::Vector3d f(std::cos(yaw) * std::cos(pitch), std::sin(yaw) * std::cos(pitch),
                          -std::sin(pitch));
  const Eigen::Vector3d right = f.cross(Eigen::Vector3d::UnitZ()).normalized();
  const Eigen::Vector3d down = f.cross(right);
  Eigen::Matrix3d R;
  R.col(0) = right;
  R.col(1) = down;
  R.col(2) = f;
  return Eigen::Quaterniond(R).normalized();
}

namespace {

constexpr double kFlyStep = 1.0 / 300.0;  // s, integration step of the flight's arc length
constexpr double kFlyBrake = 0.5;         // m/s^2, deceleration to stop at the path's end

// Speed of a flight's profile at time t: linear between knots, the last knot's speed held.
double profile_speed(const std::vector<Eigen::Vector2d>& knots, double t) {
  if (knots.empty()) return 0.0;
  if (t <= knots.front().x()) return knots.front().y();
  for (std::size_t k = 1; k < knots.size(); ++k) {
    if (t < knots[k].x()) {
      const double a = (t - knots[k - 1].x()) / (knots[k].x() - knots[k - 1].x());
      return (1.0 - a) * knots[k - 1].y() + a * knots[k].y();
    }
  }
  return knots.back().y();
}

// Arc length flown every kFlyStep seconds until the camera stops at the end of the path.
std::vector<double> flight_table(const std::vector<Eigen::Vector2d>& knots, double length) {
  std::vector<double> s{0.0};
  while (length - s.back() > 1e-4 && s.size() < 2000000) {
    const double t = kFlyStep * static_cast<double>(s.size() - 1);
    const double v =
        std::min(profile_speed(knots, t), std::sqrt(2.0 * kFlyBrake * (length - s.back())) + 0.01);
    s.push_back(std::min(length, s.back() + v * kFlyStep));
  }
  return s;
}

}  // namespace

CameraMotion::CameraMotion(const CameraSpec& spec) : spec_(spec) {
  if (!spec.hover) path_ = smooth_path(spec.path, false, 1.0);
  if (!spec.hover && spec.fly) flown_ = flight_table(spec.speed_profile, path_.length());
}

double CameraMotion::flown(double t) const {
  if (flown_.empty()) return 0.0;
  const double x = std::max(0.0, t) / kFlyStep;
  const auto k = static_cast<std::size_t>(x);
  if (k + 1 >= flown_.size()) return flown_.back();
  const double a = x - static_cast<double>(k);
  return (1.0 - a) * flown_[k] + a * flown_[k + 1];
}

double CameraMotion::speed(double t) const {
  const double h = 0.01, t0 = std::max(0.0, t - h);
  return (flown(t + h) - flown(t0)) / (t + h - t0);
}

Eigen::Vector2d CameraMotion::position_xy(double t) const {
  if (spec_.hover) {
    return spec_.position.head<2>() +
           Eigen::Vector2d(0.02 * std::sin(0.7 * t), 0.02 * std::sin(1.1 * t + 0.5));
  }
  if (spec_.fly) return path_.at(flown(t));
  return path_.at(spec_.speed * t);
}

double CameraMotion::yaw(double t) const {
  if (spec_.hover) {
    return spec_.yaw + spec_.yaw_sweep * std::sin(2 * M_PI * t / spec_.sweep_period);
  }
  if (spec_.fly) {  // heading along the path, a slow +-2.9 degree wobble
    const double s = flown(t);
    const Eigen::Vector2d d = path_.at(s + 0.4) - path_.at(s - 0.4);
    return std::atan2(d.y(), d.x()) + 0.05 * std::sin(2 * M_PI * t / 2.3);
  }
  const double s = std::min(spec_.speed * t, path_.length());
  const Eigen::Vector2d d = path_.at(s + 0.4) - path_.at(s - 0.4);
  return std::atan2(d.y(), d.x()) + 0.02 * std::sin(2 * M_PI * t / 1.8);
}

// A multirotor: height sways by a few centimetres, pitch and roll by about 1-2 degrees, and the
// nose dips into accelerations (pitch + atan(a / g)) and rises when it brakes.
PoseD CameraMotion::fly_pose(double t) const {
  PoseD p;
  const Eigen::Vector2d xy = position_xy(t);
  const double z = spec_.position.z() + 0.04 * std::sin(2 * M_PI * t / 3.1) +
                   0.01 * std::sin(2 * M_PI * t / 0.7);
  p.translation = Eigen::Vector3d(xy.x(), xy.y(), z);
  const double accel = (speed(t + 0.15) - speed(t - 0.15)) / 0.3;
  const double pitch =
      spec_.pitch + 0.02 * std::sin(2 * M_PI * t / 1.7 + 0.4) + std::atan(accel / 9.81);
  const double roll = 0.03 * std::sin(2 * M_PI * t / 2.9 + 1.1);
  p.rotation = (camera_rotation(yaw(t), pitch) *
                Eigen::Quaterniond(Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitZ())))
                   .normalized();
  return p;
}

PoseD CameraMotion::pose(double t) const {
  if (!spec_.hover && spec_.fly) return fly_pose(t);
  PoseD p;
  const Eigen::Vector2d xy = position_xy(t);
  const double z = spec_.hover ? spec_.position.z() + 0.01 * std::sin(1.3 * t)
                               : spec_.position.z() + spec_.bob * std::sin(2 * M_PI * t / 0.9);
  p.translation = Eigen::Vector3d(xy.x(), xy.y(), z);
  p.rotation = camera_rotation(yaw(t), spec_.pitch);
  return p;
}

CameraModel sim_camera_model() {
  CameraModel c;
  c.fx = 385.0;
  c.fy = 385.0;
  c.cx = 320.0;
  c.cy = 240.0;
  c.width = 640;
  c.height = 480;
  c.depth_factor = 1000.0;
  c.world_z_up = 1;
  return c;
}

std::uint64_t SplitMix64::next() {
  std::uint64_t z = (state_ += 0x9E3779B97F4A7C15ull);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

double SplitMix64::uniform(double lo, double hi) {
  return lo + (hi - lo) * (static_cast<double>(next() >> 11) * (1.0 / 9007199254740992.0));
}

std::uint64_t hash3(std::uint64_t a, std::uint64_t b, std::uint64_t c) {
  SplitMix64 r(a * 0x9E3779B97F4A7C15ull ^ (b + 0x632BE59BD9B4E019ull) * 0xD6E8FEB86659FD93ull ^
               (c + 0x85157AF5ull) * 0xA0761D6478BD642Full);
  return r.next();
}

}  // namespace dynamap::tools::sim
