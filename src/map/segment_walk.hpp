// Set-up of the Amanatides-Woo voxel walk shared by the map's segment queries (internal).
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <limits>

#include <Eigen/Core>

namespace dynamap::detail {

/// Per-axis state of a walk from voxel `idx` (containing a) to voxel `end` (containing b):
/// step direction, steps left, t of the next boundary and t between boundaries (t in [0, 1]
/// along b - a; inf on an axis with no steps).
struct SegmentWalk {
  std::int32_t step[3];
  std::int32_t remaining[3];
  float t_max[3];
  float t_delta[3];

  /// One voxel step along the axis whose next boundary comes first (ties to the lower axis);
  /// returns that axis. Needs a step left on some axis.
  std::size_t advance(std::array<std::int32_t, 3>& idx) noexcept {
    std::size_t ax = 0;
    if (t_max[1] < t_max[ax]) ax = 1;
    if (t_max[2] < t_max[ax]) ax = 2;
    idx[ax] += step[ax];
    if (--remaining[ax] == 0) {
      t_max[ax] = std::numeric_limits<float>::infinity();
    } else {
      t_max[ax] += t_delta[ax];
    }
    return ax;
  }

  /// Crosses the rest of the block of 2^kBits voxels the walk is in, where `inside` holds the
  /// steps each axis can make before it leaves the block, counting the visits into n (capped
  /// at max_visits). False when the segment ends inside the block or the cap is reached.
  ///
  /// Each axis's t sequence (t_max, t_max + t_delta, ...) does not depend on the other axes,
  /// and the walk visits the merged sequence in (t, axis) order, so the step that leaves the
  /// block is the axis whose boundary-crossing t is smallest (ties to the lower axis, as in
  /// advance()). The same float additions are made in the same order, so the walk ends in the
  /// voxel advance() would reach, with the same state.
  bool cross_block(std::array<std::int32_t, 3>& idx, const std::int32_t inside[3], std::size_t& n,
                   std::size_t max_visits) noexcept {
    constexpr float kInf = std::numeric_limits<float>::infinity();
    // t of each axis's boundary-crossing step (inf when its steps run out first).
    float cross[3];
    for (std::size_t ax = 0; ax < 3; ++ax) {
      cross[ax] = kInf;
      if (inside[ax] + 1 > remaining[ax]) continue;
      float t = t_max[ax];
      for (std::int32_t s = 0; s < inside[ax]; ++s) t += t_delta[ax];
      cross[ax] = t;
    }
    std::size_t exit_ax = 0;
    if (cross[1] < cross[exit_ax]) exit_ax = 1;
    if (cross[2] < cross[exit_ax]) exit_ax = 2;
    if (cross[exit_ax] == kInf) return false;  // the segment ends inside this block
    const float t_exit = cross[exit_ax];
    std::size_t steps = 0;
    for (std::size_t ax = 0; ax < 3; ++ax) {
      if (ax == exit_ax) continue;
      // Steps of this axis that come before the exit step in (t, axis) order.
      const std::int32_t limit = std::min(inside[ax], remaining[ax]);
      std::int32_t k = 0;
      float t = t_max[ax];
      while (k < limit && (t < t_exit || (t == t_exit && ax < exit_ax))) {
        ++k;
        t = k == remaining[ax] ? kInf : t + t_delta[ax];
      }
      idx[ax] += k * step[ax];
      remaining[ax] -= k;
      t_max[ax] = t;
      steps += static_cast<std::size_t>(k);
    }
    steps += static_cast<std::size_t>(inside[exit_ax]);
    // Visits in this block: the current voxel and one per step inside it.
    if (n + steps + 1 >= max_visits) return false;
    n += steps + 1;
    const std::int32_t k = inside[exit_ax] + 1;
    idx[exit_ax] += k * step[exit_ax];
    remaining[exit_ax] -= k;
    t_max[exit_ax] = remaining[exit_ax] == 0 ? kInf : t_exit + t_delta[exit_ax];
    return true;
  }
};

/// One axis of a voxel walk from voxel index `from` (point coordinate `a`) to voxel index `to`
/// along `d` (t in [0, 1] along the segment): step sign, steps left, t of the first boundary and
/// t between boundaries; no steps and t = inf when the axis does not move.
struct AxisStart {
  std::int32_t step = 1;
  std::int32_t remaining = 0;
  float t_max = std::numeric_limits<float>::infinity();
  float t_delta = std::numeric_limits<float>::infinity();
};
inline AxisStart start_axis(std::int32_t from, std::int32_t to, float a, float d,
                            float resolution) noexcept {
  AxisStart s;
  s.step = to > from ? 1 : -1;
  if (to == from || d == 0.f) return s;
  s.remaining = std::abs(to - from);
  const float boundary = static_cast<float>(from + (s.step > 0 ? 1 : 0)) * resolution;
  s.t_max = (boundary - a) / d;
  s.t_delta = resolution / std::fabs(d);
  return s;
}

inline SegmentWalk start_segment_walk(const Eigen::Vector3f& a, const Eigen::Vector3f& b,
                                      const std::array<std::int32_t, 3>& idx,
                                      const std::array<std::int32_t, 3>& end,
                                      float resolution) noexcept {
  SegmentWalk w{};
  const Eigen::Vector3f d = b - a;
  for (std::size_t ax = 0; ax < 3; ++ax) {
    const int e = static_cast<int>(ax);
    const AxisStart s = start_axis(idx[ax], end[ax], a[e], d[e], resolution);
    w.step[ax] = s.step;
    w.remaining[ax] = s.remaining;
    w.t_max[ax] = s.t_max;
    w.t_delta[ax] = s.t_delta;
  }
  return w;
}

/// One free-space ray of the map's pass 2: Amanatides-Woo state from its first voxel (t in
/// [0, 1] along the ray; inf on an axis without steps).
struct RayWalk {
  std::int32_t ix, iy, iz;  ///< first voxel
  std::int32_t sx, sy, sz;  ///< step signs
  std::int32_t rx, ry, rz;  ///< steps left per axis
  float tx, ty, tz;         ///< t of the next boundary per axis
  float dx, dy, dz;         ///< t between boundaries per axis
  std::size_t visits;       ///< voxels to visit, the first one included
  bool own_surface;         ///< walked from a hit's end, sparing its own surface (keep_own_surface)
  float px, py, pz;         ///< a point of the ray's line (m; set with miss_max_offset only)
  float ux, uy, uz;         ///< the line's unit direction
  float inv_length;         ///< 1 / the distance from the camera to the ray's end (1/m)
};

/// True when the line of `w` passes farther from the centre of voxel `li` (index inside its
/// block) of block (bi, bj, bk) than max(near, spread x t / L), t the centre's distance from the
/// camera along the ray and L the ray's length (all in m). The second term follows the spacing
/// of the merged rays, one per end voxel, which is about a voxel at the ray's end: there every
/// ray counts, or voxels between two rays would never be lowered.
template <int kBits>
inline bool passes_aside(const RayWalk& w, std::int32_t bi, std::int32_t bj, std::int32_t bk,
                         std::int32_t li, float resolution, float near, float spread) noexcept {
  constexpr std::int32_t kEdge = 1 << kBits;
  constexpr std::int32_t kM = kEdge - 1;
  const auto centre = [&](std::int32_t b, std::int32_t i) {
    return (static_cast<float>(b * kEdge + i) + 0.5f) * resolution;
  };
  const float vx = centre(bi, li & kM) - w.px;
  const float vy = centre(bj, (li >> kBits) & kM) - w.py;
  const float vz = centre(bk, (li >> (2 * kBits)) & kM) - w.pz;
  const float cx = vy * w.uz - vz * w.uy;
  const float cy = vz * w.ux - vx * w.uz;
  const float cz = vx * w.uy - vy * w.ux;
  const float along = (vx * w.ux + vy * w.uy + vz * w.uz) * w.inv_length;
  const float allowed = std::max(near, spread * along);
  return cx * cx + cy * cy + cz * cz > allowed * allowed;
}

/// Walks `n` voxels of `w` (blocks of 2^kBits voxels per edge), calling cursor.enter(bi, bj,
/// bk, n) on each block entered, cursor.visit(li) on each voxel (li: index inside the block;
/// true stops the walk) and cursor.leave(n) on leaving a block. Returns the visits left,
/// the stopping voxel included, when the cursor stopped the walk; 0 when it ran to the end.
///
/// The walk keeps the voxel's index inside its block and, per axis, the steps left to the next
/// event of that axis: its block face or its last step, whichever comes first. Between events
/// a step is one axis choice, one index add, one t add and one decrement; steps, end indices
/// and block faces are only looked at in the (rare) event branch. The t values get the same
/// float additions in the same order as the plain voxel walk, so the voxels are the same.
/// The rare event of one axis of walk_ray(), after its step: its last step or its block face,
/// whichever came first. `r` steps left, `c` steps to the block face, `t`/`d` its next boundary
/// and spacing, `k` steps to its next event, `o` its index offset inside a block, `b`/`s` its
/// block index and step sign. When the walk crosses into the next block (`li` wraps), calls
/// on_cross() after moving `b`.
template <int kBits, class OnCross>
inline void axis_event(std::int32_t& r, std::int32_t& c, float& t, float d, std::int32_t& k,
                       std::int32_t& li, std::int32_t o, std::int32_t& b, std::int32_t s,
                       const OnCross& on_cross) noexcept {
  constexpr std::int32_t kEdge = 1 << kBits;
  const std::int32_t done = std::min(c, r);
  r -= done;
  c -= done;
  t = r == 0 ? std::numeric_limits<float>::infinity() : t + d;
  if (c == 0) {
    li -= kEdge * o;  // wrap to the other face of the next block
    b += s;
    c = kEdge;
    on_cross();
  }
  // An axis without steps has t = inf and is never chosen, so its event count never runs out.
  k = r == 0 ? std::numeric_limits<std::int32_t>::max() : std::min(c, r);
}

/// Walks `n` voxels of `w` (blocks of 2^kBits voxels per edge), calling cursor.enter(bi, bj,
/// bk, n) on each block entered, cursor.visit(li) on each voxel (li: index inside the block;
/// true stops the walk) and cursor.leave(n) on leaving a block. Returns the visits left,
/// the stopping voxel included, when the cursor stopped the walk; 0 when it ran to the end.
///
/// The walk keeps the voxel's index inside its block and, per axis, the steps left to the next
/// event of that axis: its block face or its last step, whichever comes first. Between events
/// a step is one axis choice, one index add, one t add and one decrement; steps, end indices
/// and block faces are only looked at in the (rare) event branch, axis_event(). The t values
/// get the same float additions in the same order as the plain voxel walk, so the voxels are
/// the same.
template <int kBits, class Cursor>
std::size_t walk_ray(RayWalk& w, std::size_t n, Cursor& cursor) noexcept {
  constexpr std::int32_t kEdge = 1 << kBits;
  constexpr std::int32_t kM = kEdge - 1;
  std::int32_t bx = w.ix >> kBits, by = w.iy >> kBits, bz = w.iz >> kBits;
  const auto to_boundary = [](std::int32_t i, std::int32_t s) {
    return s > 0 ? kEdge - (i & kM) : (i & kM) + 1;
  };
  std::int32_t cx = to_boundary(w.ix, w.sx), cy = to_boundary(w.iy, w.sy),
               cz = to_boundary(w.iz, w.sz);
  const auto to_event = [](std::int32_t face, std::int32_t left) {
    return left == 0 ? std::numeric_limits<std::int32_t>::max() : std::min(face, left);
  };
  std::int32_t rx = w.rx, ry = w.ry, rz = w.rz;
  float tx = w.tx, ty = w.ty, tz = w.tz;
  const float dx = w.dx, dy = w.dy, dz = w.dz;
  std::int32_t kx = to_event(cx, rx), ky = to_event(cy, ry), kz = to_event(cz, rz);
  const std::int32_t ox = w.sx, oy = w.sy * kEdge, oz = w.sz * kEdge * kEdge;
  std::int32_t li = (w.ix & kM) | ((w.iy & kM) << kBits) | ((w.iz & kM) << (2 * kBits));
  const auto cross = [&] {
    cursor.leave(n);
    cursor.enter(bx, by, bz, n);
  };
  cursor.enter(bx, by, bz, n);
  if (n == 0) return 0;
  for (;;) {
    if (cursor.visit(li)) {
      cursor.leave(n);
      return n;
    }
    if (--n == 0) break;
    // Step along the axis with the nearest boundary (ties to the lower axis).
    if ((tx <= ty) & (tx <= tz)) {
      li += ox;
      if (--kx != 0) {
        tx += dx;
        continue;
      }
      axis_event<kBits>(rx, cx, tx, dx, kx, li, ox, bx, w.sx, cross);
    } else if (ty <= tz) {
      li += oy;
      if (--ky != 0) {
        ty += dy;
        continue;
      }
      axis_event<kBits>(ry, cy, ty, dy, ky, li, oy, by, w.sy, cross);
    } else {
      li += oz;
      if (--kz != 0) {
        tz += dz;
        continue;
      }
      axis_event<kBits>(rz, cz, tz, dz, kz, li, oz, bz, w.sz, cross);
    }
  }
  cursor.leave(0);
  return 0;
}

}  // namespace dynamap::detail
