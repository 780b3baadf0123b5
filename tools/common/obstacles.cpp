#include "common/obstacles.hpp"

#include <cstdio>
#include <ostream>

#include "common/text_io.hpp"

namespace dynamap::tools {

std::vector<ObstacleRecord> read_obstacles(const std::string& path) {
  const auto lines = read_lines(path);
  std::vector<ObstacleRecord> out;
  for (std::size_t i = 0; i < lines.size(); ++i) {
    const TextLocation at{path, i + 1};
    const std::string body = strip_comment(lines[i]);
    if (body.empty()) continue;
    const auto f = split_ws(body);
    if (f.size() < 12) {
      fail_at(at, "expected 'timestamp id x y z vx vy vz sx sy sz visible', got " +
                      std::to_string(f.size()) + " fields");
    }
    ObstacleRecord r;
    r.stamp = parse_double(f[0], at, "timestamp");
    r.stamp_text = f[0];
    r.id = static_cast<int>(parse_int(f[1], at, "id"));
    r.center = {parse_double(f[2], at, "x"), parse_double(f[3], at, "y"),
                parse_double(f[4], at, "z")};
    r.velocity = {parse_double(f[5], at, "vx"), parse_double(f[6], at, "vy"),
                  parse_double(f[7], at, "vz")};
    r.size = {parse_double(f[8], at, "sx"), parse_double(f[9], at, "sy"),
              parse_double(f[10], at, "sz")};
    r.visible = parse_double(f[11], at, "visible");
    if (r.visible < 0.0 || r.visible > 1.0) fail_at(at, "visible must be in [0, 1]");
    if ((r.size.array() < 0.0).any()) fail_at(at, "sizes must not be negative");
    out.push_back(r);
  }
  return out;
}

void write_obstacles_header(std::ostream& out, const char* what) {
  out << "# " << what << " (world frame, axis-aligned boxes; m, m/s)\n"
      << "# timestamp id x y z vx vy vz sx sy sz visible\n";
}

void write_obstacle_line(std::ostream& out, const ObstacleRecord& r) {
  char buf[320];
  const std::string stamp = r.stamp_text.empty() ? [&] {
    char s[64];
    std::snprintf(s, sizeof(s), "%.6f", r.stamp);
    return std::string(s);
  }()
                                                  : r.stamp_text;
  std::snprintf(buf, sizeof(buf), "%s %d %.4f %.4f %.4f %.4f %.4f %.4f %.3f %.3f %.3f %.4f\n",
                stamp.c_str(), r.id, r.center.x(), r.center.y(), r.center.z(), r.velocity.x(),
                r.velocity.y(), r.velocity.z(), r.size.x(), r.size.y(), r.size.z(), r.visible);
  out << buf;
}

}  // namespace dynamap::tools
