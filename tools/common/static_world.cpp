#include "common/static_world.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>

#include "common/text_io.hpp"

namespace dynamap::tools {

double StaticWorld::top_view_distance(const Eigen::Vector2d& p, double zlo, double zhi) const {
  double best = std::numeric_limits<double>::infinity();
  for (const auto& b : boxes) {
    if (b.max.z() <= zlo || b.min.z() >= zhi) continue;
    const double dx = std::max({b.min.x() - p.x(), 0.0, p.x() - b.max.x()});
    const double dy = std::max({b.min.y() - p.y(), 0.0, p.y() - b.max.y()});
    best = std::min(best, std::hypot(dx, dy));
  }
  for (const auto& c : cylinders) {
    if (c.zmax <= zlo || c.zmin >= zhi) continue;
    best = std::min(best, std::max(0.0, (p - c.center).norm() - c.radius));
  }
  return best;
}

StaticWorld read_static_world(const std::string& path) {
  const auto lines = read_lines(path);
  StaticWorld w;
  for (std::size_t i = 0; i < lines.size(); ++i) {
    const TextLocation at{path, i + 1};
    const std::string body = strip_comment(lines[i]);
    if (body.empty()) continue;
    const auto f = split_ws(body);
    if (f[0] == "floor") {
      if (f.size() < 2) fail_at(at, "expected 'floor z'");
      w.has_floor = true;
      w.floor_z = parse_double(f[1], at, "z");
    } else if (f[0] == "box") {
      if (f.size() < 7) fail_at(at, "expected 'box xmin ymin zmin xmax ymax zmax'");
      StaticBox b;
      b.min = {parse_double(f[1], at, "xmin"), parse_double(f[2], at, "ymin"),
               parse_double(f[3], at, "zmin")};
      b.max = {parse_double(f[4], at, "xmax"), parse_double(f[5], at, "ymax"),
               parse_double(f[6], at, "zmax")};
      if ((b.max.array() < b.min.array()).any()) fail_at(at, "box max must be >= min");
      b.dark = f.size() > 7 && f[7] == "dark";
      w.boxes.push_back(b);
    } else if (f[0] == "cylinder") {
      if (f.size() < 6) fail_at(at, "expected 'cylinder cx cy radius zmin zmax'");
      StaticCylinder c;
      c.center = {parse_double(f[1], at, "cx"), parse_double(f[2], at, "cy")};
      c.radius = parse_double(f[3], at, "radius");
      c.zmin = parse_double(f[4], at, "zmin");
      c.zmax = parse_double(f[5], at, "zmax");
      if (c.radius <= 0 || c.zmax < c.zmin) fail_at(at, "bad cylinder radius or height");
      c.dark = f.size() > 6 && f[6] == "dark";
      w.cylinders.push_back(c);
    } else {
      fail_at(at, "unknown shape '" + f[0] + "' (expected floor, box or cylinder)");
    }
  }
  return w;
}

void write_static_world(const std::string& path, const StaticWorld& w) {
  std::ofstream out(path);
  if (!out) throw ToolError(path + ": cannot create file");
  out << "# static world geometry (world frame, metres, z up)\n"
      << "# floor z\n# box xmin ymin zmin xmax ymax zmax [dark]\n"
      << "# cylinder cx cy radius zmin zmax [dark]\n";
  char buf[256];
  if (w.has_floor) {
    std::snprintf(buf, sizeof(buf), "floor %.4f\n", w.floor_z);
    out << buf;
  }
  for (const auto& b : w.boxes) {
    std::snprintf(buf, sizeof(buf), "box %.4f %.4f %.4f %.4f %.4f %.4f%s\n", b.min.x(), b.min.y(),
                  b.min.z(), b.max.x(), b.max.y(), b.max.z(), b.dark ? " dark" : "");
    out << buf;
  }
  for (const auto& c : w.cylinders) {
    std::snprintf(buf, sizeof(buf), "cylinder %.4f %.4f %.4f %.4f %.4f%s\n", c.center.x(),
                  c.center.y(), c.radius, c.zmin, c.zmax, c.dark ? " dark" : "");
    out << buf;
  }
  if (!out) throw ToolError(path + ": write error");
}

}  // namespace dynamap::tools
