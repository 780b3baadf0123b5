#include "dynamap/predict/path_library.hpp"

#include <algorithm>
#include <cmath>

#include "dynamap/predict/predict_params.hpp"

namespace dynamap {

namespace {
/// Below this speed (m/s) the velocity direction is meaningless; heading defaults to +x.
constexpr float kMinHeadingSpeed = 1e-6f;
}  // namespace

Status PathLibrary::init(const PathLibraryConfig& c) noexcept {
  if (!all_in_range(c, params::kPathLibrary)) return Status::kInvalidArgument;
  config_ = c;
  return Status::kOk;
}

float PathLibrary::heading_change(std::size_t i) const noexcept {
  if (config_.num_paths <= 1) return 0.0f;
  const float u = static_cast<float>(i) / static_cast<float>(config_.num_paths - 1);
  return config_.max_heading_change * (1.0f - 2.0f * u);
}

PathHorizon PathLibrary::horizon(float speed) const noexcept {
  if (!std::isfinite(speed) || speed < 0.0f) speed = 0.0f;
  PathHorizon h;
  if (speed < config_.slow_speed || speed <= 0.0f) {
    h.duration = config_.slow_horizon_time;
    h.length = speed * h.duration;
  } else {
    h.length = config_.horizon_distance;
    h.duration = h.length / speed;
  }
  // Evenly spaced samples no further apart than sample_interval, unless the cap forces it.
  const float ratio = h.duration / config_.sample_interval;
  constexpr float kMaxIntervals = static_cast<float>(kMaxPathSamples - 1);
  const float intervals = std::clamp(std::ceil(ratio - 1e-4f), 1.0f, kMaxIntervals);
  h.samples = static_cast<std::size_t>(intervals) + 1;
  return h;
}

namespace {

/// Samples path i for `speed` and stores each sample through place(k, local position, local
/// tangent): one pass for both the velocity-frame and the map-frame samples.
template <class Place>
void sample_path(const PathLibrary& lib, std::size_t i, float speed, PathSamples* out,
                 const Place& place) noexcept {
  const PathHorizon h = lib.horizon(speed);
  const std::size_t n = h.samples;
  const float intervals = static_cast<float>(n - 1);
  const float ds = h.length / intervals;
  const float dt = h.duration / intervals;

  const float theta = lib.heading_change(i);
  const float sign = theta >= 0.0f ? 1.0f : -1.0f;
  const float kappa = lib.config().turn_curvature;
  const float s_turn = std::fabs(theta) / kappa;
  // End of the arc, and the straight continuation's direction.
  const float c_end = std::cos(theta);
  const float s_end = std::sin(theta);
  const Eigen::Vector2f arc_end(std::fabs(s_end) / kappa, sign * (1.0f - c_end) / kappa);
  const Eigen::Vector2f dir_end(c_end, s_end);
  // Heading on the arc advances by kappa*ds per sample: rotate instead of calling sin/cos.
  const float c_step = std::cos(kappa * ds);
  const float s_step = std::sin(kappa * ds);
  float c = 1.0f;
  float s = 0.0f;

  out->count = n;
  for (std::size_t k = 0; k < n; ++k) {
    const float arc = static_cast<float>(k) * ds;
    out->time[k] = static_cast<float>(k) * dt;
    out->arc_length[k] = arc;
    if (arc <= s_turn) {
      place(k, Eigen::Vector2f(s / kappa, sign * (1.0f - c) / kappa), Eigen::Vector2f(c, sign * s));
    } else {
      place(k, Eigen::Vector2f(arc_end + (arc - s_turn) * dir_end), dir_end);
    }
    const float c_next = c * c_step - s * s_step;
    s = s * c_step + c * s_step;
    c = c_next;
  }
}

}  // namespace

std::size_t PathLibrary::turn_end_sample(std::size_t i, float speed) const noexcept {
  const float theta = heading_change(i);
  if (theta == 0.0f) return 0;
  const PathHorizon h = horizon(speed);
  // The same expressions as sample_path, so the sample it names is the one it puts on the arc.
  const float ds = h.length / static_cast<float>(h.samples - 1);
  const float s_turn = std::fabs(theta) / config_.turn_curvature;
  std::size_t k = 0;
  while (k + 1 < h.samples && static_cast<float>(k + 1) * ds <= s_turn) ++k;
  return k;
}

void PathLibrary::sample_local(std::size_t i, float speed, PathSamples* out) const noexcept {
  sample_path(*this, i, speed, out,
              [out](std::size_t k, const Eigen::Vector2f& p, const Eigen::Vector2f& t) {
                out->position[k] = p;
                out->tangent[k] = t;
              });
}

void PathLibrary::sample(std::size_t i, const Eigen::Vector2f& origin,
                         const Eigen::Vector2f& velocity, PathSamples* out) const noexcept {
  const float speed = velocity.norm();
  Eigen::Vector2f fwd(1.0f, 0.0f);
  if (speed > kMinHeadingSpeed) fwd = velocity / speed;
  const Eigen::Vector2f left(-fwd.y(), fwd.x());
  sample_path(*this, i, speed, out,
              [&](std::size_t k, const Eigen::Vector2f& p, const Eigen::Vector2f& t) {
                out->position[k] = origin + p.x() * fwd + p.y() * left;
                out->tangent[k] = t.x() * fwd + t.y() * left;
              });
}

}  // namespace dynamap
