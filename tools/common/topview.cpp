#include "common/topview.hpp"

#include <cairo.h>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>

#include "common/text_io.hpp"

namespace dynamap::tools {
namespace {

struct Rgb {
  double r, g, b;
};
// One colour per kind of thing, used the same way in the legend.
constexpr Rgb kMapCell{0.25, 0.25, 0.28};
constexpr Rgb kStaticFill{0.80, 0.80, 0.84};
constexpr Rgb kStaticEdge{0.45, 0.45, 0.50};
constexpr Rgb kCamera{0.10, 0.35, 0.90};
constexpr Rgb kGroundTruth{0.05, 0.60, 0.20};
constexpr Rgb kTracked{0.95, 0.50, 0.00};
constexpr Rgb kPredicted{0.75, 0.00, 0.75};
constexpr Rgb kLinear{0.45, 0.30, 0.10};
constexpr Rgb kDynamic{0.85, 0.08, 0.08};
constexpr Rgb kStaticTrack{0.15, 0.45, 0.85};
constexpr Rgb kText{0.10, 0.10, 0.10};
constexpr Rgb kGrid{0.90, 0.90, 0.90};
constexpr Rgb kMissingStatic{0.90, 0.05, 0.05};
constexpr Rgb kHeldDynamic{1.00, 0.55, 0.00};

void set(cairo_t* cr, const Rgb& c, double alpha = 1.0) {
  cairo_set_source_rgba(cr, c.r, c.g, c.b, alpha);
}

// World (x right, y up) to picture pixels (y down).
struct Frame {
  Eigen::Vector2d min, max;
  double scale = 50.0;  // px per metre
  double left = 0, top = 0;
  double px(double x) const { return left + (x - min.x()) * scale; }
  double py(double y) const { return top + (max.y() - y) * scale; }
};

void grow(Eigen::Vector2d* lo, Eigen::Vector2d* hi, const Eigen::Vector2d& p) {
  *lo = lo->cwiseMin(p);
  *hi = hi->cwiseMax(p);
}

/// Grid spacing for a span: 0.5 m, then 1, 2, 5 x 10^k m, the first with at most 12 lines, for
/// any finite span (a scene 1e12 m across gets a 1e11 m grid, not 1e10 lines of 100 m).
double nice_step(double span_m) {
  if (span_m / 0.5 <= 12.0) return 0.5;
  double decade = 1.0;
  while (span_m / (10.0 * decade) > 12.0 && decade < 1e300) decade *= 10.0;
  for (double m : {1.0, 2.0, 5.0}) {
    if (span_m / (m * decade) <= 12.0) return m * decade;
  }
  return 10.0 * decade;
}

/// Grid lines (multiples of step) in [lo, hi + tolerance]: an integer count, so the loop ends
/// even where x + step == x in floating point.
template <class F>
void for_each_grid_line(double lo, double hi, double step, double tolerance, F&& f) {
  const double first = std::ceil(lo / step);
  const double last = std::floor((hi + tolerance) / step);
  if (!(first <= last) || last - first > 1000.0) return;  // NaN, or not a nice_step grid
  for (double k = first; k <= last; k += 1.0) f(k * step);
}

void text(cairo_t* cr, double x, double y, const std::string& s, double size, bool bold = false,
          double align = 0.0) {
  cairo_select_font_face(cr, "DejaVu Sans", CAIRO_FONT_SLANT_NORMAL,
                         bold ? CAIRO_FONT_WEIGHT_BOLD : CAIRO_FONT_WEIGHT_NORMAL);
  cairo_set_font_size(cr, size);
  cairo_text_extents_t e;
  cairo_text_extents(cr, s.c_str(), &e);
  cairo_move_to(cr, x - align * e.x_advance, y);
  cairo_show_text(cr, s.c_str());
}

void polyline(cairo_t* cr, const Frame& f, const std::vector<Eigen::Vector2d>& pts) {
  if (pts.size() < 2) return;
  cairo_move_to(cr, f.px(pts[0].x()), f.py(pts[0].y()));
  for (std::size_t i = 1; i < pts.size(); ++i)
    cairo_line_to(cr, f.px(pts[i].x()), f.py(pts[i].y()));
  cairo_stroke(cr);
}

void arrow(cairo_t* cr, double x0, double y0, double x1, double y1, double head) {
  cairo_move_to(cr, x0, y0);
  cairo_line_to(cr, x1, y1);
  cairo_stroke(cr);
  const double a = std::atan2(y1 - y0, x1 - x0);
  if (std::hypot(x1 - x0, y1 - y0) < 1.0) return;
  cairo_move_to(cr, x1, y1);
  cairo_line_to(cr, x1 - head * std::cos(a - 0.45), y1 - head * std::sin(a - 0.45));
  cairo_line_to(cr, x1 - head * std::cos(a + 0.45), y1 - head * std::sin(a + 0.45));
  cairo_close_path(cr);
  cairo_fill(cr);
}

enum class Swatch { kFill, kLine, kDashed, kBox, kDots };

void legend_entry(cairo_t* cr, double x, double y, const Rgb& c, Swatch kind,
                  const std::string& label) {
  set(cr, c);
  cairo_set_line_width(cr, 2.5);
  switch (kind) {
    case Swatch::kFill:
      cairo_rectangle(cr, x, y - 10, 22, 12);
      cairo_fill(cr);
      break;
    case Swatch::kLine:
      cairo_move_to(cr, x, y - 4);
      cairo_line_to(cr, x + 22, y - 4);
      cairo_stroke(cr);
      break;
    case Swatch::kDashed: {
      const double dash[] = {6.0, 4.0};
      cairo_set_dash(cr, dash, 2, 0);
      cairo_move_to(cr, x, y - 4);
      cairo_line_to(cr, x + 22, y - 4);
      cairo_stroke(cr);
      cairo_set_dash(cr, nullptr, 0, 0);
      break;
    }
    case Swatch::kBox:
      set(cr, c, 0.25);
      cairo_rectangle(cr, x + 2, y - 11, 18, 14);
      cairo_fill_preserve(cr);
      set(cr, c);
      cairo_stroke(cr);
      break;
    case Swatch::kDots:
      cairo_move_to(cr, x, y - 4);
      cairo_line_to(cr, x + 22, y - 4);
      cairo_stroke(cr);
      for (int i = 0; i < 3; ++i) {
        cairo_arc(cr, x + 2 + 9 * i, y - 4, 2.5, 0, 2 * M_PI);
        cairo_fill(cr);
      }
      break;
  }
  set(cr, kText);
  text(cr, x + 30, y, label, 13);
}

// Map cells in one colour, with a thin dark outline so a lone cell stands out.
void draw_cells(cairo_t* cr, const Frame& f, const std::vector<Eigen::Vector3d>& cells,
                double cell_px, const Rgb& c) {
  if (cells.empty()) return;
  const double px = std::max(2.0, cell_px);
  cairo_save(cr);
  for (const auto& p : cells) {
    cairo_rectangle(cr, f.px(p.x()) - 0.5 * px, f.py(p.y()) - 0.5 * px, px, px);
  }
  set(cr, c, 0.9);
  cairo_fill_preserve(cr);
  cairo_set_line_width(cr, 0.5);
  set(cr, kText, 0.6);
  cairo_stroke(cr);
  cairo_restore(cr);
}

/// The plot's world rectangle: the scene's fixed bounds, or everything drawn plus a 0.8 m
/// margin (10 m square around the origin when nothing is drawn).
void scene_bounds(const TopViewScene& s, Eigen::Vector2d* lo_out, Eigen::Vector2d* hi_out) {
  Eigen::Vector2d lo = Eigen::Vector2d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector2d hi = -lo;
  if (s.fixed_bounds) {
    *lo_out = s.bounds_min;
    *hi_out = s.bounds_max;
    return;
  }
  for (const auto* cells : {&s.occupied_cells, &s.missing_static_cells, &s.held_dynamic_cells}) {
    for (const auto& c : *cells) grow(&lo, &hi, c.head<2>());
  }
  for (const auto& b : s.static_world.boxes) {
    grow(&lo, &hi, b.min.head<2>());
    grow(&lo, &hi, b.max.head<2>());
  }
  for (const auto& c : s.static_world.cylinders) {
    grow(&lo, &hi, c.center - Eigen::Vector2d::Constant(c.radius));
    grow(&lo, &hi, c.center + Eigen::Vector2d::Constant(c.radius));
  }
  for (const auto* set_of : {&s.obstacles, &s.ground_truth_boxes}) {
    for (const auto& o : *set_of) {
      grow(&lo, &hi, o.center - 0.5 * o.size);
      grow(&lo, &hi, o.center + 0.5 * o.size);
    }
  }
  for (const auto* paths :
       {&s.tracked_paths, &s.ground_truth_paths, &s.predicted_paths, &s.linear_paths}) {
    for (const auto& p : *paths) {
      for (const auto& q : p.points) grow(&lo, &hi, q);
    }
  }
  for (const auto& q : s.camera_trajectory) grow(&lo, &hi, q);
  if (s.show_camera) grow(&lo, &hi, s.camera_position);
  if (!std::isfinite(lo.x())) {
    lo = Eigen::Vector2d(-5, -5);
    hi = Eigen::Vector2d(5, 5);
  }
  *lo_out = lo - Eigen::Vector2d::Constant(0.8);
  *hi_out = hi + Eigen::Vector2d::Constant(0.8);
}

/// Where everything goes on the picture: plot frame and size, grid step, picture size.
struct Layout {
  Frame f;
  Eigen::Vector2d lo, hi;
  int plot_w = 0, plot_h = 0;
  int width = 0, height = 0;
  double step = 1.0;  // grid spacing, m
};

Layout make_layout(const TopViewScene& s, int plot_px) {
  Layout l;
  scene_bounds(s, &l.lo, &l.hi);
  // Finite spans only (coordinates near the double range would make it inf, the scale 0).
  constexpr double kMaxCoordinate = 1e300;
  l.lo = l.lo.cwiseMax(Eigen::Vector2d::Constant(-kMaxCoordinate));
  l.hi = l.hi.cwiseMin(Eigen::Vector2d::Constant(kMaxCoordinate));
  const Eigen::Vector2d span = (l.hi - l.lo).cwiseMax(Eigen::Vector2d::Constant(1.0));
  l.hi = l.lo + span;

  l.f.min = l.lo;
  l.f.max = l.hi;
  l.f.scale = plot_px / std::max(span.x(), span.y());
  l.plot_w = static_cast<int>(std::ceil(span.x() * l.f.scale));
  l.plot_h = static_cast<int>(std::ceil(span.y() * l.f.scale));
  const int margin_left = 70, margin_top = s.subtitle.empty() ? 56 : 78, margin_bottom = 60;
  const int legend_w = 270;
  l.f.left = margin_left;
  l.f.top = margin_top;
  l.width = margin_left + l.plot_w + 20 + legend_w;
  l.height = std::max(margin_top + l.plot_h + margin_bottom, margin_top + 420);
  l.step = nice_step(std::max(span.x(), span.y()));
  return l;
}

// Plot background and grid lines (inside the plot's clip).
void draw_grid(cairo_t* cr, const Layout& l) {
  const Frame& f = l.f;
  cairo_set_source_rgb(cr, 0.985, 0.985, 0.985);
  cairo_paint(cr);
  set(cr, kGrid);
  cairo_set_line_width(cr, 1.0);
  for_each_grid_line(l.lo.x(), l.hi.x(), l.step, 0.0, [&](double x) {
    cairo_move_to(cr, f.px(x), f.top);
    cairo_line_to(cr, f.px(x), f.top + l.plot_h);
  });
  for_each_grid_line(l.lo.y(), l.hi.y(), l.step, 0.0, [&](double y) {
    cairo_move_to(cr, f.left, f.py(y));
    cairo_line_to(cr, f.left + l.plot_w, f.py(y));
  });
  cairo_stroke(cr);
}

// The true static world (floor slabs left out), then the map's cells on top.
void draw_static_world_and_cells(cairo_t* cr, const TopViewScene& s, const Frame& f) {
  cairo_set_line_width(cr, 1.2);
  for (const auto& b : s.static_world.boxes) {
    if (b.max.z() <= s.static_world.floor_z + 0.05) continue;  // floor slabs
    cairo_rectangle(cr, f.px(b.min.x()), f.py(b.max.y()), (b.max.x() - b.min.x()) * f.scale,
                    (b.max.y() - b.min.y()) * f.scale);
    set(cr, kStaticFill);
    cairo_fill_preserve(cr);
    set(cr, kStaticEdge);
    cairo_stroke(cr);
  }
  for (const auto& c : s.static_world.cylinders) {
    cairo_new_sub_path(cr);
    cairo_arc(cr, f.px(c.center.x()), f.py(c.center.y()), c.radius * f.scale, 0, 2 * M_PI);
    set(cr, kStaticFill);
    cairo_fill_preserve(cr);
    set(cr, kStaticEdge);
    cairo_stroke(cr);
  }
  set(cr, kMapCell, 0.85);
  const double cell_px = std::max(1.0, s.cell_size * f.scale);
  for (const auto& c : s.occupied_cells) {
    cairo_rectangle(cr, f.px(c.x()) - 0.5 * cell_px, f.py(c.y()) - 0.5 * cell_px, cell_px, cell_px);
  }
  cairo_fill(cr);
  draw_cells(cr, f, s.missing_static_cells, cell_px, kMissingStatic);
  draw_cells(cr, f, s.held_dynamic_cells, cell_px, kHeldDynamic);
}

// Camera: field of view at the last frame, trajectory (dot: start), position and heading.
void draw_camera(cairo_t* cr, const TopViewScene& s, const Frame& f) {
  if (s.show_camera) {
    const Eigen::Vector2d c = s.camera_position;
    const double r = s.camera_range;
    set(cr, kCamera, 0.10);
    cairo_move_to(cr, f.px(c.x()), f.py(c.y()));
    const int n = 24;
    for (int i = 0; i <= n; ++i) {
      const double a = s.camera_yaw - 0.5 * s.camera_hfov + s.camera_hfov * i / n;
      cairo_line_to(cr, f.px(c.x() + r * std::cos(a)), f.py(c.y() + r * std::sin(a)));
    }
    cairo_close_path(cr);
    cairo_fill_preserve(cr);
    set(cr, kCamera, 0.35);
    cairo_set_line_width(cr, 1.0);
    cairo_stroke(cr);
  }
  if (!s.camera_trajectory.empty()) {
    set(cr, kCamera);
    cairo_set_line_width(cr, 2.5);
    polyline(cr, f, s.camera_trajectory);
    const auto& p0 = s.camera_trajectory.front();
    cairo_arc(cr, f.px(p0.x()), f.py(p0.y()), 4, 0, 2 * M_PI);
    cairo_fill(cr);
  }
  if (s.show_camera) {
    set(cr, kCamera);
    const double x = f.px(s.camera_position.x()), y = f.py(s.camera_position.y());
    cairo_arc(cr, x, y, 6, 0, 2 * M_PI);
    cairo_fill(cr);
    cairo_set_line_width(cr, 2.5);
    arrow(cr, x, y, x + 26 * std::cos(s.camera_yaw), y - 26 * std::sin(s.camera_yaw), 9);
  }
}

// True paths (dashed, dot at the start), tracked paths, then predictions (dots at the samples).
void draw_paths(cairo_t* cr, const TopViewScene& s, const Frame& f) {
  cairo_set_line_cap(cr, CAIRO_LINE_CAP_ROUND);
  cairo_set_line_join(cr, CAIRO_LINE_JOIN_ROUND);
  {
    const double dash[] = {8.0, 5.0};
    cairo_set_dash(cr, dash, 2, 0);
    set(cr, kGroundTruth);
    cairo_set_line_width(cr, 2.0);
    for (const auto& p : s.ground_truth_paths) polyline(cr, f, p.points);
    cairo_set_dash(cr, nullptr, 0, 0);
  }
  set(cr, kTracked);
  cairo_set_line_width(cr, 2.5);
  for (const auto& p : s.tracked_paths) polyline(cr, f, p.points);
  for (const auto* paths : {&s.linear_paths, &s.predicted_paths}) {
    set(cr, paths == &s.predicted_paths ? kPredicted : kLinear);
    cairo_set_line_width(cr, 2.0);
    for (const auto& p : *paths) {
      polyline(cr, f, p.points);
      for (const auto& q : p.points) {
        cairo_arc(cr, f.px(q.x()), f.py(q.y()), 2.2, 0, 2 * M_PI);
        cairo_fill(cr);
      }
    }
  }
  for (const auto& p : s.ground_truth_paths) {
    if (p.points.empty()) continue;
    set(cr, kGroundTruth);
    cairo_arc(cr, f.px(p.points.front().x()), f.py(p.points.front().y()), 3.5, 0, 2 * M_PI);
    cairo_fill(cr);
  }
}

// One obstacle box (filled, or dashed for the truth) with its velocity arrow and label.
void draw_box(cairo_t* cr, const Frame& f, const TopViewObstacle& o, const Rgb& c, bool dashed) {
  const double x0 = f.px(o.center.x() - 0.5 * o.size.x());
  const double y0 = f.py(o.center.y() + 0.5 * o.size.y());
  cairo_rectangle(cr, x0, y0, o.size.x() * f.scale, o.size.y() * f.scale);
  if (dashed) {
    const double dash[] = {4.0, 3.0};
    cairo_set_dash(cr, dash, 2, 0);
  } else {
    set(cr, c, 0.22);
    cairo_fill_preserve(cr);
  }
  set(cr, c);
  cairo_set_line_width(cr, 2.0);
  cairo_stroke(cr);
  cairo_set_dash(cr, nullptr, 0, 0);
  const double cx = f.px(o.center.x()), cy = f.py(o.center.y());
  if (o.velocity.norm() > 0.05) {
    cairo_set_line_width(cr, 2.5);
    arrow(cr, cx, cy, f.px(o.center.x() + o.velocity.x()), f.py(o.center.y() + o.velocity.y()), 9);
  }
  if (!o.label.empty()) {
    set(cr, kText);
    // Right of the box, unless that would run past the plot's right edge: then left of it.
    cairo_select_font_face(cr, "DejaVu Sans", CAIRO_FONT_SLANT_NORMAL, CAIRO_FONT_WEIGHT_NORMAL);
    cairo_set_font_size(cr, 12);
    cairo_text_extents_t e;
    cairo_text_extents(cr, o.label.c_str(), &e);
    const double right = x0 + o.size.x() * f.scale + 4;
    if (right + e.x_advance > f.px(f.max.x())) {
      text(cr, x0 - 4, y0 - 3, o.label, 12, false, 1.0);
    } else {
      text(cr, right, y0 - 3, o.label, 12);
    }
  }
}

// Plot frame, tick labels and axis names.
void draw_axes(cairo_t* cr, const Layout& l) {
  const Frame& f = l.f;
  cairo_set_source_rgb(cr, 0.3, 0.3, 0.3);
  cairo_set_line_width(cr, 1.0);
  cairo_rectangle(cr, f.left + 0.5, f.top + 0.5, l.plot_w, l.plot_h);
  cairo_stroke(cr);
  set(cr, kText);
  char buf[64];
  for_each_grid_line(l.lo.x(), l.hi.x(), l.step, 1e-9, [&](double x) {
    std::snprintf(buf, sizeof(buf), "%g", std::abs(x) < 1e-9 ? 0.0 : x);
    text(cr, f.px(x), f.top + l.plot_h + 16, buf, 11, false, 0.5);
  });
  for_each_grid_line(l.lo.y(), l.hi.y(), l.step, 1e-9, [&](double y) {
    std::snprintf(buf, sizeof(buf), "%g", std::abs(y) < 1e-9 ? 0.0 : y);
    text(cr, f.left - 6, f.py(y) + 4, buf, 11, false, 1.0);
  });
  text(cr, f.left + 0.5 * l.plot_w, f.top + l.plot_h + 34, "x (m)", 13, false, 0.5);
  cairo_save(cr);
  cairo_translate(cr, 22, f.top + 0.5 * l.plot_h);
  cairo_rotate(cr, -M_PI / 2);
  text(cr, 0, 0, "y (m)", 13, false, 0.5);
  cairo_restore(cr);
}

// Scale bar below the plot, left: one grid step long.
void draw_scale_bar(cairo_t* cr, const Layout& l) {
  const Frame& f = l.f;
  const double bar_m = l.step;
  const double x0 = f.left, y0 = f.top + l.plot_h + 50;
  cairo_set_source_rgb(cr, 0, 0, 0);
  cairo_set_line_width(cr, 3.0);
  cairo_move_to(cr, x0, y0);
  cairo_line_to(cr, x0 + bar_m * f.scale, y0);
  cairo_stroke(cr);
  cairo_set_line_width(cr, 1.5);
  for (double xx : {x0, x0 + bar_m * f.scale}) {
    cairo_move_to(cr, xx, y0 - 5);
    cairo_line_to(cr, xx, y0 + 5);
  }
  cairo_stroke(cr);
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%g m  (grid %g m, top view, z up)", bar_m, l.step);
  text(cr, x0 + bar_m * f.scale + 10, y0 + 4, buf, 12);
}

// Legend right of the plot (never hides data): one entry per kind of thing drawn.
void draw_legend(cairo_t* cr, const TopViewScene& s, const Layout& l) {
  const double x = l.f.left + l.plot_w + 24;
  double y = l.f.top + 8;
  set(cr, kText);
  text(cr, x, y + 6, "Legend", 15, true);
  y += 30;
  auto entry = [&](bool present, const Rgb& c, Swatch k, const std::string& label) {
    if (!present) return;
    legend_entry(cr, x, y, c, k, label);
    y += 24;
  };
  entry(!s.occupied_cells.empty(), kMapCell, Swatch::kFill, "occupied map cell");
  entry(!s.missing_static_cells.empty(), kMissingStatic, Swatch::kFill,
        "static voxel seen, not in map");
  entry(!s.held_dynamic_cells.empty(), kHeldDynamic, Swatch::kFill, "walker voxel still in map");
  entry(!s.static_world.boxes.empty() || !s.static_world.cylinders.empty(), kStaticEdge,
        Swatch::kFill, "static world (true)");
  entry(!s.camera_trajectory.empty(), kCamera, Swatch::kLine, "camera path (dot: start)");
  entry(s.show_camera, kCamera, Swatch::kBox, "camera view (last frame)");
  entry(!s.ground_truth_paths.empty(), kGroundTruth, Swatch::kDashed,
        "true obstacle path (dot: start)");
  entry(!s.ground_truth_boxes.empty(), kGroundTruth, Swatch::kDashed, "true obstacle box");
  const bool any_dyn = std::any_of(s.obstacles.begin(), s.obstacles.end(),
                                   [](const TopViewObstacle& o) { return o.dynamic; });
  const bool any_static = std::any_of(s.obstacles.begin(), s.obstacles.end(),
                                      [](const TopViewObstacle& o) { return !o.dynamic; });
  entry(any_dyn, kDynamic, Swatch::kBox, "dynamic obstacle + velocity");
  entry(any_static, kStaticTrack, Swatch::kBox, "obstacle labelled static");
  entry(!s.tracked_paths.empty(), kTracked, Swatch::kLine, "tracked path (history)");
  entry(!s.predicted_paths.empty(), kPredicted, Swatch::kDots, "predicted path (chosen)");
  entry(!s.linear_paths.empty(), kLinear, Swatch::kDots, "linear prediction (baseline)");
  set(cr, kText);
  text(cr, x, y + 10, "Arrows: velocity, length = 1 s", 12);
  text(cr, x, y + 26, "of travel.", 12);
}

}  // namespace

void render_top_view(const TopViewScene& s, const std::string& png_path, int plot_px) {
  const Layout l = make_layout(s, plot_px);
  std::unique_ptr<cairo_surface_t, decltype(&cairo_surface_destroy)> surface(
      cairo_image_surface_create(CAIRO_FORMAT_ARGB32, l.width, l.height), cairo_surface_destroy);
  std::unique_ptr<cairo_t, decltype(&cairo_destroy)> context(cairo_create(surface.get()),
                                                             cairo_destroy);
  cairo_t* cr = context.get();
  cairo_set_source_rgb(cr, 1, 1, 1);
  cairo_paint(cr);

  set(cr, kText);
  text(cr, l.f.left, 32, s.title, 20, true);
  if (!s.subtitle.empty()) text(cr, l.f.left, 56, s.subtitle, 14);

  // Everything in world coordinates is clipped to the plot area.
  cairo_save(cr);
  cairo_rectangle(cr, l.f.left, l.f.top, l.plot_w, l.plot_h);
  cairo_clip(cr);
  draw_grid(cr, l);
  draw_static_world_and_cells(cr, s, l.f);
  draw_camera(cr, s, l.f);
  draw_paths(cr, s, l.f);
  for (const auto& o : s.ground_truth_boxes) draw_box(cr, l.f, o, kGroundTruth, true);
  for (const auto& o : s.obstacles)
    draw_box(cr, l.f, o, o.dynamic ? kDynamic : kStaticTrack, false);
  cairo_restore(cr);

  draw_axes(cr, l);
  draw_scale_bar(cr, l);
  draw_legend(cr, s, l);

  cairo_surface_flush(surface.get());
  if (cairo_surface_write_to_png(surface.get(), png_path.c_str()) != CAIRO_STATUS_SUCCESS) {
    throw ToolError(png_path + ": cannot write picture");
  }
}

void render_depth_preview(const Image16& depth, double depth_factor, double max_depth,
                          const std::string& caption, const std::string& png_path) {
  const int caption_h = 28;
  std::unique_ptr<cairo_surface_t, decltype(&cairo_surface_destroy)> surface(
      cairo_image_surface_create(CAIRO_FORMAT_RGB24, depth.width, depth.height + caption_h),
      cairo_surface_destroy);
  cairo_surface_flush(surface.get());
  unsigned char* data = cairo_image_surface_get_data(surface.get());
  const int stride = cairo_image_surface_get_stride(surface.get());
  for (int v = 0; v < depth.height; ++v) {
    auto* row = reinterpret_cast<std::uint32_t*>(data + static_cast<std::ptrdiff_t>(v) * stride);
    for (int u = 0; u < depth.width; ++u) {
      const std::uint16_t d = depth.at(u, v);
      if (d == 0) {
        row[u] = 0x500000u;
        continue;
      }
      const double m = d / depth_factor;
      const auto g =
          static_cast<std::uint32_t>(std::clamp(255.0 * (1.0 - m / max_depth), 20.0, 255.0));
      row[u] = (g << 16) | (g << 8) | g;
    }
  }
  cairo_surface_mark_dirty(surface.get());
  std::unique_ptr<cairo_t, decltype(&cairo_destroy)> context(cairo_create(surface.get()),
                                                             cairo_destroy);
  cairo_t* cr = context.get();
  cairo_set_source_rgb(cr, 1, 1, 1);
  cairo_rectangle(cr, 0, depth.height, depth.width, caption_h);
  cairo_fill(cr);
  set(cr, kText);
  text(cr, 8, depth.height + 19, caption, 13);
  if (cairo_surface_write_to_png(surface.get(), png_path.c_str()) != CAIRO_STATUS_SUCCESS) {
    throw ToolError(png_path + ": cannot write picture");
  }
}

}  // namespace dynamap::tools
