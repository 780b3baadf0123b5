#include "overlay/overlay.hpp"

#include <cairo.h>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <unordered_map>

#include "common/text_io.hpp"

namespace dynamap::tools::overlay {

// ------------------------------------------------------------------------ detections.csv ----

std::vector<DetectionRow> read_detections_csv(const std::string& path) {
  const std::vector<std::string> lines = read_lines(path);
  std::size_t header = 0;
  while (header < lines.size() && strip_comment(lines[header]).empty()) ++header;
  if (header == lines.size()) fail_at({path, 0}, "empty file (no header line)");
  std::map<std::string, std::size_t> column;
  const auto names = split_csv(lines[header]);
  for (std::size_t i = 0; i < names.size(); ++i) column[names[i]] = i;
  for (const char* name : {"stamp", "u0", "v0", "u1", "v1"}) {
    if (column.count(name) == 0) {
      fail_at({path, header + 1}, std::string("header has no column '") + name + "'");
    }
  }
  std::vector<DetectionRow> rows;
  for (std::size_t i = header + 1; i < lines.size(); ++i) {
    if (strip_comment(lines[i]).empty()) continue;
    const TextLocation at{path, i + 1};
    const auto fields = split_csv(lines[i]);
    if (fields.size() < names.size()) {
      fail_at(at, "expected " + std::to_string(names.size()) + " fields, got " +
                      std::to_string(fields.size()));
    }
    // Optional columns read as 0 when the header lacks them.
    auto num = [&](const char* name) {
      const auto it = column.find(name);
      return it == column.end() ? 0.0 : parse_double(fields[it->second], at, name);
    };
    DetectionRow r;
    r.stamp = num("stamp");
    r.stamp_text = fields[column.at("stamp")];
    r.index = static_cast<int>(num("index"));
    r.center = {num("x"), num("y"), num("z")};
    r.size = {num("sx"), num("sy"), num("sz")};
    r.u0 = num("u0");
    r.v0 = num("v0");
    r.u1 = num("u1");
    r.v1 = num("v1");
    r.refined = num("refined") != 0.0;
    rows.push_back(r);
  }
  return rows;
}

// ------------------------------------------------------------------- projection, colours ----

namespace {

Eigen::Vector3d to_camera(const PoseD& pose, const Eigen::Vector3d& world) {
  return pose.rotation.conjugate() * (world - pose.translation);
}

}  // namespace

bool project_box(const CameraModel& camera, const PoseD& pose, const Eigen::Vector3d& center,
                 const Eigen::Vector3d& size, PixelRect* out, double min_z) {
  Eigen::Vector3d corner[8];
  for (int i = 0; i < 8; ++i) {
    const Eigen::Vector3d sign((i & 1) ? 0.5 : -0.5, (i & 2) ? 0.5 : -0.5, (i & 4) ? 0.5 : -0.5);
    corner[i] = to_camera(pose, center + sign.cwiseProduct(size));
  }
  double u0 = std::numeric_limits<double>::infinity(), v0 = u0, u1 = -u0, v1 = -u0;
  bool any = false;
  auto add = [&](const Eigen::Vector3d& p) {
    const double u = camera.fx * p.x() / p.z() + camera.cx;
    const double v = camera.fy * p.y() / p.z() + camera.cy;
    u0 = std::min(u0, u);
    u1 = std::max(u1, u);
    v0 = std::min(v0, v);
    v1 = std::max(v1, v);
    any = true;
  };
  // The part of a convex box in front of the plane z = min_z has as vertices the corners in
  // front and the points where edges cross the plane: cutting the 12 edges finds them all.
  for (int i = 0; i < 8; ++i) {
    for (int bit : {1, 2, 4}) {
      if (i & bit) continue;
      Eigen::Vector3d a = corner[i], b = corner[i | bit];
      if (a.z() < min_z && b.z() < min_z) continue;
      if (a.z() < min_z) a += (b - a) * ((min_z - a.z()) / (b.z() - a.z()));
      if (b.z() < min_z) b += (a - b) * ((min_z - b.z()) / (a.z() - b.z()));
      add(a);
      add(b);
    }
  }
  if (!any) return false;
  if (u1 < 0 || v1 < 0 || u0 > camera.width || v0 > camera.height) return false;
  *out = {u0, v0, u1, v1};
  return true;
}

bool project_motion(const CameraModel& camera, const PoseD& pose, const Eigen::Vector3d& center,
                    const Eigen::Vector3d& velocity, double seconds, Eigen::Vector2d* from,
                    Eigen::Vector2d* to, double min_z) {
  const Eigen::Vector3d a = to_camera(pose, center);
  const Eigen::Vector3d b =
      to_camera(pose, center + seconds * Eigen::Vector3d(velocity.x(), velocity.y(), 0.0));
  if (a.z() < min_z || b.z() < min_z) return false;
  *from = {camera.fx * a.x() / a.z() + camera.cx, camera.fy * a.y() / a.z() + camera.cy};
  *to = {camera.fx * b.x() / b.z() + camera.cx, camera.fy * b.y() / b.z() + camera.cy};
  return true;
}

Rgb8 depth_colour(double metres, double near_m, double far_m) {
  if (!(metres > 0.0)) return kNoDepthColour;
  // Logarithmic: people at 1-4 m get most of the colour range, and a ratio of distances looks
  // the same everywhere. Colours a little muted so the bright overlay lines stand out.
  const double t = std::clamp(std::log(metres / near_m) / std::log(far_m / near_m), 0.0, 1.0);
  struct Stop {
    double t;
    double r, g, b;
  };
  static constexpr Stop kStops[] = {
      {0.00, 200, 30, 30},   // red
      {0.22, 225, 110, 25},  // orange
      {0.42, 215, 190, 50},  // yellow
      {0.60, 80, 170, 120},  // teal green
      {0.80, 45, 105, 190},  // blue
      {1.00, 30, 35, 110},   // dark blue
  };
  std::size_t k = 1;
  while (k + 1 < std::size(kStops) && t > kStops[k].t) ++k;
  const Stop& a = kStops[k - 1];
  const Stop& b = kStops[k];
  const double w = std::clamp((t - a.t) / (b.t - a.t), 0.0, 1.0);
  auto mix = [w](double x, double y) {
    return static_cast<std::uint8_t>(std::lround(x + w * (y - x)));
  };
  return {mix(a.r, b.r), mix(a.g, b.g), mix(a.b, b.b)};
}

// ------------------------------------------------------------------------------ analysis ----

namespace {

double top_distance(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return (a.head<2>() - b.head<2>()).norm();
}

}  // namespace

FrameAnalysis analyse_frame(const OverlayFrame& frame, const OverlayOptions& o) {
  FrameAnalysis a;
  a.false_dynamic.assign(frame.tracks.size(), false);
  // A frame the replay never reached has no tracks: judging it would call every person missed.
  const bool judge = frame.has_reference && !frame.after_result;
  for (std::size_t i = 0; i < frame.tracks.size(); ++i) {
    const TrackRow& t = frame.tracks[i];
    if (!t.dynamic) {
      ++a.static_tracks;
      continue;
    }
    ++a.dynamic_tracks;
    if (!judge) continue;
    // Like dynamap-eval's precision: near any listed obstacle, counted or not, is right.
    const bool near =
        std::any_of(frame.reference.begin(), frame.reference.end(), [&](const ObstacleRecord& r) {
          return top_distance(r.center, t.center) <= o.match_radius;
        });
    if (!near) {
      a.false_dynamic[i] = true;
      ++a.false_dynamic_count;
    }
  }
  for (const ObstacleRecord& r : frame.reference) {
    const double depth = to_camera(frame.pose, r.center).z();
    const bool counted = judge && r.velocity.norm() >= o.moving_speed &&
                         r.visible >= o.min_visible && depth >= o.min_depth && depth <= o.max_depth;
    if (!counted) {
      a.reference.push_back(ReferenceKind::kOther);
      continue;
    }
    ++a.reference_people;
    const bool found =
        std::any_of(frame.tracks.begin(), frame.tracks.end(), [&](const TrackRow& t) {
          return t.dynamic && top_distance(r.center, t.center) <= o.match_radius;
        });
    a.reference.push_back(found ? ReferenceKind::kPerson : ReferenceKind::kMissed);
    if (!found) ++a.missed;
  }
  return a;
}

// ------------------------------------------------------------------------------- drawing ----

namespace {

struct Rgb {
  double r, g, b;
};
// One colour per kind of thing, the same in pictures, sheet and legend.
constexpr Rgb kDetection{0.95, 0.95, 0.95};
constexpr Rgb kDynamic{1.00, 0.12, 0.12};
constexpr Rgb kStatic{0.30, 0.60, 1.00};
constexpr Rgb kFalse{1.00, 0.25, 1.00};
constexpr Rgb kReference{0.25, 0.95, 0.35};
constexpr Rgb kMissed{1.00, 0.72, 0.00};
constexpr Rgb kText{0.10, 0.10, 0.10};
constexpr Rgb kMissedText{0.85, 0.45, 0.00};  // readable on white
constexpr Rgb kFalseText{0.75, 0.00, 0.75};
constexpr Rgb kQuiet{0.55, 0.55, 0.55};

void set(cairo_t* cr, const Rgb& c, double alpha = 1.0) {
  cairo_set_source_rgba(cr, c.r, c.g, c.b, alpha);
}

using Surface = std::unique_ptr<cairo_surface_t, decltype(&cairo_surface_destroy)>;
using Context = std::unique_ptr<cairo_t, decltype(&cairo_destroy)>;

Surface make_surface(int w, int h) {
  return Surface(cairo_image_surface_create(CAIRO_FORMAT_RGB24, w, h), cairo_surface_destroy);
}

void write_png(cairo_surface_t* s, const std::string& path) {
  cairo_surface_flush(s);
  if (cairo_surface_write_to_png(s, path.c_str()) != CAIRO_STATUS_SUCCESS) {
    throw ToolError(path + ": cannot write picture");
  }
}

double text_width(cairo_t* cr, const std::string& s, double size, bool bold) {
  cairo_select_font_face(cr, "DejaVu Sans", CAIRO_FONT_SLANT_NORMAL,
                         bold ? CAIRO_FONT_WEIGHT_BOLD : CAIRO_FONT_WEIGHT_NORMAL);
  cairo_set_font_size(cr, size);
  cairo_text_extents_t e;
  cairo_text_extents(cr, s.c_str(), &e);
  return e.x_advance;
}

// Draws text with its baseline at y; returns the x after it. align 0 left, 1 right.
double text(cairo_t* cr, double x, double y, const std::string& s, double size, bool bold = false,
            double align = 0.0) {
  const double w = text_width(cr, s, size, bold);
  cairo_move_to(cr, x - align * w, y);
  cairo_show_text(cr, s.c_str());
  return x - align * w + w;
}

// The colour-mapped depth image (or a dark "no data" image) as a surface of the image's size.
Surface depth_surface(const OverlayFrame& f, const CameraModel& cam, const OverlayOptions& o) {
  Surface s = make_surface(cam.width, cam.height);
  cairo_surface_flush(s.get());
  unsigned char* data = cairo_image_surface_get_data(s.get());
  const int stride = cairo_image_surface_get_stride(s.get());
  const bool ok = f.depth_ok && f.depth.width == cam.width && f.depth.height == cam.height;
  for (int v = 0; v < cam.height; ++v) {
    auto* row = reinterpret_cast<std::uint32_t*>(data + static_cast<std::ptrdiff_t>(v) * stride);
    for (int u = 0; u < cam.width; ++u) {
      const Rgb8 c = ok ? depth_colour(f.depth.at(u, v) / cam.depth_factor, o.near_m, o.far_m)
                        : kNoDepthColour;
      row[u] = (std::uint32_t{c.r} << 16) | (std::uint32_t{c.g} << 8) | c.b;
    }
  }
  cairo_surface_mark_dirty(s.get());
  return s;
}

// How big things are drawn: full pictures (scale 1, labels) or thumbnails (no labels).
struct Style {
  double scale = 1.0;   // picture pixels per image pixel
  double x = 0, y = 0;  // top-left of the image in the picture
  double line = 1.0;    // line width multiplier
  bool labels = true;
};

void stroke_rect(cairo_t* cr, double x0, double y0, double x1, double y1, const Rgb& c,
                 double width, double dash, double halo = 0.75) {
  cairo_rectangle(cr, x0, y0, x1 - x0, y1 - y0);
  // A dark halo under every line keeps it visible on any colour of the depth map.
  cairo_set_source_rgba(cr, 0, 0, 0, halo);
  cairo_set_line_width(cr, width + 2.0);
  cairo_stroke_preserve(cr);
  if (dash > 0) {
    const double d[] = {dash, 0.7 * dash};
    cairo_set_dash(cr, d, 2, 0);
  }
  set(cr, c);
  cairo_set_line_width(cr, width);
  cairo_stroke(cr);
  cairo_set_dash(cr, nullptr, 0, 0);
}

// Labels on dark plates, moved up or down past the ones already placed so none hides another.
class LabelPlacer {
 public:
  LabelPlacer(cairo_t* cr, double x0, double y0, double x1, double y1)
      : cr_(cr), x0_(x0), y0_(y0), x1_(x1), y1_(y1) {}

  // `top` is where the plate's top edge would like to be.
  void place(double x, double top, const std::string& s, const Rgb& c, double size, bool bold) {
    const double w = text_width(cr_, s, size, bold) + 6, h = size + 5;
    x = std::clamp(x, x0_ + 1, std::max(x0_ + 1, x1_ - w - 1));
    double best = std::clamp(top, y0_, y1_ - h);
    for (int k = 0; k < 9; ++k) {
      const int step = (k + 1) / 2 * (k % 2 ? -1 : 1);  // 0, -1, +1, -2, +2, ...
      const double t = std::clamp(top + step * (h + 1), y0_, y1_ - h);
      if (free(x, t, w, h)) {
        best = t;
        break;
      }
    }
    placed_.push_back({x, best, w, h});
    cairo_set_source_rgba(cr_, 0, 0, 0, 0.72);
    cairo_rectangle(cr_, x, best, w, h);
    cairo_fill(cr_);
    set(cr_, c);
    text(cr_, x + 3, best + size, s, size, bold);
  }

 private:
  bool free(double x, double y, double w, double h) const {
    for (const auto& r : placed_) {
      if (x < r[0] + r[2] && r[0] < x + w && y < r[1] + r[3] && r[1] < y + h) return false;
    }
    return true;
  }
  cairo_t* cr_;
  double x0_, y0_, x1_, y1_;
  std::vector<std::array<double, 4>> placed_;  // x, y, w, h
};

// How far ahead the velocity arrows reach: long enough to read a 0.3 m/s error 3 m away (the
// legend says "0.5 s").
constexpr double kArrowSeconds = 0.5;

void arrow(cairo_t* cr, double x0, double y0, double x1, double y1, const Rgb& c, double width) {
  const double len = std::hypot(x1 - x0, y1 - y0);
  if (len < 1e-6) return;
  const double ux = (x1 - x0) / len, uy = (y1 - y0) / len, head = std::min(10.0, 0.4 * len);
  for (int halo = 1; halo >= 0; --halo) {  // dark halo first, like every other line
    if (halo) {
      cairo_set_source_rgba(cr, 0, 0, 0, 0.6);
    } else {
      set(cr, c);
    }
    cairo_set_line_width(cr, width + 2.0 * halo);
    cairo_move_to(cr, x0, y0);
    cairo_line_to(cr, x1, y1);
    cairo_move_to(cr, x1 - head * (ux - 0.5 * uy), y1 - head * (uy + 0.5 * ux));
    cairo_line_to(cr, x1, y1);
    cairo_line_to(cr, x1 - head * (ux + 0.5 * uy), y1 - head * (uy - 0.5 * ux));
    cairo_stroke(cr);
  }
}

// A counted person's true motion and each dynamic track's, kArrowSeconds ahead from the box
// centre, so a wrong direction shows at a glance (full-size frames only: thumbnails are small).
void draw_velocity_arrows(cairo_t* cr, const OverlayFrame& f, const FrameAnalysis& a,
                          const CameraModel& cam, const Style& st) {
  // The truth is drawn wider and first, so where the two agree it shows as a green rim.
  auto draw = [&](const Eigen::Vector3d& center, const Eigen::Vector3d& velocity, const Rgb& c,
                  double width) {
    Eigen::Vector2d from, to;
    if (!project_motion(cam, f.pose, center, velocity, kArrowSeconds, &from, &to)) return;
    // Pixel centres are at integer projection coordinates, as in draw_view.
    arrow(cr, st.x + (from.x() + 0.5) * st.scale, st.y + (from.y() + 0.5) * st.scale,
          st.x + (to.x() + 0.5) * st.scale, st.y + (to.y() + 0.5) * st.scale, c, width * st.line);
  };
  for (std::size_t i = 0; i < f.reference.size() && i < a.reference.size(); ++i) {
    if (a.reference[i] != ReferenceKind::kOther) {
      draw(f.reference[i].center, f.reference[i].velocity, kReference, 4.0);
    }
  }
  for (const TrackRow& t : f.tracks) {
    if (t.dynamic) draw(t.center, t.velocity, kDynamic, 2.0);
  }
}

std::string speed_text(const Eigen::Vector3d& v) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.1f m/s", v.norm());
  return buf;
}

// Pixel centres are at integer projection coordinates; picture pixels cover [u, u+1).
double view_x(const Style& st, double u) {
  return st.x + (u + 0.5) * st.scale;
}
double view_y(const Style& st, double v) {
  return st.y + (v + 0.5) * st.scale;
}

// A box's label plate: drawn last, over every line, in priority order.
struct Plate {
  double x, top;  // preferred top-left of the plate
  std::string text;
  Rgb colour;
  bool bold;
  int priority;  // placed in this order: missed, false dynamic, dynamic, static
};
constexpr double kPlateFont = 13;
constexpr double kPlateHeight = kPlateFont + 5;

// The depth image scaled into the view ("depth missing" written over it when it was not read).
void draw_depth(cairo_t* cr, const OverlayFrame& f, const CameraModel& cam, const OverlayOptions& o,
                const Style& st, double w, double h) {
  {
    Surface img = depth_surface(f, cam, o);
    cairo_save(cr);
    cairo_translate(cr, st.x, st.y);
    cairo_scale(cr, st.scale, st.scale);
    cairo_set_source_surface(cr, img.get(), 0, 0);
    cairo_pattern_set_filter(cairo_get_source(cr),
                             st.scale < 1.0 ? CAIRO_FILTER_GOOD : CAIRO_FILTER_NEAREST);
    cairo_paint(cr);
    cairo_restore(cr);
  }
  if (!f.depth_ok) {
    set(cr, {0.85, 0.85, 0.85});
    text(cr, st.x + 0.5 * w, st.y + 0.88 * h, "depth missing", st.labels ? 28 : 14, true, 0.5);
  }
}

// The detector's image boxes (inclusive pixel bounds: the rectangle covers pixels u0..u1).
void draw_detection_boxes(cairo_t* cr, const OverlayFrame& f, const Style& st) {
  for (const DetectionRow& d : f.detections) {
    stroke_rect(cr, st.x + d.u0 * st.scale, st.y + d.v0 * st.scale, st.x + (d.u1 + 1) * st.scale,
                st.y + (d.v1 + 1) * st.scale, kDetection, 1.0 * st.line, 0, 0.5);
  }
}

// Reference people counted (solid) and listed but not counted (faint, dashed); the missed
// ones are drawn later, over the tracks.
void draw_reference_boxes(cairo_t* cr, const OverlayFrame& f, const FrameAnalysis& a,
                          const CameraModel& cam, const Style& st) {
  const double lw = st.line;
  for (std::size_t i = 0; i < f.reference.size(); ++i) {
    const ObstacleRecord& r = f.reference[i];
    const ReferenceKind kind = i < a.reference.size() ? a.reference[i] : ReferenceKind::kOther;
    if (kind == ReferenceKind::kOther && r.visible <= 0.0) continue;
    PixelRect pr;
    if (!project_box(cam, f.pose, r.center, r.size, &pr)) continue;
    const double x0 = view_x(st, pr.u0), y0 = view_y(st, pr.v0);
    const double x1 = view_x(st, pr.u1), y1 = view_y(st, pr.v1);
    if (kind == ReferenceKind::kOther) {
      // Listed but not counted (slow, mostly hidden or out of range): faint, never "missed".
      cairo_save(cr);
      const double d[] = {2.0 * lw, 3.0 * lw};
      cairo_set_dash(cr, d, 2, 0);
      set(cr, kReference, 0.6);
      cairo_set_line_width(cr, 1.2 * lw);
      cairo_rectangle(cr, x0, y0, x1 - x0, y1 - y0);
      cairo_stroke(cr);
      cairo_restore(cr);
    } else if (kind == ReferenceKind::kPerson) {
      stroke_rect(cr, x0, y0, x1, y1, kReference, 2.0 * lw, 7 * lw);
    }
  }
}

// Track boxes, static ones first and light, so the dynamic ones stay on top and catch the eye;
// their labels go to `plates`.
void draw_track_boxes(cairo_t* cr, const OverlayFrame& f, const FrameAnalysis& a,
                      const CameraModel& cam, const Style& st, std::vector<Plate>& plates) {
  const double lw = st.line;
  for (int pass = 0; pass < 2; ++pass) {
    for (std::size_t i = 0; i < f.tracks.size(); ++i) {
      const TrackRow& t = f.tracks[i];
      if (t.dynamic != (pass == 1)) continue;
      PixelRect pr;
      if (!project_box(cam, f.pose, t.center, t.size, &pr)) continue;
      const bool false_dyn = i < a.false_dynamic.size() && a.false_dynamic[i];
      const Rgb c = false_dyn ? kFalse : t.dynamic ? kDynamic : kStatic;
      const double width = (false_dyn ? 3.5 : t.dynamic ? 2.5 : 1.4) * lw;
      stroke_rect(cr, view_x(st, pr.u0), view_y(st, pr.v0), view_x(st, pr.u1), view_y(st, pr.v1), c,
                  width, 0, t.dynamic ? 0.75 : 0.45);
      std::string label = std::to_string(t.id);
      if (t.dynamic) label += "  " + speed_text(t.velocity);
      if (false_dyn) label = "FALSE DYN " + label;
      // Above the box; inside its top when the box starts at the image's top edge.
      double top = view_y(st, pr.v0) - kPlateHeight - 1;
      if (top < st.y) top = std::max(view_y(st, pr.v0), st.y) + 2;
      plates.push_back({view_x(st, pr.u0), top, label, c, t.dynamic,
                        false_dyn   ? 1
                        : t.dynamic ? 2
                                    : 3});
    }
  }
}

// Missed people: they matter most and must not hide under a track's box; their labels go to
// `plates`. h: the view's height.
void draw_missed_boxes(cairo_t* cr, const OverlayFrame& f, const FrameAnalysis& a,
                       const CameraModel& cam, const Style& st, double h,
                       std::vector<Plate>& plates) {
  const double lw = st.line;
  for (std::size_t i = 0; i < f.reference.size() && i < a.reference.size(); ++i) {
    if (a.reference[i] != ReferenceKind::kMissed) continue;
    const ObstacleRecord& r = f.reference[i];
    PixelRect pr;
    if (!project_box(cam, f.pose, r.center, r.size, &pr)) continue;
    stroke_rect(cr, view_x(st, pr.u0), view_y(st, pr.v0), view_x(st, pr.u1), view_y(st, pr.v1),
                kMissed, 4.0 * lw, 10 * lw);
    // Below the box (track labels go above); inside its bottom when it reaches the image's.
    double top = view_y(st, pr.v1) + 3;
    if (top + kPlateHeight > st.y + h)
      top = std::min(view_y(st, pr.v1), st.y + h) - kPlateHeight - 4;
    plates.push_back({view_x(st, pr.u0), top,
                      "MISSED ref " + std::to_string(r.id) + "  " + speed_text(r.velocity), kMissed,
                      true, 0});
  }
}

// The image with every overlay, at st.scale with its top-left at (st.x, st.y).
void draw_view(cairo_t* cr, const OverlayFrame& f, const FrameAnalysis& a, const CameraModel& cam,
               const OverlayOptions& o, const Style& st) {
  const double w = cam.width * st.scale, h = cam.height * st.scale;
  cairo_save(cr);
  cairo_rectangle(cr, st.x, st.y, w, h);
  cairo_clip(cr);
  draw_depth(cr, f, cam, o, st, w, h);
  std::vector<Plate> plates;  // drawn last, over every line
  draw_detection_boxes(cr, f, st);
  draw_reference_boxes(cr, f, a, cam, st);
  draw_track_boxes(cr, f, a, cam, st, plates);
  if (st.labels) draw_velocity_arrows(cr, f, a, cam, st);
  draw_missed_boxes(cr, f, a, cam, st, h, plates);
  if (st.labels) {
    std::stable_sort(plates.begin(), plates.end(),
                     [](const Plate& x, const Plate& y) { return x.priority < y.priority; });
    LabelPlacer placer(cr, st.x, st.y, st.x + w, st.y + h);
    for (const Plate& l : plates) placer.place(l.x, l.top, l.text, l.colour, kPlateFont, l.bold);
  }
  cairo_restore(cr);
}

enum class Swatch { kSolid, kDashed, kFaint, kThickDashed, kThick, kArrow };

void legend_swatch(cairo_t* cr, double x, double y, const Rgb& c, Swatch kind) {
  // A small box like the ones in the image, on a dark square so light colours read on white.
  cairo_set_source_rgb(cr, 0.22, 0.22, 0.25);
  cairo_rectangle(cr, x, y - 12, 26, 16);
  cairo_fill(cr);
  switch (kind) {
    case Swatch::kSolid:
      stroke_rect(cr, x + 5, y - 8, x + 21, y, c, 2.0, 0);
      break;
    case Swatch::kThick:
      stroke_rect(cr, x + 5, y - 8, x + 21, y, c, 3.0, 0);
      break;
    case Swatch::kDashed:
      stroke_rect(cr, x + 5, y - 8, x + 21, y, c, 2.0, 4);
      break;
    case Swatch::kThickDashed:
      stroke_rect(cr, x + 5, y - 8, x + 21, y, c, 3.0, 5);
      break;
    case Swatch::kArrow:
      arrow(cr, x + 4, y - 4, x + 22, y - 4, c, 2.0);
      break;
    case Swatch::kFaint: {
      const double d[] = {2.0, 3.0};
      cairo_set_dash(cr, d, 2, 0);
      set(cr, c, 0.7);
      cairo_set_line_width(cr, 1.2);
      cairo_rectangle(cr, x + 5, y - 8, 16, 8);
      cairo_stroke(cr);
      cairo_set_dash(cr, nullptr, 0, 0);
      break;
    }
  }
}

struct LegendItem {
  Rgb colour;
  Swatch swatch;
  std::string label;
};

std::vector<LegendItem> legend_items(bool reference, bool detections, bool arrows) {
  std::vector<LegendItem> items;
  if (detections) items.push_back({kDetection, Swatch::kSolid, "detection (image box)"});
  items.push_back({kDynamic, Swatch::kSolid, "dynamic track: id, speed"});
  if (arrows) items.push_back({kDynamic, Swatch::kArrow, "its motion in 0.5 s"});
  items.push_back({kStatic, Swatch::kSolid, "static track: id"});
  if (reference) {
    items.push_back({kFalse, Swatch::kThick, "FALSE DYN: no reference near"});
    items.push_back({kReference, Swatch::kDashed, "reference person (counted)"});
    if (arrows) items.push_back({kReference, Swatch::kArrow, "its true motion in 0.5 s"});
    items.push_back({kMissed, Swatch::kThickDashed, "MISSED: no dynamic track near"});
    items.push_back({kReference, Swatch::kFaint, "reference, not counted"});
  }
  return items;
}

// Vertical colour bar with metre ticks; (x, y) top-left.
void colour_bar_vertical(cairo_t* cr, double x, double y, double bar_h, const OverlayOptions& o) {
  const double bar_w = 18;
  for (int i = 0; i < static_cast<int>(bar_h); ++i) {
    const double t = (i + 0.5) / bar_h;  // top = near
    const double m = o.near_m * std::pow(o.far_m / o.near_m, t);
    const Rgb8 c = depth_colour(m, o.near_m, o.far_m);
    cairo_set_source_rgb(cr, c.r / 255.0, c.g / 255.0, c.b / 255.0);
    cairo_rectangle(cr, x, y + i, bar_w, 1.0);
    cairo_fill(cr);
  }
  cairo_set_source_rgb(cr, 0.3, 0.3, 0.3);
  cairo_set_line_width(cr, 1.0);
  cairo_rectangle(cr, x + 0.5, y + 0.5, bar_w - 1, bar_h - 1);
  cairo_stroke(cr);
  set(cr, kText);
  for (double m : {0.3, 0.5, 1.0, 2.0, 3.0, 5.0, 8.0}) {
    if (m < o.near_m - 1e-9 || m > o.far_m + 1e-9) continue;
    const double yy = y + bar_h * std::log(m / o.near_m) / std::log(o.far_m / o.near_m);
    cairo_move_to(cr, x + bar_w, yy);
    cairo_line_to(cr, x + bar_w + 5, yy);
    cairo_stroke(cr);
    char buf[16];
    std::snprintf(buf, sizeof(buf), "%g m", m);
    text(cr, x + bar_w + 8, yy + 4, buf, 12);
  }
  const Rgb8 n = kNoDepthColour;
  cairo_set_source_rgb(cr, n.r / 255.0, n.g / 255.0, n.b / 255.0);
  cairo_rectangle(cr, x, y + bar_h + 10, bar_w, 14);
  cairo_fill(cr);
  set(cr, kText);
  text(cr, x + bar_w + 8, y + bar_h + 21, "no depth", 12);
}

// Coloured runs of text on one line ("missed 2" orange when non-zero, ...).
struct Run {
  std::string s;
  Rgb c;
  bool bold;
};
double runs(cairo_t* cr, double x, double y, const std::vector<Run>& rs, double size) {
  for (const Run& r : rs) {
    set(cr, r.c);
    x = text(cr, x, y, r.s, size, r.bold);
  }
  return x;
}

std::vector<Run> count_runs(const OverlayFrame& f, const FrameAnalysis& a, bool long_form) {
  std::vector<Run> rs;
  auto n = [](int v) { return std::to_string(v); };
  if (long_form) {
    rs.push_back({"dynamic tracks " + n(a.dynamic_tracks) + "   static " + n(a.static_tracks) +
                      "   detections " + n(static_cast<int>(f.detections.size())),
                  kText, false});
  }
  if (f.after_result) {
    rs.push_back({long_form ? "   (not replayed: nothing judged)" : "not replayed", kQuiet, false});
    return rs;
  }
  if (!f.has_reference) {
    if (long_form) rs.push_back({"   (no reference: nothing judged)", kText, false});
    return rs;
  }
  if (long_form)
    rs.push_back({"   reference people " + n(a.reference_people) + "   ", kText, false});
  // Zeros grey, so the eye finds the non-zero counts.
  rs.push_back({"missed " + n(a.missed), a.missed > 0 ? kMissedText : kQuiet, a.missed > 0});
  rs.push_back({"   false dyn " + n(a.false_dynamic_count),
                a.false_dynamic_count > 0 ? kFalseText : kQuiet, a.false_dynamic_count > 0});
  return rs;
}

std::string frame_title(const OverlayFrame& f) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), "frame %zu", f.index);
  return buf;
}

// Layout of the pictures.
constexpr int kPanelWidth = 250;      // colour bar and legend right of the image
constexpr int kCaptionHeight = 54;    // two lines under the image
constexpr int kMinFrameHeight = 560;  // room for the legend under the colour bar
constexpr int kTileWidth = 208;       // six columns fit a README at about 1300 px
constexpr int kTileGap = 4, kSheetMargin = 10, kTileCaption = 17, kSheetHeader = 92;

int tile_height(const CameraModel& cam) {
  return static_cast<int>(std::lround(cam.height * static_cast<double>(kTileWidth) / cam.width));
}

}  // namespace

PictureSize frame_picture_size(const CameraModel& cam) {
  return {cam.width + kPanelWidth, std::max(cam.height + kCaptionHeight, kMinFrameHeight)};
}

PictureSize contact_sheet_size(const CameraModel& cam, std::size_t tiles, int columns) {
  columns = std::max(1, columns);
  const int rows = static_cast<int>((tiles + columns - 1) / columns);
  return {2 * kSheetMargin + columns * kTileWidth + (columns - 1) * kTileGap,
          kSheetHeader + rows * (tile_height(cam) + kTileCaption + kTileGap) + kSheetMargin};
}

void render_overlay_frame(const OverlayFrame& f, const CameraModel& cam, const OverlayOptions& o,
                          const std::string& png_path) {
  const FrameAnalysis a = analyse_frame(f, o);
  const PictureSize size = frame_picture_size(cam);
  Surface s = make_surface(size.width, size.height);
  Context ctx(cairo_create(s.get()), cairo_destroy);
  cairo_t* cr = ctx.get();
  cairo_set_source_rgb(cr, 1, 1, 1);
  cairo_paint(cr);

  Style st;
  draw_view(cr, f, a, cam, o, st);

  // Caption: which frame, then the counts.
  set(cr, kText);
  double x = text(cr, 8, cam.height + 21, frame_title(f), 15, true);
  std::string when = "   t " + f.stamp_text;
  if (f.after_result) when += "   after the result's last stamp";
  if (!f.depth_ok) when += "   depth missing";
  text(cr, x, cam.height + 21, when, 13);
  runs(cr, 8, cam.height + 43, count_runs(f, a, true), 13);

  // Right panel: colour bar, then the legend.
  const double px0 = cam.width + 16;
  set(cr, kText);
  text(cr, px0, 22, "depth", 14, true);
  colour_bar_vertical(cr, px0, 32, 200, o);
  double y = 300;
  text(cr, px0, y, "boxes", 14, true);
  y += 24;
  for (const LegendItem& item : legend_items(f.has_reference, !f.detections.empty(), true)) {
    legend_swatch(cr, px0, y, item.colour, item.swatch);
    set(cr, kText);
    text(cr, px0 + 32, y, item.label, 11.5);
    y += 22;
  }
  write_png(s.get(), png_path);
}

// The sheet's legend on one line (short labels: the sheet is one README-wide picture), then a
// near -> far colour bar with a few ticks, filling what is left of the line.
void draw_sheet_legend(cairo_t* cr, const std::vector<OverlayFrame>& tiles, const OverlayOptions& o,
                       int margin, int width) {
  bool any_ref = false, any_det = false;
  for (const auto& t : tiles) {
    any_ref = any_ref || t.has_reference;
    any_det = any_det || !t.detections.empty();
  }
  double x = margin;
  const double ly = 70;
  for (const LegendItem& item : legend_items(any_ref, any_det, false)) {
    std::string label = item.label.substr(0, item.label.find(':'));
    if (label == "reference, not counted") label = "ref. not counted";
    if (label == "reference person (counted)") label = "reference person";
    if (label == "detection (image box)") label = "detection";
    legend_swatch(cr, x, ly, item.colour, item.swatch);
    set(cr, kText);
    x = text(cr, x + 30, ly, label, 11.5) + 14;
  }
  const double bar_x = x + 4, bar_w = std::max(60.0, width - margin - 40 - bar_x), bar_h = 10;
  if (bar_x + bar_w > width) return;
  for (int i = 0; i < static_cast<int>(bar_w); ++i) {
    const double m = o.near_m * std::pow(o.far_m / o.near_m, (i + 0.5) / bar_w);
    const Rgb8 c = depth_colour(m, o.near_m, o.far_m);
    cairo_set_source_rgb(cr, c.r / 255.0, c.g / 255.0, c.b / 255.0);
    cairo_rectangle(cr, bar_x + i, ly - 16, 1.0, bar_h);
    cairo_fill(cr);
  }
  set(cr, kText);
  for (double m : {0.5, 1.0, 2.0, 4.0, 8.0}) {
    if (m < o.near_m || m > o.far_m) continue;
    const double xx = bar_x + bar_w * std::log(m / o.near_m) / std::log(o.far_m / o.near_m);
    char buf[16];
    std::snprintf(buf, sizeof(buf), "%g", m);
    text(cr, std::min(xx, bar_x + bar_w - 4.0), ly + 6, buf, 10, false, 0.5);
  }
  text(cr, bar_x + bar_w + 6, ly - 7, "m", 11);
}

// A frame around a tile with a missed person (orange) or a false dynamic track (magenta, inside
// the orange one): the sheet's problem frames show from across the room. Then the caption:
// "#index" left, the counts (or the dynamic tracks without a reference) right.
void draw_tile_marks(cairo_t* cr, const OverlayFrame& f, const FrameAnalysis& a, const Style& st,
                     int tile_w, int tile_h) {
  double inset = 1.5;
  for (const auto& [bad, colour] :
       {std::pair{a.missed > 0, kMissed}, {a.false_dynamic_count > 0, kFalse}}) {
    if (!bad) continue;
    set(cr, colour);
    cairo_set_line_width(cr, 3.0);
    cairo_rectangle(cr, st.x + inset, st.y + inset, tile_w - 2 * inset, tile_h - 2 * inset);
    cairo_stroke(cr);
    inset += 3.0;
  }
  const double cy = st.y + tile_h + 13;
  set(cr, kText);
  text(cr, st.x + 2, cy, "#" + std::to_string(f.index), 11.5, true);
  if (f.has_reference || f.after_result) {
    std::vector<Run> rs = count_runs(f, a, false);
    for (auto& r : rs) r.s = r.s.substr(r.s.find_first_not_of(' '));
    // Right-aligned: "missed N  false dyn M".
    double w = 0;
    for (std::size_t i = 0; i < rs.size(); ++i) {
      if (i > 0) rs[i].s = "  " + rs[i].s;
      w += text_width(cr, rs[i].s, 11, rs[i].bold);
    }
    runs(cr, st.x + tile_w - 2 - w, cy, rs, 11);
  } else {
    std::string dyn = "dynamic " + std::to_string(a.dynamic_tracks);
    set(cr, kText);
    text(cr, st.x + tile_w - 2, cy, dyn, 11, false, 1.0);
  }
}

void render_contact_sheet(const std::vector<OverlayFrame>& tiles, const CameraModel& cam,
                          const OverlayOptions& o, const std::string& title,
                          const std::string& summary, const std::string& png_path, int columns) {
  columns = std::max(1, columns);
  const int tile_w = kTileWidth, tile_h = tile_height(cam);
  const double scale = static_cast<double>(tile_w) / cam.width;
  const int gap = kTileGap, margin = kSheetMargin, tile_caption = kTileCaption;
  const int header_h = kSheetHeader;
  const PictureSize size = contact_sheet_size(cam, tiles.size(), columns);
  Surface s = make_surface(size.width, size.height);
  Context ctx(cairo_create(s.get()), cairo_destroy);
  cairo_t* cr = ctx.get();
  cairo_set_source_rgb(cr, 1, 1, 1);
  cairo_paint(cr);

  set(cr, kText);
  text(cr, margin, 26, title, 19, true);
  text(cr, margin, 46, summary, 12.5);
  draw_sheet_legend(cr, tiles, o, margin, size.width);

  for (std::size_t k = 0; k < tiles.size(); ++k) {
    const OverlayFrame& f = tiles[k];
    const FrameAnalysis a = analyse_frame(f, o);
    const std::size_t row = k / columns, column = k % columns;  // row-major tiles
    Style st;
    st.scale = scale;
    st.x = margin + static_cast<double>(column) * (tile_w + gap);
    st.y = header_h + static_cast<double>(row) * (tile_h + tile_caption + gap);
    st.line = 0.8;
    st.labels = false;
    draw_view(cr, f, a, cam, o, st);
    draw_tile_marks(cr, f, a, st, tile_w, tile_h);
  }
  write_png(s.get(), png_path);
}

// ---------------------------------------------------------------------------------- run ----

namespace {

template <class Row>
std::unordered_map<std::int64_t, std::vector<Row>> by_stamp(const std::vector<Row>& rows) {
  std::unordered_map<std::int64_t, std::vector<Row>> m;
  for (const Row& r : rows) m[stamp_key(r.stamp)].push_back(r);
  return m;
}

template <class Row>
std::vector<Row> at(const std::unordered_map<std::int64_t, std::vector<Row>>& m, std::int64_t key) {
  const auto it = m.find(key);
  return it == m.end() ? std::vector<Row>{} : it->second;
}

std::string base_name(const std::string& path) {
  std::filesystem::path p(path);
  while (!p.empty() && p.filename().empty()) p = p.parent_path();  // trailing '/'
  return p.filename().string();
}

std::string percent(std::size_t part, std::size_t whole) {
  if (whole == 0) return "";
  char buf[32];
  std::snprintf(buf, sizeof(buf), " (%.1f %%)", 100.0 * part / whole);
  return buf;
}

void say(const RunOptions& o, const std::string& line) {
  if (o.progress) o.progress(line);
}

// The result and reference rows by stamp, and the last stamp the replay reached.
struct RunInputs {
  std::unordered_map<std::int64_t, std::vector<TrackRow>> tracks;
  std::unordered_map<std::int64_t, std::vector<DetectionRow>> detections;
  std::unordered_map<std::int64_t, std::vector<ObstacleRecord>> reference;
  std::int64_t last_result = std::numeric_limits<std::int64_t>::min();
};

// tracks.csv, timing.csv (it has a row for every frame the replay processed, even one without
// any track, so it tells best where a replay stopped), detections.csv when present and the
// reference (--reference, else SEQ/obstacles.txt when it exists).
RunInputs read_inputs(const RunOptions& o, RunSummary& sum) {
  RunInputs in;
  in.tracks = by_stamp(read_tracks_csv(join_path(o.result_dir, "tracks.csv")));
  for (const auto& kv : in.tracks) in.last_result = std::max(in.last_result, kv.first);
  const std::string timing_path = join_path(o.result_dir, "timing.csv");
  if (file_exists(timing_path)) {
    const std::vector<std::string> lines = read_lines(timing_path);
    for (std::size_t i = 1; i < lines.size(); ++i) {
      if (strip_comment(lines[i]).empty()) continue;
      const auto fields = split_csv(lines[i]);
      in.last_result = std::max(in.last_result,
                                stamp_key(parse_double(fields[0], {timing_path, i + 1}, "stamp")));
    }
  }
  const std::string det_path = join_path(o.result_dir, "detections.csv");
  if (file_exists(det_path)) {
    sum.has_detections = true;
    in.detections = by_stamp(read_detections_csv(det_path));
    for (const auto& kv : in.detections) in.last_result = std::max(in.last_result, kv.first);
  }
  sum.reference_path = o.reference;
  if (sum.reference_path.empty() && file_exists(join_path(o.seq, "obstacles.txt"))) {
    sum.reference_path = join_path(o.seq, "obstacles.txt");
  }
  if (!sum.reference_path.empty()) {
    sum.has_reference = true;
    in.reference = by_stamp(read_obstacles(sum.reference_path));
  }
  return in;
}

// The frames of the run: their rows (cheap: used for the totals over every frame), and with the
// depth image for the pictures (a depth image that cannot be read is counted once and named).
class FrameSource {
 public:
  FrameSource(const Sequence& seq, const RunInputs& in, const RunOptions& o, std::size_t n,
              RunSummary& sum)
      : seq_(seq), in_(in), o_(o), sum_(sum), depth_counted_(n, false) {}

  OverlayFrame rows(std::size_t i) const {
    const SequenceFrame& sf = seq_.frames[i];
    const std::int64_t key = stamp_key(sf.stamp);
    OverlayFrame f;
    f.index = i;
    f.stamp_text = sf.stamp_text;
    f.pose = sf.pose;
    f.has_reference = sum_.has_reference;
    f.after_result =
        in_.last_result != std::numeric_limits<std::int64_t>::min() && key > in_.last_result;
    f.tracks = at(in_.tracks, key);
    f.detections = at(in_.detections, key);
    f.reference = at(in_.reference, key);
    return f;
  }

  OverlayFrame with_depth(std::size_t i) {
    OverlayFrame f = rows(i);
    try {
      f.depth = load_depth(seq_, seq_.frames[i]);
      f.depth_ok = true;
    } catch (const ToolError& e) {
      if (!depth_counted_[i]) {
        depth_counted_[i] = true;
        ++sum_.depth_missing;
        if (sum_.depth_errors.size() < 5) sum_.depth_errors.push_back(e.what());
        say(o_, std::string("frame ") + std::to_string(i) +
                    ": depth missing, drawn without: " + e.what());
      }
    }
    return f;
  }

 private:
  const Sequence& seq_;
  const RunInputs& in_;
  const RunOptions& o_;
  RunSummary& sum_;
  std::vector<bool> depth_counted_;
};

// Missed people and false dynamic tracks over every considered frame, and per frame.
void count_totals(const Sequence& seq, const FrameSource& frames, std::size_t n,
                  const RunOptions& o, RunSummary& sum) {
  sum.missed_per_frame.assign(n, 0);
  sum.false_per_frame.assign(n, 0);
  for (std::size_t i = 0; i < n; ++i) {
    const OverlayFrame f = frames.rows(i);
    const FrameAnalysis a = analyse_frame(f, o.overlay);
    sum.reference_people += a.reference_people;
    sum.missed += a.missed;
    sum.dynamic_tracks += a.dynamic_tracks;
    sum.false_dynamic += a.false_dynamic_count;
    sum.missed_per_frame[i] = a.missed;
    sum.false_per_frame[i] = a.false_dynamic_count;
    sum.frames_after_result += f.after_result ? 1 : 0;
    sum.depth_files_missing += file_exists(seq.frames[i].depth_path) ? 0 : 1;
  }
}

// The contact sheet's second line: frames shown and the totals.
std::string sheet_summary(const RunSummary& sum, std::size_t n, std::size_t count) {
  std::string line = std::to_string(n) + " frames, " + std::to_string(count) + " shown";
  if (count > 1 && count < n)
    line += " (about every " + std::to_string((n - 1) / (count - 1)) + ")";
  line += "   ";
  if (sum.has_reference) {
    line += "reference people: " + std::to_string(sum.reference_people) +
            " person-frames, missed " + std::to_string(sum.missed) +
            percent(sum.missed, sum.reference_people) + "   dynamic track-frames " +
            std::to_string(sum.dynamic_tracks) + ", false dynamic " +
            std::to_string(sum.false_dynamic) + percent(sum.false_dynamic, sum.dynamic_tracks);
  } else {
    line += "dynamic track-frames " + std::to_string(sum.dynamic_tracks) +
            "   no reference: missed / false dynamic not judged";
  }
  return line;
}

// The contact sheet: thumbnails evenly spread over the whole run, in full rows.
void write_contact_sheet(const RunOptions& o, const CameraModel& cam, std::size_t n,
                         FrameSource& frames, const std::string& out_dir, RunSummary& sum) {
  const std::size_t columns = static_cast<std::size_t>(std::max(1, o.sheet_columns));
  const std::size_t wanted =
      (static_cast<std::size_t>(std::max(1, o.sheet_tiles)) + columns - 1) / columns * columns;
  const std::size_t count = std::min(n, wanted);
  std::vector<OverlayFrame> tiles;
  for (std::size_t k = 0; k < count; ++k) {
    const std::size_t i =
        count == 1 ? 0
                   : static_cast<std::size_t>(std::llround(static_cast<double>(k) * (n - 1) /
                                                           static_cast<double>(count - 1)));
    tiles.push_back(frames.with_depth(i));
  }
  sum.tiles = tiles.size();
  std::string title = "dynamap-overlay: " + base_name(o.seq) + "  /  " + base_name(o.result_dir);
  const std::string sheet = join_path(out_dir, "contact_sheet.png");
  render_contact_sheet(tiles, cam, o.overlay, title, sheet_summary(sum, n, count), sheet,
                       static_cast<int>(columns));
  sum.written.push_back(sheet);
  say(o, "contact sheet (" + std::to_string(count) + " tiles) -> " + sheet);
}

}  // namespace

RunSummary run_overlay(const RunOptions& o) {
  RunSummary sum;
  const Sequence seq = read_sequence(o.seq);
  if (seq.frames.empty()) throw ToolError(o.seq + ": no depth image has a pose; nothing to draw");
  const CameraModel& cam = seq.camera;
  const std::size_t n = o.max_frames >= 0
                            ? std::min(seq.frames.size(), static_cast<std::size_t>(o.max_frames))
                            : seq.frames.size();
  if (n == 0) throw ToolError("--max-frames 0: nothing to draw");
  sum.frames = n;
  const RunInputs inputs = read_inputs(o, sum);
  const std::string out_dir = o.out_dir.empty() ? join_path(o.result_dir, "overlay") : o.out_dir;
  make_directories(out_dir, "cannot create the output directory");

  FrameSource frames(seq, inputs, o, n, sum);
  count_totals(seq, frames, n, o, sum);
  if (o.every > 0) {
    for (std::size_t i = 0; i < n; i += static_cast<std::size_t>(o.every)) {
      char name[32];
      std::snprintf(name, sizeof(name), "frame_%05zu.png", i);
      const std::string path = join_path(out_dir, name);
      render_overlay_frame(frames.with_depth(i), cam, o.overlay, path);
      ++sum.pictures;
      sum.written.push_back(path);
      say(o, "frame " + std::to_string(i) + "/" + std::to_string(n) + " -> " + path);
    }
  }
  write_contact_sheet(o, cam, n, frames, out_dir, sum);
  return sum;
}

}  // namespace dynamap::tools::overlay
