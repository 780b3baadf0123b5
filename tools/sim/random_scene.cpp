// The scene generator of dynamap-sim random (docs/tools.md). Layout, clutter, camera run and
// people are drawn in that order; paths are planned on a 0.1 m clearance grid (A*, then
// shortened by line of sight) and every walker and camera motion is checked by sampling before it
// is kept, so nobody starts in or walks through an obstacle and the camera flies clear.
#include "sim/random_scene.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <queue>
#include <utility>

namespace dynamap::tools::sim {
namespace {

using V2 = Eigen::Vector2d;
using Limits = RandomSceneLimits;
constexpr double kFps = 30.0;
constexpr double kCell = 0.1;         // m, planning grid
constexpr double kThickness = 0.2;    // m, walls
constexpr double kSampleStep = 0.05;  // s, soundness sampling of motions

struct Rect {
  V2 lo, hi;
  bool contains(const V2& p) const {
    return p.x() >= lo.x() && p.y() >= lo.y() && p.x() <= hi.x() && p.y() <= hi.y();
  }
  double edge_distance(const V2& p) const {
    return std::min({p.x() - lo.x(), hi.x() - p.x(), p.y() - lo.y(), hi.y() - p.y()});
  }
  double area() const { return (hi - lo).prod(); }
};

// Draws on top of SplitMix64; small helpers only (no std distributions: they differ between
// standard libraries).
class Rng {
 public:
  explicit Rng(std::uint64_t seed) : r_(seed) {}
  double uni(double lo, double hi) { return r_.uniform(lo, hi); }
  int pick(int n) { return static_cast<int>(r_.next() % static_cast<std::uint64_t>(n)); }
  bool chance(double p) { return r_.uniform(0.0, 1.0) < p; }

 private:
  SplitMix64 r_;
};

std::string fmt(const char* f, double a = 0, double b = 0, double c = 0, double d = 0, double e = 0,
                double g = 0) {
  char buf[256];
  std::snprintf(buf, sizeof(buf), f, a, b, c, d, e, g);
  return buf;
}

std::string pts(const std::vector<V2>& p) {
  std::string s;
  for (const auto& q : p) s += fmt(" (%.2f, %.2f)", q.x(), q.y());
  return s;
}

double wrap(double a) {
  return std::atan2(std::sin(a), std::cos(a));
}

// One walker of a unit (a person or a group) while drawing: its spec and its motion.
struct Placed {
  WalkerSpec spec;
  WalkerMotion motion;
};

class Generator {
 public:
  Generator(std::uint64_t seed, int frames)
      : rng_(seed ^ 0xA5D0C0FFEEull), frames_(frames), duration_(frames / kFps) {}
  RandomScene run();

 private:
  void log(const std::string& s) { out_.draws.push_back(s); }
  // Layout and clutter.
  void draw_layout();
  void room(double x0, double y0, double x1, double y1);
  void box(const V2& lo, const V2& hi, double h, bool dark) {
    out_.scene.world.boxes.push_back(StaticBox{{lo.x(), lo.y(), 0.0}, {hi.x(), hi.y(), h}, dark});
  }
  void draw_clutter();
  bool place_item(int k);
  bool box_fits(const V2& lo, const V2& hi, bool narrow) const;
  double clearance(const V2& p) const;
  V2 random_point();
  bool free_point(double c, V2* p, double c_max = 1e9);
  // Planning.
  void build_grid();
  double grid_clearance(int ix, int iy) const;
  std::vector<V2> astar(const V2& a, const V2& b, double c) const;
  bool segment_clear(const V2& a, const V2& b, double c) const;
  std::vector<V2> plan(const V2& a, const V2& b, double c) const;
  std::vector<V2> plan_loop(const std::vector<V2>& stops, double c, std::vector<int>* at) const;
  // Camera.
  void draw_camera();
  bool draw_moving_camera(bool fly);
  bool camera_sound(const CameraSpec& spec) const;
  // People.
  void draw_people();
  int draw_unit(int index, int left);
  bool unit_stops(int kind, double c, std::vector<V2>* stops);
  bool crossing_stops(int kind, double c, std::vector<V2>* stops);
  std::vector<WalkerSpec> unit_people(int members);
  bool place_unit(std::vector<WalkerSpec>& specs, const std::vector<Waypoint>& wps, int kind);
  std::string describe_unit(const std::vector<Waypoint>& wps) const;
  bool unit_sound(const std::vector<Placed>& unit) const;
  bool unit_clear_of_others(const std::vector<Placed>& unit) const;
  double align(const WalkerMotion& m, const V2& x, double t) const;

  Rng rng_;
  int frames_;
  double duration_;
  RandomScene out_;
  std::vector<Rect> areas_;
  bool open_ = false;  // open space: no walls; walkers keep inside the area
  double wall_h_ = 2.5;
  std::size_t walls_ = 0;  // the first walls_ boxes are walls
  V2 cam_start_ = V2(1.2, 0.0);
  // Grid over the areas' bounding box: clearance of each cell centre (-1 outside the areas).
  V2 origin_ = V2::Zero();
  int nx_ = 0, ny_ = 0;
  std::vector<float> clear_;
  std::vector<Placed> placed_;
  int groups_ = 0;
  V2 cross_x_ = V2::Zero();  // the unit being drawn crosses here at cross_t_ (< 0: no)
  double cross_t_ = -1.0;
};

void Generator::room(double x0, double y0, double x1, double y1) {
  const double t = kThickness;
  box({x0 - t, y0 - t}, {x1 + t, y0}, wall_h_, false);
  box({x0 - t, y1}, {x1 + t, y1 + t}, wall_h_, false);
  box({x0 - t, y0}, {x0, y1}, wall_h_, false);
  box({x1, y0}, {x1 + t, y1}, wall_h_, false);
}

void Generator::draw_layout() {
  static const char* kinds[] = {"room", "corridor", "l_corridor", "open_space", "cluttered_hall"};
  const int kind = rng_.pick(5);
  out_.layout = kinds[kind];
  wall_h_ = rng_.uni(2.0, 3.0);
  double w = 0, d = 0;
  if (kind == 0 || kind == 4) {
    w = kind == 0 ? rng_.uni(8.0, 14.0) : rng_.uni(12.0, 18.0);
    d = kind == 0 ? rng_.uni(6.0, 10.0) : rng_.uni(8.0, 12.0);
    areas_.push_back({{0.0, -0.5 * d}, {w, 0.5 * d}});
    room(0.0, -0.5 * d, w, 0.5 * d);
  } else if (kind == 1) {
    w = rng_.uni(14.0, 24.0);
    d = rng_.uni(2.6, 4.0);
    areas_.push_back({{0.0, -0.5 * d}, {w, 0.5 * d}});
    room(0.0, -0.5 * d, w, 0.5 * d);
  } else if (kind == 2) {
    w = rng_.uni(8.0, 14.0);  // leg A along +x, width d
    d = rng_.uni(2.6, 3.6);
    const double lb = rng_.uni(6.0, 12.0), wb = rng_.uni(2.6, 3.6), t = kThickness;
    const double x0 = w - wb, ya = 0.5 * d, yb = ya + lb;
    areas_.push_back({{0.0, -ya}, {w, ya}});
    areas_.push_back({{x0, ya - 0.01}, {w, yb}});
    box({-t, -ya - t}, {w + t, -ya}, wall_h_, false);    // south of A
    box({-t, ya}, {x0, ya + t}, wall_h_, false);         // north of A up to the corner
    box({w, -ya - t}, {w + t, yb + t}, wall_h_, false);  // east of A and B
    box({x0 - t, ya}, {x0, yb}, wall_h_, false);         // west of B
    box({-t, -ya}, {0.0, ya}, wall_h_, false);           // back of A
    box({x0 - t, yb}, {w + t, yb + t}, wall_h_, false);  // end of B
    log(fmt("leg B: %.2f m long, %.2f m wide", lb, wb));
  } else {
    w = rng_.uni(14.0, 20.0);
    d = rng_.uni(10.0, 16.0);
    areas_.push_back({{0.0, -0.5 * d}, {w, 0.5 * d}});
    open_ = true;
  }
  cam_start_ = V2(rng_.uni(0.9, 1.5), rng_.uni(-0.2, 0.2) * std::min(d, 3.0));
  walls_ = out_.scene.world.boxes.size();
  log("layout: " + out_.layout + fmt(", %.2f x %.2f m, walls %.2f m high", w, d, wall_h_) +
      (open_ ? " (no walls)" : ""));
}

double Generator::clearance(const V2& p) const {
  double edge = -1.0;
  for (const auto& a : areas_) {
    if (a.contains(p)) edge = std::max(edge, open_ ? a.edge_distance(p) : 1e9);
  }
  if (edge < 0.0) return -1.0;
  return std::min(edge, out_.scene.world.top_view_distance(p, 0.0, 10.0));
}

V2 Generator::random_point() {
  double total = 0.0;
  for (const auto& a : areas_) total += a.area();
  double u = rng_.uni(0.0, total);
  for (const auto& a : areas_) {
    if (u <= a.area() || &a == &areas_.back()) {
      return {rng_.uni(a.lo.x(), a.hi.x()), rng_.uni(a.lo.y(), a.hi.y())};
    }
    u -= a.area();
  }
  return cam_start_;
}

bool Generator::free_point(double c, V2* p, double c_max) {
  for (int i = 0; i < 300; ++i) {
    const V2 q = random_point();
    const double cl = clearance(q);
    if (cl >= c && cl <= c_max) {
      *p = q;
      return true;
    }
  }
  return false;
}

// One clutter item: a crate, a pillar or a person who only stands, kept 0.8 m from the others
// and 1.5 m from the camera's start. Corridors get their items along the walls.
bool Generator::place_item(int k) {
  const int type = rng_.pick(4);  // 0, 1 crate, 2 pillar, 3 standing person
  const bool dark = rng_.chance(0.25);
  const bool narrow = out_.layout == "corridor" || out_.layout == "l_corridor";
  V2 c = random_point();
  if (type == 3) {
    const double r = rng_.uni(0.18, 0.28), h = rng_.uni(1.1, 1.9);
    if (clearance(c) < r + 0.8 || (c - cam_start_).norm() < 1.5 + r) return false;
    out_.scene.world.cylinders.push_back(StaticCylinder{c, r, 0.0, h, false});
    log(fmt("item %.0f: standing person at (%.2f, %.2f), radius %.2f, %.2f m tall", k, c.x(), c.y(),
            r, h));
    return true;
  }
  if (type == 2) {
    const double r = rng_.uni(0.15, 0.4), h = open_ ? rng_.uni(2.0, 3.0) : wall_h_;
    if (clearance(c) < r + 0.8 || (c - cam_start_).norm() < 1.5 + r) return false;
    out_.scene.world.cylinders.push_back(StaticCylinder{c, r, 0.0, h, dark});
    log(fmt("item %.0f: pillar at (%.2f, %.2f), radius %.2f, %.2f m high", k, c.x(), c.y(), r, h) +
        (dark ? " dark" : ""));
    return true;
  }
  V2 size(rng_.uni(0.3, 2.0), rng_.uni(0.3, 2.0));
  const double h = rng_.uni(0.3, 2.0);
  if (narrow) {
    // Against a wall of the leg it falls in: at most 0.3 of the width deep.
    for (const auto& a : areas_) {
      if (!a.contains(c)) continue;
      const bool along_x = (a.hi - a.lo).x() >= (a.hi - a.lo).y();
      const int ax = along_x ? 1 : 0;
      const double width = (a.hi - a.lo)[ax];
      size[ax] = std::min(size[ax], 0.3 * width);
      c[ax] = rng_.chance(0.5) ? a.lo[ax] + 0.5 * size[ax] : a.hi[ax] - 0.5 * size[ax];
      break;
    }
  }
  const V2 lo = c - 0.5 * size, hi = c + 0.5 * size;
  if (!box_fits(lo, hi, narrow)) return false;
  box(lo, hi, h, dark);
  log(fmt("item %.0f: crate x [%.2f, %.2f] y [%.2f, %.2f], %.2f m high", k, lo.x(), hi.x(), lo.y(),
          hi.y(), h) +
      (dark ? " dark" : ""));
  return true;
}

// A crate at [lo, hi] fits: inside the floor, 0.8 m from other items (and from walls except in
// corridors, where it stands against them), 1.5 m from the camera's start.
bool Generator::box_fits(const V2& lo, const V2& hi, bool narrow) const {
  auto gap = [&](const V2& blo, const V2& bhi) {
    const double dx = std::max({blo.x() - hi.x(), 0.0, lo.x() - bhi.x()});
    const double dy = std::max({blo.y() - hi.y(), 0.0, lo.y() - bhi.y()});
    return std::hypot(dx, dy);
  };
  for (const V2& q : {lo, hi, V2(lo.x(), hi.y()), V2(hi.x(), lo.y())}) {
    bool inside = false;
    for (const auto& a : areas_) inside = inside || a.contains(q);
    if (!inside) return false;
  }
  const auto& boxes = out_.scene.world.boxes;
  for (std::size_t i = 0; i < boxes.size(); ++i) {
    if (i < walls_ && narrow) continue;
    if (gap(boxes[i].min.head<2>(), boxes[i].max.head<2>()) < 0.8) return false;
  }
  for (const auto& cy : out_.scene.world.cylinders) {
    if (gap(cy.center, cy.center) < cy.radius + 0.8) return false;
  }
  if (open_) {
    for (const V2& q : {lo, hi}) {
      if (areas_[0].edge_distance(q) < 0.8) return false;
    }
  }
  return gap(cam_start_, cam_start_) >= 1.5;
}

void Generator::draw_clutter() {
  const auto& l = out_.layout;
  const int n = l == "cluttered_hall" ? 10 + rng_.pick(9)
                : l == "open_space"   ? 4 + rng_.pick(7)
                : l == "room"         ? 3 + rng_.pick(6)
                                      : 2 + rng_.pick(6);
  int placed = 0;
  for (int tries = 0; placed < n && tries < 40 * n; ++tries) {
    if (place_item(placed + 1)) ++placed;
  }
  log(fmt("clutter: %.0f items drawn, %.0f placed", n, placed));
}

void Generator::build_grid() {
  V2 lo = areas_[0].lo, hi = areas_[0].hi;
  for (const auto& a : areas_) {
    lo = lo.cwiseMin(a.lo);
    hi = hi.cwiseMax(a.hi);
  }
  origin_ = lo;
  nx_ = static_cast<int>(std::ceil((hi.x() - lo.x()) / kCell)) + 1;
  ny_ = static_cast<int>(std::ceil((hi.y() - lo.y()) / kCell)) + 1;
  clear_.assign(static_cast<std::size_t>(nx_) * static_cast<std::size_t>(ny_), -1.0f);
  for (int iy = 0; iy < ny_; ++iy) {
    for (int ix = 0; ix < nx_; ++ix) {
      const V2 p = origin_ + kCell * V2(ix, iy);
      clear_[static_cast<std::size_t>(iy) * nx_ + ix] = static_cast<float>(clearance(p));
    }
  }
}

double Generator::grid_clearance(int ix, int iy) const {
  if (ix < 0 || iy < 0 || ix >= nx_ || iy >= ny_) return -1.0;
  return clear_[static_cast<std::size_t>(iy) * nx_ + ix];
}

// A* over the grid's cells with clearance >= c, 8-connected; ties broken by cell index, so the
// result is the same everywhere. Returns cell centres from a's cell to b's cell (empty: none).
std::vector<V2> Generator::astar(const V2& a, const V2& b, double c) const {
  auto cell = [&](const V2& p) {
    const V2 q = (p - origin_) / kCell;
    return std::make_pair(static_cast<int>(std::lround(q.x())),
                          static_cast<int>(std::lround(q.y())));
  };
  const int ax = cell(a).first, ay = cell(a).second;  // no structured bindings: lambdas use them
  const int bx = cell(b).first, by = cell(b).second;
  if (grid_clearance(ax, ay) < c || grid_clearance(bx, by) < c) return {};
  const int start = ay * nx_ + ax, goal = by * nx_ + bx;
  std::vector<double> g(clear_.size(), std::numeric_limits<double>::infinity());
  std::vector<int> from(clear_.size(), -1);
  using Item = std::pair<double, int>;
  std::priority_queue<Item, std::vector<Item>, std::greater<Item>> open;
  auto h = [&](int i) {
    const double dx = std::abs(i % nx_ - bx), dy = std::abs(i / nx_ - by);
    return std::max(dx, dy) + (std::sqrt(2.0) - 1.0) * std::min(dx, dy);
  };
  g[static_cast<std::size_t>(start)] = 0.0;
  open.push({h(start), start});
  while (!open.empty()) {
    const auto [f, i] = open.top();
    open.pop();
    if (i == goal) break;
    if (f > g[static_cast<std::size_t>(i)] + h(i) + 1e-9) continue;
    for (int dy = -1; dy <= 1; ++dy) {
      for (int dx = -1; dx <= 1; ++dx) {
        const int jx = i % nx_ + dx, jy = i / nx_ + dy;
        if ((dx == 0 && dy == 0) || grid_clearance(jx, jy) < c) continue;
        const int j = jy * nx_ + jx;
        const double ng =
            g[static_cast<std::size_t>(i)] + (dx != 0 && dy != 0 ? std::sqrt(2.0) : 1.0);
        if (ng + 1e-12 < g[static_cast<std::size_t>(j)]) {
          g[static_cast<std::size_t>(j)] = ng;
          from[static_cast<std::size_t>(j)] = i;
          open.push({ng + h(j), j});
        }
      }
    }
  }
  if (from[static_cast<std::size_t>(goal)] < 0 && goal != start) return {};
  std::vector<V2> path;
  for (int i = goal; i >= 0; i = i == start ? -1 : from[static_cast<std::size_t>(i)]) {
    path.push_back(origin_ + kCell * V2(i % nx_, i / nx_));
  }
  std::reverse(path.begin(), path.end());
  return path;
}

bool Generator::segment_clear(const V2& a, const V2& b, double c) const {
  const int n = std::max(1, static_cast<int>(std::ceil((b - a).norm() / 0.05)));
  for (int i = 0; i <= n; ++i) {
    if (clearance(a + (b - a) * (static_cast<double>(i) / n)) < c) return false;
  }
  return true;
}

// Path from a to b keeping clearance c: A* on the grid, then shortened by line of sight.
std::vector<V2> Generator::plan(const V2& a, const V2& b, double c) const {
  std::vector<V2> cells = astar(a, b, c);
  if (cells.empty()) return {};
  cells.front() = a;
  cells.back() = b;
  std::vector<V2> out{a};
  std::size_t i = 0;
  while (i + 1 < cells.size()) {
    std::size_t j = cells.size() - 1;
    while (j > i + 1 && !segment_clear(cells[i], cells[j], c)) --j;
    out.push_back(cells[j]);
    i = j;
  }
  return out;
}

// A closed loop through `stops` (planned leg by leg); `at` receives each stop's index in it.
std::vector<V2> Generator::plan_loop(const std::vector<V2>& stops, double c,
                                     std::vector<int>* at) const {
  std::vector<V2> loop;
  at->clear();
  for (std::size_t k = 0; k < stops.size(); ++k) {
    const std::vector<V2> leg = plan(stops[k], stops[(k + 1) % stops.size()], c);
    if (leg.empty()) return {};
    at->push_back(static_cast<int>(loop.size()));
    loop.insert(loop.end(), leg.begin(), leg.end() - 1);  // the next leg adds its start
  }
  if (loop.empty()) return {};
  // A stop whose leg added no point (it coincides with the next stop) may sit at loop.size():
  // on a closed loop that is the first point.
  for (int& i : *at) {
    if (i >= static_cast<int>(loop.size())) i = 0;
  }
  return loop;
}

// Sound camera run: the centre keeps camera_static from every shape (and inside the floor), and
// the heading turns at most max_yaw_rate.
bool Generator::camera_sound(const CameraSpec& spec) const {
  const CameraMotion m(spec);
  const double dt = 1.0 / kFps;
  for (int f = 0; f < frames_; ++f) {
    const double t = f / kFps;
    if (clearance(m.position_xy(t)) < Limits::camera_static) return false;
    if (std::fabs(wrap(m.yaw(t + dt) - m.yaw(t))) > Limits::max_yaw_rate * dt) return false;
  }
  return true;
}

// Carried at walking pace or flying with a random speed profile, along a chain of planned legs
// to random goals long enough for the run; slowed down until its turns are slow enough.
bool Generator::draw_moving_camera(bool fly) {
  auto& c = out_.scene.camera;
  c.hover = false;
  c.fly = fly;
  c.speed = rng_.uni(0.9, 1.4);
  c.bob = rng_.uni(0.015, 0.035);
  c.speed_profile.clear();
  double mean = c.speed;
  if (fly) {
    mean = 0.0;
    for (double t = 0.0; t < duration_ + 3.0; t += rng_.uni(2.0, 4.0)) {
      c.speed_profile.push_back({t, rng_.uni(0.5, 2.0)});
      mean += c.speed_profile.back().y() / 1.0;
    }
    mean /= static_cast<double>(c.speed_profile.size());
  }
  const double clear = Limits::camera_static + 0.3;
  for (int attempt = 0; attempt < 6; ++attempt) {
    std::vector<V2> path{cam_start_};
    double length = 0.0;
    for (int leg = 0; leg < 8 && length < 1.1 * mean * duration_; ++leg) {
      V2 goal;
      if (!free_point(clear + 0.2, &goal) || (goal - path.back()).norm() < 3.0) continue;
      const std::vector<V2> p = plan(path.back(), goal, clear);
      if (p.empty()) continue;
      for (std::size_t i = 1; i < p.size(); ++i) length += (p[i] - p[i - 1]).norm();
      path.insert(path.end(), p.begin() + 1, p.end());
    }
    if (path.size() < 2) continue;
    c.path = path;
    for (int slow = 0; slow < 5; ++slow) {
      if (camera_sound(c)) {
        out_.camera = fly ? "fly" : "carried";
        std::string profile;
        for (const auto& k : c.speed_profile) profile += fmt(" %.1fs:%.2fm/s", k.x(), k.y());
        log("camera: " + out_.camera +
            fmt(", %.2f m high, pitch %.3f rad", c.position.z(), c.pitch) +
            (fly ? ", speed profile" + profile : fmt(", %.2f m/s, bob %.3f m", c.speed, c.bob)));
        log("camera path:" + pts(path));
        return true;
      }
      c.speed *= 0.75;
      for (auto& k : c.speed_profile) k.y() = std::max(0.3, 0.75 * k.y());
    }
  }
  return false;
}

void Generator::draw_camera() {
  auto& c = out_.scene.camera;
  c.position = {cam_start_.x(), cam_start_.y(), rng_.uni(1.0, 1.6)};
  c.pitch = rng_.uni(0.05, 0.2);
  const int mode = rng_.pick(10);  // 0-2 hover, 3-5 carried, 6-9 fly
  if (mode >= 3 && draw_moving_camera(mode >= 6)) return;
  c.hover = true;
  c.fly = false;
  c.yaw = rng_.uni(-0.3, 0.3);
  c.yaw_sweep = rng_.uni(0.0, 0.7);
  c.sweep_period = rng_.uni(8.0, 16.0);
  out_.camera = "hover";
  log(fmt("camera: hover at (%.2f, %.2f, %.2f), pitch %.3f rad, yaw %.3f rad", c.position.x(),
          c.position.y(), c.position.z(), c.pitch, c.yaw) +
      fmt(", sweep +-%.3f rad every %.1f s", c.yaw_sweep, c.sweep_period) +
      (mode >= 3 ? " (no sound moving run found)" : ""));
}

// Stops of a walker crossing the camera's view at a random time: A and B on either side of a
// point ahead of the camera (close: 0.8-1.2 m ahead). Side entry: from outside the view at the
// start to a point in it. `cross_` receives the point and time to align the walker with.
bool Generator::crossing_stops(int kind, double c, std::vector<V2>* stops) {
  const CameraMotion cam(out_.scene.camera);
  const bool side = kind == 4;
  const double tc = side ? 0.0 : rng_.uni(1.0, std::max(1.5, duration_ - 1.0));
  const V2 p = cam.position_xy(tc);
  const double yaw = cam.yaw(tc);
  const V2 ahead(std::cos(yaw), std::sin(yaw)), left(-ahead.y(), ahead.x());
  if (side) {
    for (int i = 0; i < 10; ++i) {
      const double s = rng_.chance(0.5) ? 1.0 : -1.0, a = s * rng_.uni(0.9, 1.6);
      const V2 from = p + rng_.uni(1.0, 4.0) * V2(std::cos(yaw + a), std::sin(yaw + a));
      const V2 to = p + rng_.uni(2.0, 5.0) * ahead + rng_.uni(-1.0, 1.0) * left;
      if (clearance(from) < c || clearance(to) < c) continue;
      *stops = {from, to};
      return true;
    }
    return false;
  }
  const V2 x = p + (kind == 3 ? rng_.uni(0.8, 1.2) : rng_.uni(1.5, 5.0)) * ahead;
  if (clearance(x) < c) return false;
  V2 a = x + rng_.uni(1.5, 3.5) * left, b = x - rng_.uni(1.5, 3.5) * left;
  while (clearance(a) < c && (a - x).norm() > 0.5) a -= 0.1 * left;
  while (clearance(b) < c && (b - x).norm() > 0.5) b += 0.1 * left;
  if (clearance(a) < c || clearance(b) < c || (a - b).norm() < 1.2) return false;
  *stops = rng_.chance(0.5) ? std::vector<V2>{a, b} : std::vector<V2>{b, a};
  cross_x_ = x;
  cross_t_ = tc;
  return true;
}

// Stops of a unit by kind: a loop through 3-4 points; there and back to a point in front of
// an obstacle or wall (a U-turn); crossings and side entries (crossing_stops).
bool Generator::unit_stops(int kind, double c, std::vector<V2>* stops) {
  stops->clear();
  cross_t_ = -1.0;
  if (kind == 0 || kind == 5) {
    const int n = 3 + rng_.pick(2);
    for (int i = 0; i < n; ++i) {
      V2 p;
      if (!free_point(c + 0.1, &p)) return false;
      stops->push_back(p);
    }
    return true;
  }
  if (kind == 1) {
    V2 a, b;
    if (!free_point(c, &a)) return false;
    for (int i = 0; i < 20; ++i) {
      if (free_point(c, &b, c + 0.3) && (b - a).norm() > 3.0) {
        *stops = {a, b};
        return true;
      }
    }
    return false;
  }
  return crossing_stops(kind, c, stops);
}

// Time offset that puts the walker at (nearly) x at time t.
double Generator::align(const WalkerMotion& m, const V2& x, double t) const {
  double best = 1e18, tau = 0.0;
  for (double s = 0.0; s < m.period(); s += kSampleStep) {
    const double d = (m.position(s) - x).squaredNorm();
    if (d < best) best = d, tau = s;
  }
  const double off = std::fmod(tau - t, m.period());
  return off < 0.0 ? off + m.period() : off;
}

// Static soundness over the whole loop: clearance from every shape, inside the floor, and no
// faster than max_speed.
bool Generator::unit_sound(const std::vector<Placed>& unit) const {
  for (const auto& w : unit) {
    V2 last = w.motion.position(0.0);
    for (double t = 0.0; t <= w.motion.period() + 1e-9; t += kSampleStep) {
      const V2 p = w.motion.position(t);
      if (clearance(p) < w.spec.radius + Limits::walker_static) return false;
      if ((p - last).norm() > Limits::max_speed * kSampleStep) return false;
      last = p;
    }
  }
  return true;
}

// During the run: clear of the camera and not through the people placed before.
bool Generator::unit_clear_of_others(const std::vector<Placed>& unit) const {
  const CameraMotion cam(out_.scene.camera);
  for (int f = 0; f < frames_; ++f) {  // at the frames' times
    const double t = f / kFps;
    const V2 cp = cam.position_xy(t);
    for (const auto& w : unit) {
      const V2 p = w.motion.position(t);
      if ((p - cp).norm() < w.spec.radius + Limits::camera_walker) return false;
      for (const auto& o : placed_) {
        const double min = Limits::walker_overlap * (w.spec.radius + o.spec.radius);
        if ((p - o.motion.position(t)).norm() < min) return false;
      }
    }
  }
  return true;
}

// The people of one unit (a person, or a group of 2-3 side by side): sizes from children to tall
// adults, a speed, pauses (stops and restarts) at some stops.
std::vector<WalkerSpec> Generator::unit_people(int members) {
  std::vector<WalkerSpec> specs(static_cast<std::size_t>(members));
  const double speed = rng_.uni(0.5, 1.6);
  for (int m = 0; m < members; ++m) {
    auto& w = specs[static_cast<std::size_t>(m)];
    const bool child = rng_.chance(0.2);
    w.radius = child ? rng_.uni(0.15, 0.2) : rng_.uni(0.2, 0.3);
    w.height = child ? rng_.uni(1.0, 1.4) : rng_.uni(1.5, 1.95);
    w.speed = speed;
    w.corner_cut = 0.4;
    if (members > 1) {
      w.lateral = 0.65 * (m - 0.5 * (members - 1));
      w.half_width = std::max(0.5, 0.325 * (members - 1));
    }
  }
  return specs;
}

// Draws one unit and places it if some time offset makes it sound; returns its size (placed or
// dropped, so the drawing ends).
int Generator::draw_unit(int index, int left) {
  static const char* names[] = {"loop",       "there and back", "crossing",
                                "close pass", "side entry",     "group"};
  const int u = rng_.pick(20);
  const int kind = u < 6 ? 0 : u < 10 ? 1 : u < 13 ? 2 : u < 15 ? 3 : u < 17 ? 4 : 5;
  const int members = kind == 5 ? std::min(left, 2 + rng_.pick(2)) : 1;
  std::vector<WalkerSpec> specs = unit_people(members);
  double rmax = 0.0;
  for (const auto& w : specs) rmax = std::max(rmax, w.radius);
  const double c = rmax + Limits::walker_static + 0.325 * (members - 1) + 0.2;
  for (int attempt = 0; attempt < 6; ++attempt) {
    std::vector<V2> stops;
    std::vector<int> at;
    if (!unit_stops(kind, c, &stops)) continue;
    const std::vector<V2> loop = plan_loop(stops, c, &at);
    if (loop.empty()) continue;
    std::vector<Waypoint> wps;
    for (const auto& p : loop) wps.push_back({p, 0.0});
    for (std::size_t k = 0; k < at.size(); ++k) {
      const bool stop = rng_.chance(kind == 1 ? 0.5 : 0.3) && !(kind == 4 && k == 0);
      wps[static_cast<std::size_t>(at[k])].pause = stop ? rng_.uni(0.5, 3.0) : 0.0;
    }
    if (place_unit(specs, wps, kind)) {
      log(fmt("unit %.0f: ", index) + names[kind] +
          fmt(", %.0f people at %.2f m/s", members, specs[0].speed) + describe_unit(wps));
      return members;
    }
  }
  log(fmt("unit %.0f: ", index) + names[kind] +
      fmt(", %.0f people: dropped (no sound place)", members));
  return members;
}

// Sets the unit's waypoints and time offset (aligned with its crossing, random otherwise) and
// keeps it if it is sound.
bool Generator::place_unit(std::vector<WalkerSpec>& specs, const std::vector<Waypoint>& wps,
                           int kind) {
  const int group = specs.size() > 1 ? ++groups_ : 0;
  std::vector<Placed> unit;
  for (auto& w : specs) {
    w.waypoints = wps;
    w.group = w.lane = group;
    unit.push_back({w, WalkerMotion(w)});
  }
  if (!unit_sound(unit)) return false;
  const double period = unit[0].motion.period();
  const double base = cross_t_ >= 0.0 ? align(unit[0].motion, cross_x_, cross_t_)
                      : kind == 4     ? 0.0
                                      : rng_.uni(0.0, period);
  static const double shifts[] = {0.0, 0.4, -0.4, 0.8, -0.8, 1.5, -1.5};
  for (double shift : shifts) {
    double off = std::fmod(base + shift, period);
    if (off < 0.0) off += period;
    for (auto& p : unit) {
      p.spec.time_offset = off;
      p.motion = WalkerMotion(p.spec);
    }
    if (!unit_clear_of_others(unit)) continue;
    for (auto& p : unit) {
      placed_.push_back(p);
      out_.scene.walkers.push_back(p.spec);
    }
    specs[0].time_offset = off;
    return true;
  }
  return false;
}

std::string Generator::describe_unit(const std::vector<Waypoint>& wps) const {
  const auto& w = placed_.back().spec;
  std::string s = fmt(", start %.2f s into the loop; sizes", w.time_offset);
  const std::size_t n = placed_.size();
  for (std::size_t k = n - std::min(n, static_cast<std::size_t>(3)); k < n; ++k) {
    if (placed_[k].spec.group != w.group || (w.group == 0 && k + 1 != n)) continue;
    s += fmt(" r %.2f h %.2f", placed_[k].spec.radius, placed_[k].spec.height);
  }
  s += "; path";
  for (const auto& p : wps) {
    s += fmt(" (%.2f, %.2f)", p.p.x(), p.p.y());
    if (p.pause > 0.0) s += fmt(" stop %.1f s", p.pause);
  }
  return s;
}

void Generator::draw_people() {
  const int n = rng_.pick(21);
  int drawn = 0, index = 0;
  while (drawn < n) drawn += draw_unit(++index, n - drawn);
  log(fmt("people: %.0f walkers drawn, %.0f placed", n, out_.scene.walkers.size()));
}

RandomScene Generator::run() {
  auto& s = out_.scene;
  s.name = "random";
  s.fps = kFps;
  s.world.has_floor = true;
  s.world.floor_z = 0.0;
  draw_layout();
  draw_clutter();
  build_grid();
  draw_camera();
  draw_people();
  s.description = out_.layout + ", camera " + out_.camera + ", " +
                  std::to_string(s.walkers.size()) + " walkers, " +
                  std::to_string(s.world.boxes.size() - walls_ + s.world.cylinders.size()) +
                  " items (see README.md)";
  return out_;
}

}  // namespace

RandomScene make_random_scene(std::uint64_t seed, int frames) {
  Generator g(seed, frames);
  RandomScene r = g.run();
  r.scene.default_frames = frames;
  return r;
}

std::string random_scene_readme(const RandomScene& r, std::uint64_t seed, int frames) {
  std::string s = "# Generated sequence: seed " + std::to_string(seed) + "\n\n";
  s += "Rebuild: `dynamap-sim random --seed " + std::to_string(seed) + " --frames " +
       std::to_string(frames) + " --out DIR` (30 Hz, realistic sensor).\n\n";
  s += r.scene.description +
       ".\n\nEvery draw, in order (metres, seconds, radians; world z up, "
       "camera starting near x = 1 looking along +x):\n\n";
  for (const auto& d : r.draws) s += "- " + d + "\n";
  return s;
}

}  // namespace dynamap::tools::sim
