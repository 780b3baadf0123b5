// The built-in scenes. Layout coordinates are metres, world z up, floor at z = 0. Walker loops
// keep at least radius + 0.1 m from the static geometry (checked by test_tools).
#include <algorithm>
#include <cmath>

#include "common/text_io.hpp"
#include "sim/scene.hpp"

namespace dynamap::tools::sim {
namespace {

constexpr double kWallHeight = 2.5;
constexpr double kWallThickness = 0.2;

struct Builder {
  Scene scene;

  Builder(const char* name, const char* description) {
    scene.name = name;
    scene.description = description;
    scene.world.has_floor = true;
    scene.world.floor_z = 0.0;
  }
  // `dark`: a dark or shiny surface (the depth camera loses it in patches).
  void box(double x0, double y0, double x1, double y1, double h, bool dark = false) {
    scene.world.boxes.push_back(StaticBox{{x0, y0, 0.0}, {x1, y1, h}, dark});
  }
  // Wall along an axis-aligned segment, thickness outward of the given inner line.
  void wall_x(double x0, double x1, double y, bool outward_positive) {
    const double y0 = outward_positive ? y : y - kWallThickness;
    box(x0, y0, x1, y0 + kWallThickness, kWallHeight);
  }
  void wall_y(double y0, double y1, double x, bool outward_positive) {
    const double x0 = outward_positive ? x : x - kWallThickness;
    box(x0, y0, x0 + kWallThickness, y1, kWallHeight);
  }
  void room(double x0, double y0, double x1, double y1) {
    const double t = kWallThickness;
    wall_x(x0 - t, x1 + t, y0, false);
    wall_x(x0 - t, x1 + t, y1, true);
    wall_y(y0, y1, x0, false);
    wall_y(y0, y1, x1, true);
  }
  void pillar(double x, double y, double r = 0.25, double h = kWallHeight, bool dark = false) {
    scene.world.cylinders.push_back(StaticCylinder{{x, y}, r, 0.0, h, dark});
  }
  void standing_person(double x, double y, double h = 1.75) { pillar(x, y, 0.25, h); }
  void walker(std::vector<Waypoint> wps, double speed, double offset = 0.0) {
    WalkerSpec w;
    w.waypoints = std::move(wps);
    w.speed = speed;
    w.time_offset = offset;
    scene.walkers.push_back(w);
  }
  // A lane of the crowd: a stadium-shaped loop, one straight side at x = x_front walked from
  // y0 to y1, a half circle, the other side at x = x_back walked back, a half circle. The half
  // circles (waypoints every 15 degrees, radius half the lane spacing) keep a group's inner
  // member from turning on the spot. `pause` s standing at (x_front, pause_y) if > 0.
  static std::vector<Waypoint> stadium(double x_front, double x_back, double y0, double y1,
                                       double pause_y = 0.0, double pause = 0.0) {
    std::vector<Waypoint> w;
    const double xm = 0.5 * (x_front + x_back), r = 0.5 * std::fabs(x_back - x_front);
    const double out = y1 > y0 ? 1.0 : -1.0, side = x_back > x_front ? 1.0 : -1.0;
    auto half_circle = [&](double y, double bulge, double from) {
      for (int k = 0; k <= 12; ++k) {  // from x = `from` side across to the other side
        const double a = M_PI * k / 12.0;
        w.push_back({{xm - from * side * r * std::cos(a), y + bulge * r * std::sin(a)}, 0.0});
      }
    };
    w.push_back({{x_front, y0}, 0.0});
    if (pause > 0.0) w.push_back({{x_front, pause_y}, pause});
    half_circle(y1, out, 1.0);    // (x_front, y1) -> (x_back, y1)
    half_circle(y0, -out, -1.0);  // (x_back, y0) -> (x_front, y0)
    w.pop_back();                 // the loop closes on its first waypoint
    return w;
  }
  // Walkers on one lane: units (a group side by side or one person) spread evenly in time
  // along the loop, starting `phase` (0-1) into it. `sizes` = people per unit; members stand
  // 0.65 m apart side by side. All units pace turns for the lane's widest group, so they all
  // move alike (one motion shifted in time) and never catch up with each other.
  void lane(const std::vector<Waypoint>& wps, double speed, const std::vector<int>& sizes,
            double phase) {
    const int lane_id = ++lanes;
    const int widest = *std::max_element(sizes.begin(), sizes.end());
    WalkerSpec base;
    base.waypoints = wps;
    base.speed = speed;
    base.corner_cut = 0.5;
    // Turns paced for at least 0.5 m: even alone, people slow down to turn round.
    base.half_width = std::max(0.5, 0.325 * (widest - 1));
    base.lane = lane_id;
    const double period = WalkerMotion(base).period();
    for (std::size_t u = 0; u < sizes.size(); ++u) {
      WalkerSpec w = base;
      w.group = ++groups;
      w.time_offset = period * std::fmod(phase + static_cast<double>(u) / sizes.size(), 1.0);
      for (int m = 0; m < sizes[u]; ++m) {
        w.lateral = 0.65 * (m - 0.5 * (sizes[u] - 1));
        scene.walkers.push_back(w);
      }
    }
  }
  int lanes = 0, groups = 0;
  // There and back along a side lane of corridor_flight (y = 1.05 m on the side of `side`):
  // from a bay at x0 to a bay at x1 (0.9 m deep into each, standing 1 s there).
  static std::vector<Waypoint> side_lane(double x0, double x1, double side) {
    const double lane = 1.05 * side, bay = 1.95 * side;
    return {{{x0, bay}, 1.0}, {{x0, lane}, 0.0}, {{x1, lane}, 0.0},
            {{x1, bay}, 1.0}, {{x1, lane}, 0.0}, {{x0, lane}, 0.0}};
  }

  void hover(double x, double y, double z, double yaw, double sweep, double pitch = 0.12) {
    auto& c = scene.camera;
    c.hover = true;
    c.position = {x, y, z};
    c.yaw = yaw;
    c.yaw_sweep = sweep;
    c.pitch = pitch;
  }
  void carried(std::vector<Eigen::Vector2d> path, double z, double speed, double pitch = 0.12) {
    auto& c = scene.camera;
    c.hover = false;
    c.path = std::move(path);
    c.position = {0, 0, z};
    c.speed = speed;
    c.pitch = pitch;
  }
  // Flying like a multirotor along a path at height z with a (time, speed) profile.
  void fly(std::vector<Eigen::Vector2d> path, double z, std::vector<Eigen::Vector2d> profile,
           double pitch) {
    carried(std::move(path), z, 0.0, pitch);
    scene.camera.fly = true;
    scene.camera.speed_profile = std::move(profile);
  }
};

Scene corridor() {
  Builder b("corridor",
            "straight 3.2 m wide corridor; camera carried slowly forward; two people "
            "walking loops towards and away from it, one pausing");
  b.wall_x(-1.2, 16.2, -1.6, false);
  b.wall_x(-1.2, 16.2, 1.6, true);
  b.wall_y(-1.8, 1.8, -1.0, false);
  b.wall_y(-1.8, 1.8, 16.0, true);
  b.carried({{0.0, 0.0}, {3.0, 0.0}}, 1.3, 0.3);
  b.walker({{{11.5, 0.45}}, {{5.0, 0.45}}, {{5.0, -0.45}}, {{11.5, -0.45}}}, 1.0, 0.0);
  b.walker({{{7.5, -1.1}}, {{14.5, -1.1}}, {{14.5, 1.1}, 1.5}, {{7.5, 1.1}}}, 1.3, 3.0);
  return b.scene;
}

Scene l_corridor() {
  Builder b("l_corridor",
            "L-shaped corridor; camera carried to the corner and around it; one "
            "person walking around the corner, one pausing in the far leg");
  // Leg A along +x (inner y in [-1.5, 1.5]), leg B along +y (inner x in [6, 9]).
  b.wall_x(-1.2, 9.2, -1.5, false);  // south wall of leg A
  b.wall_x(-1.2, 6.0, 1.5, true);    // north wall of leg A, up to the corner
  b.wall_y(-1.7, 12.2, 9.0, true);   // east wall of both legs
  b.wall_y(1.5, 12.2, 6.0, false);   // west wall of leg B
  b.wall_y(-1.7, 1.7, -1.0, false);  // back wall of leg A
  b.wall_x(5.8, 9.2, 12.0, true);    // end wall of leg B
  b.carried({{1.0, 0.0}, {7.5, 0.0}, {7.5, 4.0}}, 1.3, 0.7);
  b.walker({{{3.5, -0.7}}, {{8.0, -0.7}}, {{8.0, 3.0}}, {{7.0, 3.0}}, {{7.0, 0.7}}, {{3.5, 0.7}}},
           1.0, 2.0);
  b.walker({{{6.9, 5.0}}, {{6.9, 11.0}, 2.0}, {{8.1, 11.0}}, {{8.1, 5.0}}}, 1.2, 1.0);
  return b.scene;
}

Scene env_a() {
  Builder b("env_a",
            "most cluttered room: pillars, crates, shelves and a standing person; four "
            "people walking around them, two pausing; camera hovering with a yaw sweep");
  b.room(0.0, -5.0, 14.0, 5.0);
  b.pillar(4.5, 1.6);
  b.pillar(6.5, -1.8);
  b.pillar(9.0, 2.4);
  b.pillar(10.5, -2.2);
  b.pillar(12.0, 0.8, 0.3, kWallHeight, true);  // glossy
  b.box(8.4, -0.4, 9.2, 0.4, 1.2, true);        // dark crate
  b.box(4.0, -3.8, 4.8, -3.0, 1.0);             // crate
  b.box(11.8, 3.0, 12.8, 4.0, 1.5);             // crate
  b.box(5.5, 3.6, 7.2, 4.1, 1.8);               // shelf along the north wall
  b.box(7.0, -4.7, 8.6, -4.2, 1.8);             // shelf along the south wall
  b.box(2.6, -2.6, 3.2, -2.0, 0.8);             // low box
  b.standing_person(6.8, 1.2);
  b.hover(2.0, 0.0, 1.4, 0.0, 0.20);
  b.walker({{{7.6, -1.1}}, {{10.0, -1.1}}, {{10.0, 1.1}}, {{7.6, 1.1}, 1.0}}, 1.0, 0.0);
  b.walker({{{3.6, -1.0}}, {{5.6, -0.8}}, {{5.6, 0.5}}, {{3.6, 0.7}, 1.0}}, 1.2, 2.0);
  b.walker({{{4.8, 2.7}}, {{8.2, 3.2}}, {{10.4, 3.0}, 1.5}, {{10.4, 1.6}}, {{7.9, 1.7}}}, 0.8, 4.0);
  b.walker({{{5.2, -1.9}}, {{6.6, -3.3}}, {{8.0, -2.4}}, {{6.6, -0.9}}}, 0.9, 1.0);
  return b.scene;
}

Scene env_b() {
  Builder b("env_b",
            "medium clutter: two pillars and two crates; three people walking; camera "
            "carried slowly along a gentle curve");
  b.room(0.0, -4.5, 13.0, 4.5);
  b.pillar(5.5, 1.5);
  b.pillar(8.5, -1.5);
  b.box(6.8, 0.2, 7.6, 1.0, 1.1);
  b.box(9.5, 1.8, 10.5, 2.8, 1.4, true);  // dark crate
  b.carried({{0.8, -0.8}, {2.5, -0.2}, {4.0, 0.6}}, 1.35, 0.3);
  b.walker(
      {{{4.5, -0.6}}, {{8.0, -0.4}}, {{10.8, -0.2}}, {{11.2, -2.6}}, {{7.0, -2.8}}, {{5.2, -2.2}}},
      1.1, 0.0);
  b.walker({{{7.4, 3.3}}, {{9.0, 1.0}, 1.2}, {{11.5, 0.8}}, {{11.8, 3.4}}, {{8.0, 3.6}}}, 0.9, 3.0);
  b.walker({{{4.6, 3.0}}, {{6.6, 2.6}}, {{6.2, 0.0}}, {{4.2, 0.6}}}, 0.7, 1.0);
  return b.scene;
}

Scene env_c() {
  Builder b("env_c",
            "simplest: an open room with one crate; two people walking; camera "
            "hovering still");
  b.room(0.0, -5.0, 12.0, 5.0);
  b.box(8.0, 1.5, 9.0, 2.5, 1.0);
  b.hover(1.5, 0.0, 1.3, 0.0, 0.0, 0.10);
  b.walker({{{4.0, -1.5}}, {{8.0, -1.5}}, {{8.0, 0.5}}, {{4.0, 0.5}}}, 1.0, 0.0);
  b.walker({{{5.0, 2.0}}, {{6.5, 3.2}}, {{10.0, 3.2}}, {{10.5, 0.6}, 1.0}, {{6.0, 1.0}}}, 1.3, 2.0);
  return b.scene;
}

Scene standing() {
  Builder b("standing",
            "three people who never move and two crates; camera carried past them "
            "(nothing here should be labelled dynamic)");
  b.room(0.0, -4.0, 11.0, 4.0);
  b.standing_person(4.5, 0.8);
  b.standing_person(6.0, -1.2, 1.65);
  b.standing_person(8.0, 1.6, 1.85);
  b.box(7.0, -0.3, 7.8, 0.5, 1.0);
  b.box(9.0, -2.8, 10.0, -1.8, 1.3, true);  // dark crate
  b.carried({{0.8, -1.5}, {2.5, -0.5}, {3.2, 1.8}}, 1.35, 0.35);
  return b.scene;
}

Scene crowd() {
  Builder b("crowd",
            "16 people in three lanes crossing both ways, in groups of 2-3 side by side, "
            "stopping, overtaking, passing within 1 m; a group standing talking; camera "
            "hovering");
  b.room(-1.5, -6.5, 8.2, 6.5);  // the far wall just within the camera's 8 m
  b.pillar(7.6, -3.5, 0.3);
  b.box(7.4, 4.2, 8.0, 5.0, 0.9, true);  // dark crate
  // The group standing talking (static: in static_world.txt, not in obstacles.txt).
  b.standing_person(7.35, 1.6);
  b.standing_person(7.3, 2.3, 1.68);
  b.standing_person(7.85, 1.95, 1.8);
  b.hover(0.0, 0.0, 1.4, 0.0, 0.06, 0.14);
  // Lanes nest in depth without sharing space, so nobody walks through anybody. Near lane:
  // two people crossing 0.9 m in front of the camera, coming back at 1.5 m.
  b.lane(Builder::stadium(0.9, 1.5, -1.9, 1.9), 1.2, {1, 1}, 0.05);
  // Middle lane: groups side by side crossing at 2.75 m and coming back at 4.7 m, each
  // stopping 2.5 s in front of the camera.
  b.lane(Builder::stadium(2.75, 4.7, -3.3, 3.3, 0.3, 2.5), 1.0, {3, 2, 1, 2, 3}, 0.12);
  // Far lane: faster people overtaking the middle lane's returning groups (same direction,
  // 0.6 m beside their outer member).
  b.lane(Builder::stadium(5.95, 6.6, 5.2, -5.2), 1.4, {1, 1, 1}, 0.3);
  return b.scene;
}

Scene corridor_flight() {
  Builder b("corridor_flight",
            "5 m wide corridor lined with boxes (some dark); camera flying down the middle at "
            "0.5-1.5 m/s; people walking along it both ways and across it, turning back in "
            "front of boxes and walls");
  // Inner corridor x in [0, 28], y in [-2.5, 2.5]; boxes 1 m deep and 2 m high along both
  // walls leave a free middle |y| < 1.5 and bays between them.
  b.wall_x(-0.2, 28.2, -2.5, false);
  b.wall_x(-0.2, 28.2, 2.5, true);
  b.wall_y(-2.5, 2.5, 0.0, false);
  b.wall_y(-2.5, 2.5, 28.0, true);
  const double north[][3] = {{2.0, 3.0, 0},   {4.2, 6.0, 1},   {7.0, 8.0, 0},
                             {9.5, 11.3, 0},  {12.5, 13.5, 1}, {15.0, 16.8, 0},
                             {18.0, 19.0, 0}, {20.5, 22.3, 1}, {24.0, 25.0, 0}};
  const double south[][3] = {{1.5, 3.3, 0},   {4.5, 5.5, 0},   {6.8, 8.6, 1},
                             {10.0, 11.0, 0}, {12.2, 14.0, 0}, {15.5, 16.5, 1},
                             {18.0, 19.8, 0}, {21.5, 22.5, 0}, {24.0, 25.8, 1}};
  for (const auto& x : north) b.box(x[0], 1.5, x[1], 2.5, 2.0, x[2] > 0);
  for (const auto& x : south) b.box(x[0], -2.5, x[1], -1.5, 2.0, x[2] > 0);
  // Flying down the middle with a gentle weave: 0.6 m/s, up to 1.5, down to 0.5, on at 1.0.
  b.fly({{1.0, 0.0}, {4.0, 0.12}, {8.0, -0.12}, {11.0, 0.08}, {13.0, 0.0}}, 1.35,
        {{0.0, 0.6}, {2.5, 1.5}, {5.0, 1.5}, {7.0, 0.5}, {8.5, 0.5}, {10.0, 1.0}}, 0.1);
  // Along the corridor in its side lanes (|y| = 1.05 m, 0.66 m clear of the camera), there and
  // back between two bays, standing a moment in each before turning back in front of its wall.
  b.walker(Builder::side_lane(3.6, 11.9, 1.0), 1.0, 12.0);
  b.walker(Builder::side_lane(3.9, 11.6, -1.0), 1.3, 2.0);
  // Across it beyond where the camera stops (x = 13 m): wall to wall, turning back in front
  // of the walls; and from a bay to the front of a box and back.
  b.walker({{{14.5, 1.95}, 1.0}, {{14.5, -1.95}, 0.8}}, 0.9, 1.0);
  b.walker({{{17.4, -1.95}, 1.0}, {{16.0, 1.1}, 0.5}}, 1.2, 3.0);
  return b.scene;
}

}  // namespace

std::vector<std::string> scene_names() {
  return {"corridor", "l_corridor", "env_a", "env_b",
          "env_c",    "standing",   "crowd", "corridor_flight"};
}

Scene make_scene(const std::string& name, std::uint64_t seed) {
  Scene s;
  if (name == "corridor") {
    s = corridor();
  } else if (name == "l_corridor") {
    s = l_corridor();
  } else if (name == "env_a") {
    s = env_a();
  } else if (name == "env_b") {
    s = env_b();
  } else if (name == "env_c") {
    s = env_c();
  } else if (name == "standing") {
    s = standing();
  } else if (name == "crowd") {
    s = crowd();
  } else if (name == "corridor_flight") {
    s = corridor_flight();
  } else {
    std::string known;
    for (const auto& n : scene_names()) known += " " + n;
    throw ToolError("unknown scene '" + name + "' (built-in scenes:" + known + ")");
  }
  SplitMix64 rng(seed ^ 0x5CE9E5EEDull);
  for (std::size_t k = 0; k < s.walkers.size(); ++k) {
    auto& w = s.walkers[k];
    w.speed = std::clamp(w.speed * rng.uniform(0.92, 1.08), 0.5, 1.5);
    w.radius = rng.uniform(0.23, 0.27);
    w.height = rng.uniform(1.62, 1.85);
    w.time_offset += rng.uniform(0.0, 0.5);
    // A lane's walkers share the first one's speed, a group's members its start time too.
    const auto same = [&](auto member) {
      return std::find_if(
          s.walkers.begin(), s.walkers.begin() + static_cast<long>(k),
          [&](const WalkerSpec& o) { return member(o) > 0 && member(o) == member(w); });
    };
    const auto lane = same([](const WalkerSpec& o) { return o.lane; });
    if (lane != s.walkers.begin() + static_cast<long>(k)) w.speed = lane->speed;
    const auto group = same([](const WalkerSpec& o) { return o.group; });
    if (group != s.walkers.begin() + static_cast<long>(k)) w.time_offset = group->time_offset;
  }
  return s;
}

}  // namespace dynamap::tools::sim
