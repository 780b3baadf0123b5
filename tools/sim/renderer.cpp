#include "sim/renderer.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace dynamap::tools::sim {
namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();
constexpr float kEps = 1e-4f;

struct BoxPrim {
  Eigen::Vector3f min, max;
};
struct CylPrim {
  float cx, cy, r, zmin, zmax;
};

// Ray o + t*d (d has camera-z component 1, so t is the depth). Returns t of the entry point or
// +inf. Rays starting inside the box see nothing of it.
inline float hit_box(const Eigen::Vector3f& o, const Eigen::Vector3f& d, const BoxPrim& b) {
  float t0 = -kInf, t1 = kInf;
  for (int a = 0; a < 3; ++a) {
    if (std::fabs(d[a]) < 1e-12f) {
      if (o[a] < b.min[a] || o[a] > b.max[a]) return kInf;
      continue;
    }
    const float inv = 1.0f / d[a];
    float ta = (b.min[a] - o[a]) * inv, tb = (b.max[a] - o[a]) * inv;
    if (ta > tb) std::swap(ta, tb);
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb);
  }
  return (t0 <= t1 && t0 > kEps) ? t0 : kInf;
}

inline float hit_cylinder(const Eigen::Vector3f& o, const Eigen::Vector3f& d, const CylPrim& c) {
  float best = kInf;
  const float fx = o.x() - c.cx, fy = o.y() - c.cy;
  const float a = d.x() * d.x() + d.y() * d.y();
  if (a > 1e-12f) {
    const float b = 2.0f * (fx * d.x() + fy * d.y());
    const float cc = fx * fx + fy * fy - c.r * c.r;
    const float disc = b * b - 4.0f * a * cc;
    if (disc >= 0.0f) {
      const float t = (-b - std::sqrt(disc)) / (2.0f * a);
      if (t > kEps) {
        const float z = o.z() + t * d.z();
        if (z >= c.zmin && z <= c.zmax) best = t;
      }
    }
  }
  if (std::fabs(d.z()) > 1e-12f) {
    for (float zc : {c.zmin, c.zmax}) {
      const float t = (zc - o.z()) / d.z();
      if (t > kEps && t < best) {
        const float px = fx + t * d.x(), py = fy + t * d.y();
        if (px * px + py * py <= c.r * c.r) best = t;
      }
    }
  }
  return best;
}

// Pixel rectangle [u0,u1) x [v0,v1) covering the projection of an axis-aligned box, within
// the given limits; the whole limit when a corner is (nearly) behind the camera.
struct Rect {
  int u0, v0, u1, v1;
};
Rect project_bounds(const Eigen::Vector3f& lo, const Eigen::Vector3f& hi, const Eigen::Matrix3f& Rt,
                    const Eigen::Vector3f& o, const CameraModel& cam, const Rect& limit) {
  float umin = kInf, vmin = kInf, umax = -kInf, vmax = -kInf;
  for (int i = 0; i < 8; ++i) {
    const Eigen::Vector3f corner((i & 1) ? hi.x() : lo.x(), (i & 2) ? hi.y() : lo.y(),
                                 (i & 4) ? hi.z() : lo.z());
    const Eigen::Vector3f pc = Rt * (corner - o);
    if (pc.z() < 0.05f) return limit;
    const float u = static_cast<float>(cam.fx) * pc.x() / pc.z() + static_cast<float>(cam.cx);
    const float v = static_cast<float>(cam.fy) * pc.y() / pc.z() + static_cast<float>(cam.cy);
    umin = std::min(umin, u);
    umax = std::max(umax, u);
    vmin = std::min(vmin, v);
    vmax = std::max(vmax, v);
  }
  Rect r;
  r.u0 = std::max(limit.u0, static_cast<int>(std::floor(umin)) - 1);
  r.v0 = std::max(limit.v0, static_cast<int>(std::floor(vmin)) - 1);
  r.u1 = std::min(limit.u1, static_cast<int>(std::ceil(umax)) + 2);
  r.v1 = std::min(limit.v1, static_cast<int>(std::ceil(vmax)) + 2);
  return r;
}

// Standard normal from one 64-bit hash (Box-Muller on its two 32-bit halves).
inline double gaussian(std::uint64_t h) {
  const double u1 = (static_cast<double>(h >> 32) + 0.5) * (1.0 / 4294967296.0);
  const double u2 = (static_cast<double>(h & 0xFFFFFFFFull) + 0.5) * (1.0 / 4294967296.0);
  return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * M_PI * u2);
}
inline double unit(std::uint64_t h) {
  return static_cast<double>(h >> 11) * (1.0 / 9007199254740992.0);
}

// Uniform [0, 1) from the high and the low 32 bits of a hash.
inline double unit_hi(std::uint64_t h) {
  return static_cast<double>(h >> 32) * (1.0 / 4294967296.0);
}
inline double unit_lo(std::uint64_t h) {
  return static_cast<double>(h & 0xFFFFFFFFull) * (1.0 / 4294967296.0);
}

constexpr std::uint64_t kDarkJitterSalt = 0xDA5C0FFEEull;
constexpr std::uint64_t kDarkCellSalt = 0xDA5CE11ull;
constexpr std::uint64_t kDarkDrawSalt = 0xDA5D4A3ull;

// 2-D coordinates of a surface point in the object's own frame: a box face's two in-plane axes
// (face = which of the 6 faces), a cylinder's unrolled mantle (arc length, height).
Eigen::Vector2d surface_coordinates(const StaticWorld& world, int surface, const Eigen::Vector3d& p,
                                    int* face) {
  const int nb = static_cast<int>(world.boxes.size());
  if (surface < nb) {
    const auto& b = world.boxes[static_cast<std::size_t>(surface)];
    double best = std::numeric_limits<double>::infinity();
    int axis = 0;
    for (int a = 0; a < 3; ++a) {
      for (int side = 0; side < 2; ++side) {
        const double d = std::fabs(p[a] - (side == 0 ? b.min[a] : b.max[a]));
        if (d < best) {
          best = d;
          axis = a;
          *face = 2 * a + side;
        }
      }
    }
    return {p[(axis + 1) % 3], p[(axis + 2) % 3]};
  }
  const auto& c = world.cylinders[static_cast<std::size_t>(surface - nb)];
  const Eigen::Vector2d r = p.head<2>() - c.center;
  *face = 6;
  return {std::atan2(r.y(), r.x()) * c.radius, p.z()};
}

// Dark or shiny surface: the stereo matcher fails in patches. The surface (in its own
// coordinates) is divided into irregular cells, the Voronoi cells of one random site per
// `dark_patch` m square; each cell is lost with probability `dark_dropout`, redrawn every
// `dark_period` frames at its own phase. The lookup point is jittered by up to 0.08 cell per
// pixel and frame, so patch borders are ragged and flicker.
bool lost_on_dark_surface(const StaticWorld& world, int surface, const Eigen::Vector3d& p,
                          const DepthNoise& nz, std::uint64_t seed, std::uint64_t frame,
                          std::uint64_t pix) {
  int face = 0;
  Eigen::Vector2d g = surface_coordinates(world, surface, p, &face) / nz.dark_patch;
  const std::uint64_t jitter = hash3(seed ^ kDarkJitterSalt, frame, pix);
  g += 0.16 * Eigen::Vector2d(unit_hi(jitter) - 0.5, unit_lo(jitter) - 0.5);
  const std::uint64_t shape =
      static_cast<std::uint64_t>(surface) * 8 + static_cast<std::uint64_t>(face);
  const double fa = std::floor(g.x()), fb = std::floor(g.y());
  std::uint64_t cell = 0;
  double best = std::numeric_limits<double>::infinity();
  for (int da = -1; da <= 1; ++da) {
    for (int db = -1; db <= 1; ++db) {
      const auto ia = static_cast<std::int64_t>(fa) + da, ib = static_cast<std::int64_t>(fb) + db;
      const std::uint64_t id =
          hash3(seed ^ kDarkCellSalt, shape,
                hash3(static_cast<std::uint64_t>(ia), static_cast<std::uint64_t>(ib), 0));
      const Eigen::Vector2d site(fa + da + unit_hi(id), fb + db + unit_lo(id));
      const double d = (site - g).squaredNorm();
      if (d < best) {
        best = d;
        cell = id;
      }
    }
  }
  const auto period = static_cast<std::uint64_t>(std::max(1, nz.dark_period));
  const std::uint64_t epoch = (frame + cell % period) / period;
  return unit(hash3(seed ^ kDarkDrawSalt, epoch, cell)) < nz.dark_dropout;
}

// Static geometry into the range/id buffers; `surface` receives the static shape index per
// pixel (boxes, then cylinders; -1 floor).
void render_static(const Scene& scene, const CameraModel& cam, const Eigen::Matrix3f& Rt,
                   const Eigen::Vector3f& o, const std::vector<Eigen::Vector3f>& dirs,
                   RenderedFrame* out, std::vector<int>* surface) {
  const int W = cam.width;
  const Rect image{0, 0, W, cam.height};
  if (scene.world.has_floor && o.z() > static_cast<float>(scene.world.floor_z)) {
    const float fz = static_cast<float>(scene.world.floor_z);
    for (std::size_t i = 0; i < dirs.size(); ++i) {
      if (dirs[i].z() < -1e-9f) {
        out->range[i] = (fz - o.z()) / dirs[i].z();
        out->id[i] = -1;
      }
    }
  }
  int index = 0;
  auto shape = [&](const Eigen::Vector3f& lo, const Eigen::Vector3f& hi, auto hit) {
    const Rect r = project_bounds(lo, hi, Rt, o, cam, image);
    for (int v = r.v0; v < r.v1; ++v) {
      for (int u = r.u0; u < r.u1; ++u) {
        const std::size_t i = static_cast<std::size_t>(v) * W + u;
        const float t = hit(dirs[i]);
        if (t < out->range[i]) {
          out->range[i] = t;
          out->id[i] = -1;
          (*surface)[i] = index;
        }
      }
    }
    ++index;
  };
  for (const auto& b : scene.world.boxes) {
    const BoxPrim p{b.min.cast<float>(), b.max.cast<float>()};
    shape(p.min, p.max, [&](const Eigen::Vector3f& d) { return hit_box(o, d, p); });
  }
  for (const auto& c : scene.world.cylinders) {
    const CylPrim p{static_cast<float>(c.center.x()), static_cast<float>(c.center.y()),
                    static_cast<float>(c.radius), static_cast<float>(c.zmin),
                    static_cast<float>(c.zmax)};
    shape({p.cx - p.r, p.cy - p.r, p.zmin}, {p.cx + p.r, p.cy + p.r, p.zmax},
          [&](const Eigen::Vector3f& d) { return hit_cylinder(o, d, p); });
  }
}

// Walkers into the range/id buffers (clearing `surface`), with each one's projected area
// counted on a canvas three times the image, and the visible fractions.
void render_walkers(const Scene& scene, const CameraModel& cam, const Eigen::Matrix3f& Rt,
                    const Eigen::Vector3f& o, const std::vector<Eigen::Vector3f>& dirs,
                    const std::vector<WalkerState>& walkers, std::size_t nw, RenderedFrame* out,
                    std::vector<int>* surface) {
  const int W = cam.width, H = cam.height;
  const Eigen::Matrix3f R = Rt.transpose();
  const float fx = static_cast<float>(cam.fx), fy = static_cast<float>(cam.fy);
  const float cx = static_cast<float>(cam.cx), cy = static_cast<float>(cam.cy);
  auto ray = [&](int u, int v) {
    return Eigen::Vector3f(R * Eigen::Vector3f((static_cast<float>(u) - cx) / fx,
                                               (static_cast<float>(v) - cy) / fy, 1.0f));
  };
  out->visible.assign(walkers.size(), 0.0);
  out->visible_pixels.assign(walkers.size(), 0);
  out->projected_pixels.assign(walkers.size(), 0);
  const Rect canvas{-W, -H, 2 * W, 2 * H};  // for the projected area, also outside the image
  for (std::size_t k = 0; k < nw; ++k) {
    const auto& w = walkers[k];
    const CylPrim p{static_cast<float>(w.position.x()), static_cast<float>(w.position.y()),
                    static_cast<float>(w.radius), static_cast<float>(scene.world.floor_z),
                    static_cast<float>(scene.world.floor_z + w.height)};
    const Rect r = project_bounds({p.cx - p.r, p.cy - p.r, p.zmin},
                                  {p.cx + p.r, p.cy + p.r, p.zmax}, Rt, o, cam, canvas);
    long alone = 0;
    for (int v = r.v0; v < r.v1; ++v) {
      for (int u = r.u0; u < r.u1; ++u) {
        const bool inside = u >= 0 && u < W && v >= 0 && v < H;
        const std::size_t i = inside ? static_cast<std::size_t>(v) * W + u : 0;
        const float t = hit_cylinder(o, inside ? dirs[i] : ray(u, v), p);
        if (t == kInf) continue;
        ++alone;
        if (inside && t < out->range[i]) {
          out->range[i] = t;
          out->id[i] = static_cast<int>(k);
          (*surface)[i] = -1;
        }
      }
    }
    out->projected_pixels[k] = alone;
  }
  for (std::size_t i = 0; i < out->id.size(); ++i) {
    if (out->id[i] >= 0) ++out->visible_pixels[static_cast<std::size_t>(out->id[i])];
  }
  for (std::size_t k = 0; k < nw; ++k) {
    out->visible[k] = out->projected_pixels[k] > 0
                          ? static_cast<double>(out->visible_pixels[k]) / out->projected_pixels[k]
                          : 0.0;
  }
}

// Depth edges at pixel (u, v) of depth z: `background` if a 4-neighbour is nearer by more than
// 0.05 m + 3 % of the farther depth, `foreground` if one is that much farther.
void edge_sides(const std::vector<float>& range, int W, int H, int u, int v, double z,
                bool* background, bool* foreground) {
  *background = *foreground = false;
  const int nu[4] = {u - 1, u + 1, u, u};
  const int nv[4] = {v, v, v - 1, v + 1};
  for (int n = 0; n < 4; ++n) {
    if (nu[n] < 0 || nu[n] >= W || nv[n] < 0 || nv[n] >= H) continue;
    const double zn = range[static_cast<std::size_t>(nv[n]) * W + nu[n]];
    if (zn <= 0.0) continue;
    if (zn < z - (0.05 + 0.03 * z)) *background = true;
    if (zn > z + (0.05 + 0.03 * zn)) *foreground = true;
  }
}

// The D435-like sensor model on the exact depth: range limits, stereo losses on both sides of
// depth edges, patches on dark surfaces, random losses, quadratic noise, 1 mm quantisation.
// All draws are hashes of (seed, frame, pixel).
void apply_sensor(const StaticWorld& world, const CameraModel& cam, const Eigen::Vector3f& o,
                  const std::vector<Eigen::Vector3f>& dirs, const std::vector<int>& surface,
                  const RenderOptions& opt, RenderedFrame* out) {
  const int W = cam.width, H = cam.height;
  const DepthNoise& nz = opt.noise;
  const std::size_t nb = world.boxes.size();
  auto dark = [&](int s) {
    if (s < 0) return false;
    const auto k = static_cast<std::size_t>(s);
    return k < nb ? world.boxes[k].dark : world.cylinders[k - nb].dark;
  };
  for (int v = 0; v < H; ++v) {
    for (int u = 0; u < W; ++u) {
      const std::size_t i = static_cast<std::size_t>(v) * W + u;
      const double z = out->range[i];
      if (z <= 0.0) continue;
      double measured = z;
      if (nz.enabled) {
        if (z < nz.min_range || z > nz.max_range) continue;
        const auto pix = static_cast<std::uint64_t>(i);
        const auto draw = [&](std::uint64_t channel) {
          return unit(hash3(opt.seed, opt.frame_index, pix * 4 + channel));
        };
        // Stereo matching fails on both sides of a depth edge (occlusion, mixed windows).
        bool background = false, foreground = false;
        edge_sides(out->range, W, H, u, v, z, &background, &foreground);
        if (background && draw(0) < nz.edge_dropout) continue;
        if (foreground && draw(3) < nz.edge_dropout_foreground) continue;
        if (draw(1) < nz.random_dropout) continue;
        if (dark(surface[i])) {
          const Eigen::Vector3d p = (o + static_cast<float>(z) * dirs[i]).cast<double>();
          if (lost_on_dark_surface(world, surface[i], p, nz, opt.seed, opt.frame_index, pix)) {
            continue;
          }
        }
        const double sigma = nz.sigma0 + nz.sigma_quadratic * z * z;
        measured = z + sigma * gaussian(hash3(opt.seed, opt.frame_index, pix * 4 + 2));
        if (measured < nz.min_range || measured > nz.max_range) continue;
      }
      const double units = std::round(measured * cam.depth_factor);
      out->depth.pixels[i] = static_cast<std::uint16_t>(std::clamp(units, 0.0, 65535.0));
    }
  }
}

}  // namespace

RenderedFrame render_frame(const Scene& scene, const CameraModel& cam, const PoseD& pose,
                           const std::vector<WalkerState>& walkers, const RenderOptions& opt) {
  const int W = cam.width, H = cam.height;
  const std::size_t N = static_cast<std::size_t>(W) * H;
  RenderedFrame out;
  out.range.assign(N, kInf);
  out.id.assign(N, -2);
  std::vector<int> surface(N, -1);
  const Eigen::Matrix3f R = pose.rotation.toRotationMatrix().cast<float>();
  const Eigen::Matrix3f Rt = R.transpose();
  const Eigen::Vector3f o = pose.translation.cast<float>();
  const float fx = static_cast<float>(cam.fx), fy = static_cast<float>(cam.fy);
  const float cx = static_cast<float>(cam.cx), cy = static_cast<float>(cam.cy);
  std::vector<Eigen::Vector3f> dirs(N);
  for (int v = 0; v < H; ++v) {
    for (int u = 0; u < W; ++u) {
      dirs[static_cast<std::size_t>(v) * W + u] =
          R * Eigen::Vector3f((static_cast<float>(u) - cx) / fx, (static_cast<float>(v) - cy) / fy,
                              1.0f);
    }
  }
  if (opt.static_geometry) render_static(scene, cam, Rt, o, dirs, &out, &surface);
  const std::size_t nw = opt.walkers ? walkers.size() : 0;
  render_walkers(scene, cam, Rt, o, dirs, walkers, nw, &out, &surface);

  out.depth.width = W;
  out.depth.height = H;
  out.depth.pixels.assign(N, 0);
  for (std::size_t i = 0; i < N; ++i) {
    if (out.range[i] == kInf) out.range[i] = 0.0f;
  }
  apply_sensor(scene.world, cam, o, dirs, surface, opt, &out);
  return out;
}

}  // namespace dynamap::tools::sim
