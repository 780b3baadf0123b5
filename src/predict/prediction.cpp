#include "dynamap/predict/prediction.hpp"

#include <algorithm>
#include <cmath>

#include "dynamap/predict/detail/path_sweep.hpp"
#include "dynamap/predict/far_field_layer.hpp"
#include "dynamap/predict/predict_params.hpp"

namespace dynamap {

Status validate(const ClearanceConfig& c) noexcept {
  return all_in_range(c, params::kClearance) ? Status::kOk : Status::kInvalidArgument;
}

Status validate(const ObstacleState& o) noexcept {
  if (!o.position.allFinite() || !o.velocity.allFinite() || !std::isfinite(o.footprint_radius) ||
      !std::isfinite(o.height) || !std::isfinite(o.body_margin)) {
    return Status::kNonFinite;
  }
  if (o.footprint_radius < 0.0f || o.height < 0.0f || o.body_margin < 0.0f) {
    return Status::kInvalidArgument;
  }
  return Status::kOk;
}

std::size_t clearance_lines(const ClearanceConfig& c, float radius) noexcept {
  if (!(radius > 0.0f) || !(c.line_spacing > 0.0f)) return 1;
  const float gaps = std::ceil(2.0f * radius / c.line_spacing - 1e-3f);
  const float cap = static_cast<float>(std::min(c.max_lines, kMaxClearanceLines));
  return static_cast<std::size_t>(std::clamp(gaps + 1.0f, 1.0f, cap));
}

namespace {
/// Fraction t in [0, 1] of segment a->b where it leaves the disc of squared radius r2 around c
/// (0 when a is outside; > 1 when b is inside too, i.e. the whole segment is inside).
float exit_fraction(const Eigen::Vector2f& a, const Eigen::Vector2f& b, const Eigen::Vector2f& c,
                    float r2) noexcept {
  const Eigen::Vector2f d = b - a;
  const Eigen::Vector2f f = a - c;
  const float cf = f.squaredNorm() - r2;
  if (cf >= 0.0f) return 0.0f;  // starts outside
  if ((b - c).squaredNorm() <= r2) return 2.0f;
  const float dd = d.squaredNorm();
  const float fd = f.dot(d);
  // |f + t d|^2 = r2 has one root in (0, 1) because a is inside and b outside.
  return (-fd + std::sqrt(fd * fd - dd * cf)) / dd;
}

/// Last sample m > k such that the chord k->m stays within `tolerance` of the path: the sag of
/// an arc of length L turning by dphi is about L * dphi / 8 (exactly 0 on straight parts).
std::size_t chord_end(const PathSamples& path, std::size_t k, std::size_t n, float tolerance,
                      std::uint32_t breaks) noexcept {
  std::size_t m = k + 1;
  const Eigen::Vector2f& t0 = path.tangent[k];
  while (m + 1 < n && ((breaks >> m) & 1u) == 0) {
    const Eigen::Vector2f& t1 = path.tangent[m + 1];
    const float dot = t0.dot(t1);
    const float cross = std::fabs(t0.x() * t1.y() - t0.y() * t1.x());
    const float length = path.arc_length[m + 1] - path.arc_length[k];
    if (dot < 0.9f || length * cross > 8.0f * tolerance) break;  // sin(dphi) ~ dphi up to 25 deg
    ++m;
  }
  return m;
}

/// The swept lines of one obstacle: lateral offsets, heights, and the own-body disc.
struct SweepGeometry {
  std::array<float, kMaxClearanceLines> offset{};
  std::size_t lines = 1;
  std::array<float, kMaxHeightLevels> level{};
  std::size_t levels = 1;
  Eigen::Vector2f self_centre = Eigen::Vector2f::Zero();
  float self_r = 0.0f;
  float self_r2 = 0.0f;
};

SweepGeometry sweep_geometry(const ObstacleState& obstacle,
                             const ClearanceConfig& clearance) noexcept {
  SweepGeometry g;
  const float r = obstacle.footprint_radius;
  g.lines = clearance_lines(clearance, r);
  for (std::size_t j = 0; j < g.lines; ++j) {
    g.offset[j] = g.lines == 1
                      ? 0.0f
                      : -r + 2.0f * r * static_cast<float>(j) / static_cast<float>(g.lines - 1);
  }
  const float lo = obstacle.position.z() - 0.5f * obstacle.height + clearance.ground_clearance;
  const float hi = obstacle.position.z() + 0.5f * obstacle.height;
  g.levels = std::min(clearance.height_levels, kMaxHeightLevels);
  if (hi <= lo) {
    g.levels = 1;
    g.level[0] = obstacle.position.z();
  } else {
    const float step = (hi - lo) / static_cast<float>(g.levels);
    for (std::size_t h = 0; h < g.levels; ++h) {
      g.level[h] = lo + (static_cast<float>(h) + 0.5f) * step;
    }
  }
  // The obstacle's own body: not checked.
  g.self_centre = obstacle.position.head<2>();
  g.self_r = clearance.self_margin > 0.0f ? r + clearance.self_margin + obstacle.body_margin : 0.0f;
  g.self_r2 = g.self_r * g.self_r;
  return g;
}

/// Arc length along `path` before any swept line meets a voxel that `query` reports (the map's
/// occupied query); the full length, and *free = true, when none does.
template <class Query>
float first_hit_distance(const Query& query, const PathSamples& path, const SweepGeometry& g,
                         const ClearanceConfig& clearance, const SweepSpan& span, bool* free,
                         std::size_t* hit_chord) noexcept {
  *free = true;
  const std::size_t n = std::min(path.count, kMaxPathSamples);
  if (n == 0) return 0.0f;
  std::size_t k = span.start;
  while (k + 1 < n) {
    const std::size_t m = chord_end(path, k, n, clearance.chord_tolerance, span.breaks);
    const Eigen::Vector2f n0(-path.tangent[k].y(), path.tangent[k].x());
    const Eigen::Vector2f n1(-path.tangent[m].y(), path.tangent[m].x());
    float first = 2.0f;  // fraction of this chord at the first hit; > 1 means none
    for (std::size_t h = 0; h < g.levels; ++h) {
      for (std::size_t j = 0; j < g.lines; ++j) {
        const Eigen::Vector2f a2 = path.position[k] + g.offset[j] * n0;
        const Eigen::Vector2f b2 = path.position[m] + g.offset[j] * n1;
        const Eigen::Vector3f a(a2.x(), a2.y(), g.level[h]);
        const Eigen::Vector3f b(b2.x(), b2.y(), g.level[h]);
        // Start where the line leaves the obstacle's own body; after a hit at fraction
        // `first`, the other lines only need to look before it.
        const float t0 = g.self_r > 0.0f ? exit_fraction(a2, b2, g.self_centre, g.self_r2) : 0.0f;
        const float t1 = std::min(first, 1.0f);
        if (t0 >= t1) continue;
        const Eigen::Vector3f a_cut = t0 > 0.0f ? Eigen::Vector3f(a + t0 * (b - a)) : a;
        const Eigen::Vector3f b_cut = t1 < 1.0f ? Eigen::Vector3f(a + t1 * (b - a)) : b;
        Eigen::Vector3f hit;
        if (!query(a_cut, b_cut, &hit)) continue;
        const Eigen::Vector2f ab = b2 - a2;
        const float len2 = ab.squaredNorm();
        float f = 0.0f;
        if (len2 > 1e-12f) f = (hit.head<2>() - a2).dot(ab) / len2;
        if (!(f > 0.0f)) f = 0.0f;  // also catches NaN from a degenerate hit
        first = std::min(first, std::min(f, 1.0f));
      }
    }
    if (first <= 1.0f) {
      *free = false;
      *hit_chord = k;
      return path.arc_length[k] + first * (path.arc_length[m] - path.arc_length[k]);
    }
    k = m;
  }
  return path.arc_length[n - 1];
}
/// Arc length along `path`, up to `limit`, before a point of the footprint at a sample lies in a
/// remembered wall cell of the far-field layer; `limit` and *free = true when none does. The
/// lines are at most one cell apart, so no cell slips between them.
float far_hit_distance(const FarFieldLayer& far, const PathSamples& path, const SweepGeometry& g,
                       float radius, float limit, std::size_t start, bool* free) noexcept {
  *free = true;
  const float cell = far.config().cell_size;
  // A remembered wall lies somewhere in its cell: the half cell is taken off the footprint so
  // the coarse grid does not inflate walls by a whole cell (on average it is half of one).
  radius = std::max(0.0f, radius - 0.5f * cell);
  const std::size_t lines =
      radius > 0.0f
          ? std::min<std::size_t>(kMaxClearanceLines,
                                  static_cast<std::size_t>(std::ceil(2.0f * radius / cell)) + 1)
          : 1;
  std::array<float, kMaxClearanceLines> offset{};
  for (std::size_t j = 0; j < lines; ++j) {
    offset[j] = lines == 1 ? 0.0f
                           : -radius + 2.0f * radius * static_cast<float>(j) /
                                           static_cast<float>(lines - 1);
  }
  const std::size_t n = std::min(path.count, kMaxPathSamples);
  for (std::size_t k = start; k < n; ++k) {
    if (path.arc_length[k] > limit) break;
    const Eigen::Vector2f normal(-path.tangent[k].y(), path.tangent[k].x());
    for (std::size_t j = 0; j < lines; ++j) {
      const Eigen::Vector2f p2 = path.position[k] + offset[j] * normal;
      if (g.self_r > 0.0f && (p2 - g.self_centre).squaredNorm() < g.self_r2) continue;
      if (far.occupied(p2)) {
        *free = false;
        return path.arc_length[k];
      }
    }
  }
  return limit;
}

/// Ends `result`'s free distance at the far-field layer's first remembered wall before it.
void apply_far_field(const FarFieldLayer* far_field, const PathSamples& path,
                     const SweepGeometry& g, float radius, std::size_t start,
                     PathClearance* result) noexcept {
  if (far_field == nullptr || !far_field->initialised() || !far_field->config().enabled) return;
  bool far_free = true;
  const float d =
      far_hit_distance(*far_field, path, g, radius, result->free_distance, start, &far_free);
  if (!far_free) block_at_far_wall(d, result);
}
}  // namespace

PathClearance sweep_path(const OccupancyQuery& map, const PathSamples& path,
                         const ObstacleState& obstacle, const ClearanceConfig& clearance,
                         const FarFieldLayer* far_field, const SweepSpan& span) noexcept {
  const SweepGeometry g = sweep_geometry(obstacle, clearance);
  PathClearance result;
  result.free_distance =
      first_hit_distance([&map](const Eigen::Vector3f& a, const Eigen::Vector3f& b,
                                Eigen::Vector3f* hit) { return map.segment(a, b, hit); },
                         path, g, clearance, span, &result.free, &result.hit_chord);
  apply_far_field(far_field, path, g, obstacle.footprint_radius, 0, &result);
  return result;
}

PathClearance add_far_field(const PathClearance& map_result, const PathSamples& path,
                            const ObstacleState& obstacle, const ClearanceConfig& clearance,
                            const FarFieldLayer* far_field, std::size_t far_start) noexcept {
  PathClearance result = map_result;
  apply_far_field(far_field, path, sweep_geometry(obstacle, clearance), obstacle.footprint_radius,
                  far_start, &result);
  return result;
}

void block_at_far_wall(float far_distance, PathClearance* result) noexcept {
  result->far_distance = far_distance;
  result->far_blocked = result->free || far_distance < result->free_distance;
  result->free = false;
  result->free_distance = std::min(result->free_distance, far_distance);
}

void write_chosen_path(const PathSamples& path, float z, PathPrediction* out) noexcept {
  const std::size_t n = std::min(path.count, kMaxPathSamples);
  out->num_samples = n;
  out->path_length = n > 0 ? path.arc_length[n - 1] : 0.0f;
  for (std::size_t k = 0; k < n; ++k) {
    out->position[k] = Eigen::Vector3f(path.position[k].x(), path.position[k].y(), z);
    out->time[k] = path.time[k];
  }
}

Status validate_prediction_call(const ObstacleState* obstacles, std::size_t count,
                                const OccupancyQuery& map, const PathPrediction* out) noexcept {
  if (count > kMaxTracks) return Status::kCapacityExceeded;
  if (count > 0 && (obstacles == nullptr || out == nullptr || !map.valid())) {
    return Status::kNullData;
  }
  for (std::size_t k = 0; k < count; ++k) {
    const Status s = validate(obstacles[k]);
    if (!ok(s)) return s;
  }
  return Status::kOk;
}

}  // namespace dynamap
