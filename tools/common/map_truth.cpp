#include "common/map_truth.hpp"

#include <algorithm>
#include <cmath>
#include <unordered_set>

namespace dynamap::tools {
namespace {

constexpr double kEps = 1e-4;  // m: a face this close to a voxel boundary lies on it
constexpr std::int32_t kHalfRange = 1 << 20;
constexpr std::int64_t kMask = (std::int64_t{1} << 21) - 1;

// Interval [lo, hi] of a voxel along one axis.
struct Span {
  double lo, hi;
};
Span span(int i, double res) {
  return {i * res, (i + 1) * res};
}

// The voxel overlaps [a, b] by more than eps / lies within (a, b), more than eps from both ends
// (a voxel with a face on the shape's face holds part of its boundary).
bool overlaps(const Span& s, double a, double b) {
  return s.hi > a + kEps && s.lo < b - kEps;
}
bool within(const Span& s, double a, double b) {
  return s.lo > a + kEps && s.hi < b - kEps;
}

// Nearest and farthest distance from (cx, cy) to the voxel's x-y square.
void square_distances(const Span& x, const Span& y, const Eigen::Vector2d& c, double* nearest,
                      double* farthest) {
  const double nx = std::max({x.lo - c.x(), 0.0, c.x() - x.hi});
  const double ny = std::max({y.lo - c.y(), 0.0, c.y() - y.hi});
  const double fx = std::max(std::fabs(x.lo - c.x()), std::fabs(x.hi - c.x()));
  const double fy = std::max(std::fabs(y.lo - c.y()), std::fabs(y.hi - c.y()));
  *nearest = std::hypot(nx, ny);
  *farthest = std::hypot(fx, fy);
}

void add_box(const StaticBox& b, double res, std::unordered_set<std::int64_t>& surface,
             std::unordered_set<std::int64_t>& interior) {
  const Eigen::Vector3i lo = voxel_of(b.min.array() - kEps, res);
  const Eigen::Vector3i hi = voxel_of(b.max.array() + kEps, res);
  for (int i = lo.x(); i <= hi.x(); ++i) {
    for (int j = lo.y(); j <= hi.y(); ++j) {
      for (int k = lo.z(); k <= hi.z(); ++k) {
        const Span sx = span(i, res), sy = span(j, res), sz = span(k, res);
        if (!overlaps(sx, b.min.x(), b.max.x()) || !overlaps(sy, b.min.y(), b.max.y()) ||
            !overlaps(sz, b.min.z(), b.max.z()))
          continue;
        const Eigen::Vector3i v(i, j, k);
        const Eigen::Vector3d c = voxel_centre(v, res);
        if ((c.array() > b.min.array() + kEps).all() && (c.array() < b.max.array() - kEps).all())
          interior.insert(pack_voxel(v));
        if (!(within(sx, b.min.x(), b.max.x()) && within(sy, b.min.y(), b.max.y()) &&
              within(sz, b.min.z(), b.max.z())))
          surface.insert(pack_voxel(v));
      }
    }
  }
}

void add_cylinder(const StaticCylinder& cy, double res, std::unordered_set<std::int64_t>& surface,
                  std::unordered_set<std::int64_t>& interior) {
  const Eigen::Vector3i lo = voxel_of(
      Eigen::Vector3d(cy.center.x() - cy.radius, cy.center.y() - cy.radius, cy.zmin).array() - kEps,
      res);
  const Eigen::Vector3i hi = voxel_of(
      Eigen::Vector3d(cy.center.x() + cy.radius, cy.center.y() + cy.radius, cy.zmax).array() + kEps,
      res);
  for (int i = lo.x(); i <= hi.x(); ++i) {
    for (int j = lo.y(); j <= hi.y(); ++j) {
      double nearest = 0, farthest = 0;
      square_distances(span(i, res), span(j, res), cy.center, &nearest, &farthest);
      if (nearest >= cy.radius - kEps) continue;
      for (int k = lo.z(); k <= hi.z(); ++k) {
        const Span sz = span(k, res);
        if (!overlaps(sz, cy.zmin, cy.zmax)) continue;
        const Eigen::Vector3i v(i, j, k);
        const Eigen::Vector3d c = voxel_centre(v, res);
        if ((c.head<2>() - cy.center).norm() < cy.radius - kEps && c.z() > cy.zmin + kEps &&
            c.z() < cy.zmax - kEps)
          interior.insert(pack_voxel(v));
        if (!(farthest < cy.radius - kEps && within(sz, cy.zmin, cy.zmax)))
          surface.insert(pack_voxel(v));
      }
    }
  }
}

std::vector<Eigen::Vector3i> sorted_voxels(const std::unordered_set<std::int64_t>& set) {
  std::vector<std::int64_t> keys(set.begin(), set.end());
  std::sort(keys.begin(), keys.end());
  std::vector<Eigen::Vector3i> out;
  out.reserve(keys.size());
  for (std::int64_t k : keys) out.push_back(unpack_voxel(k));
  return out;
}

}  // namespace

Eigen::Vector3i voxel_of(const Eigen::Vector3d& p, double resolution) {
  return (p / resolution).array().floor().cast<int>();
}

Eigen::Vector3d voxel_centre(const Eigen::Vector3i& v, double resolution) {
  return (v.cast<double>().array() + 0.5) * resolution;
}

std::int64_t pack_voxel(const Eigen::Vector3i& v) {
  return ((std::int64_t{v.x()} + kHalfRange) & kMask) |
         (((std::int64_t{v.y()} + kHalfRange) & kMask) << 21) |
         (((std::int64_t{v.z()} + kHalfRange) & kMask) << 42);
}

Eigen::Vector3i unpack_voxel(std::int64_t key) {
  return {static_cast<int>(key & kMask) - kHalfRange,
          static_cast<int>((key >> 21) & kMask) - kHalfRange,
          static_cast<int>((key >> 42) & kMask) - kHalfRange};
}

StaticTruthVoxels static_truth_voxels(const StaticWorld& world, double resolution) {
  std::unordered_set<std::int64_t> surface, interior;
  for (const StaticBox& b : world.boxes) add_box(b, resolution, surface, interior);
  for (const StaticCylinder& c : world.cylinders) add_cylinder(c, resolution, surface, interior);
  return {sorted_voxels(surface), sorted_voxels(interior)};
}

bool is_floor_voxel(const StaticWorld& world, const Eigen::Vector3i& v, double resolution) {
  if (!world.has_floor) return false;
  const Span s = span(v.z(), resolution);
  return s.lo <= world.floor_z + kEps && s.hi >= world.floor_z - kEps;
}

bool near_static_shape(const StaticWorld& world, const Eigen::Vector3i& v, double resolution,
                       double margin) {
  const Span sx = span(v.x(), resolution), sy = span(v.y(), resolution);
  const Span sz = span(v.z(), resolution);
  const Span gx{sx.lo - margin, sx.hi + margin}, gy{sy.lo - margin, sy.hi + margin};
  const Span gz{sz.lo - margin, sz.hi + margin};
  for (const StaticBox& b : world.boxes) {
    if (overlaps(gx, b.min.x(), b.max.x()) && overlaps(gy, b.min.y(), b.max.y()) &&
        overlaps(gz, b.min.z(), b.max.z()))
      return true;
  }
  for (const StaticCylinder& c : world.cylinders) {
    double nearest = 0, farthest = 0;
    square_distances(gx, gy, c.center, &nearest, &farthest);
    if (nearest < c.radius - kEps && overlaps(gz, c.zmin, c.zmax)) return true;
  }
  return false;
}

MapFrameChecker::MapFrameChecker(const StaticWorld& world, const OccupancyMap& map) {
  const StaticTruthVoxels truth = static_truth_voxels(world, map.resolution());
  auto on_map_grid = [&](const Eigen::Vector3i& v) {
    return map.center_of(map.key_of(voxel_centre(v, map.resolution()).cast<float>()));
  };
  for (const auto& v : truth.surface) surface_.push_back(on_map_grid(v));
  for (const auto& v : truth.interior) {
    interior_.push_back(on_map_grid(v));
    // Both lists are sorted by pack_voxel.
    const bool on_surface =
        std::binary_search(truth.surface.begin(), truth.surface.end(), v,
                           [](const Eigen::Vector3i& a, const Eigen::Vector3i& b) {
                             return pack_voxel(a) < pack_voxel(b);
                           });
    whole_.push_back(on_surface ? 0 : 1);
  }
  held_.assign(surface_.size(), 0);
  resolution_ = map.resolution();
}

bool MapFrameChecker::has_occupied_neighbour(const OccupancyMap& map,
                                             const Eigen::Vector3f& centre) const {
  for (int dx = -1; dx <= 1; ++dx)
    for (int dy = -1; dy <= 1; ++dy)
      for (int dz = -1; dz <= 1; ++dz) {
        if (dx == 0 && dy == 0 && dz == 0) continue;
        const Eigen::Vector3f step(static_cast<float>(dx), static_cast<float>(dy),
                                   static_cast<float>(dz));
        if (map.state(centre + resolution_ * step) == Occupancy::kOccupied) return true;
      }
  return false;
}

MapFrameChecker::Counts MapFrameChecker::check(const OccupancyMap& map,
                                               const Eigen::Vector3f& camera, float near_radius) {
  Counts n;
  const float r2 = near_radius * near_radius;
  for (std::size_t i = 0; i < surface_.size(); ++i) {
    const Occupancy s = map.state(surface_[i]);
    if (s == Occupancy::kOccupied) {
      held_[i] = 1;
    } else if (s == Occupancy::kFree && held_[i] != 0) {
      const bool near = (surface_[i] - camera).squaredNorm() <= r2;
      ++n.erased_all;
      if (near) ++n.erased_near;
      if (has_occupied_neighbour(map, surface_[i])) continue;
      ++n.erased_bare_all;
      if (near) ++n.erased_bare_near;
    }
  }
  for (std::size_t i = 0; i < interior_.size(); ++i) {
    const Eigen::Vector3f& c = interior_[i];
    if (map.state(c) != Occupancy::kFree) continue;
    const bool near = (c - camera).squaredNorm() <= r2;
    ++n.free_through_all;
    if (near) ++n.free_through_near;
    if (whole_[i] == 0) continue;
    ++n.free_through_whole_all;
    if (near) ++n.free_through_whole_near;
  }
  return n;
}

}  // namespace dynamap::tools
