#include "dynamap/predict/markov_predictor.hpp"

#include <cmath>
#include <limits>

#include "dynamap/core/fixed_vector.hpp"
#include "dynamap/predict/predict_params.hpp"

namespace dynamap {

namespace {

using Belief = MarkovPredictor::Belief;

/// Discrete Gaussian over indices 0..n-1 around `centre`, normalised. Exponents are taken
/// relative to the nearest index so the largest weight is 1 and the sum never underflows.
void discrete_gaussian(std::size_t n, double centre, double sigma, Belief* out) noexcept {
  double nearest = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < n; ++i) {
    const double d = static_cast<double>(i) - centre;
    nearest = std::fmin(nearest, d * d);
  }
  double sum = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    const double d = static_cast<double>(i) - centre;
    (*out)[i] = std::exp(-(d * d - nearest) / (2.0 * sigma * sigma));
    sum += (*out)[i];
  }
  for (std::size_t i = 0; i < n; ++i) (*out)[i] /= sum;
  for (std::size_t i = n; i < kMaxPaths; ++i) (*out)[i] = 0.0;
}

/// Scales v[0..n) to sum 1; false (v untouched) when the sum is zero, subnormal or not finite.
bool normalise(std::size_t n, Belief* v) noexcept {
  double sum = 0.0;
  for (std::size_t i = 0; i < n; ++i) sum += (*v)[i];
  if (!std::isfinite(sum) || !(sum >= std::numeric_limits<double>::min())) return false;
  const double inv = 1.0 / sum;
  for (std::size_t i = 0; i < n; ++i) (*v)[i] *= inv;
  return true;
}

}  // namespace

Status MarkovPredictor::init(const MarkovPredictorConfig& c) noexcept {
  PathLibrary lib;
  if (!ok(lib.init(c.paths))) return Status::kInvalidArgument;
  if (!ok(validate(c.clearance)) || !all_in_range(c, params::kMarkovPredictor)) {
    return Status::kInvalidArgument;
  }
  PathLibrary turn_back;
  if (c.turn_back_curvature > 0.0f) {
    PathLibraryConfig tight = c.paths;
    tight.turn_curvature = c.turn_back_curvature;
    if (!ok(turn_back.init(tight))) return Status::kInvalidArgument;
  }

  config_ = c;
  library_ = lib;
  turn_back_library_ = turn_back;
  const std::size_t l = library_.size();
  const double s_init = sigma_in_indices(c.sigma_init);
  const double s_trans = sigma_in_indices(c.sigma_trans);
  discrete_gaussian(l, static_cast<double>(library_.center_index()), s_init, &initial_);
  for (std::size_t i = 0; i < kMaxPaths; ++i) {
    if (i < l) {
      discrete_gaussian(l, static_cast<double>(i), s_trans, &trans_[i]);
    } else {
      trans_[i].fill(0.0);
    }
  }
  beliefs_.clear();
  underflow_restarts_ = 0;
  initialised_ = true;
  return Status::kOk;
}

double MarkovPredictor::sigma_in_indices(float sigma_rad) const noexcept {
  const std::size_t l = library_.size();
  const double spacing = l > 1 ? 2.0 * static_cast<double>(library_.config().max_heading_change) /
                                     static_cast<double>(l - 1)
                               : 0.0;
  // All paths identical (l = 1 or no turning): the distributions are uniform anyway.
  if (!(spacing > 0.0)) return 1e6;
  return static_cast<double>(sigma_rad) / spacing;
}

bool MarkovPredictor::belief(std::uint32_t track_id, Belief* out) const noexcept {
  const Belief* b = beliefs_.find(track_id);
  if (b == nullptr) return false;
  *out = *b;
  return true;
}

Status MarkovPredictor::predict(const ObstacleState* obstacles, std::size_t count,
                                const OccupancyQuery& map, const FarFieldLayer* far_field,
                                PathPrediction* out) noexcept {
  if (!initialised_) return Status::kNotInitialized;
  // Validate everything before touching any state.
  const Status bad = validate_prediction_call(obstacles, count, map, out);
  if (!ok(bad)) return bad;
  for (std::size_t k = 0; k < count; ++k) {
    for (std::size_t m = 0; m < k; ++m) {
      if (obstacles[m].track_id == obstacles[k].track_id) return Status::kInvalidArgument;
    }
  }

  // Forget tracks that are not in this frame first, so the table never holds more than count.
  FixedVector<std::uint32_t, kPredictorTrackSlots> stale;
  beliefs_.for_each([&](std::uint32_t id, const Belief&) {
    for (std::size_t k = 0; k < count; ++k) {
      if (obstacles[k].track_id == id) return;
    }
    (void)stale.push_back(id);  // cannot fail: stale holds at most the table's size
  });
  for (const std::uint32_t id : stale) beliefs_.erase(id);

  for (std::size_t k = 0; k < count; ++k) predict_one(obstacles[k], map, far_field, &out[k]);
  return Status::kOk;
}

void MarkovPredictor::predict_one(const ObstacleState& obstacle, const OccupancyQuery& map,
                                  const FarFieldLayer* far_field, PathPrediction* out) noexcept {
  const std::size_t l = library_.size();
  const Belief env = sweep_paths(obstacle, map, far_field, out);
  const Belief post = update_belief(obstacle.track_id, env);
  const std::size_t best = choose_path(post, *out);
  for (std::size_t i = 0; i < kMaxPaths; ++i) {
    out->probability[i] = i < l ? static_cast<float>(post[i]) : 0.0f;
    if (i >= l) out->free_distance[i] = 0.0f;
  }
  out->chosen = best;
  out->failed = !out->path_free(best);
  write_chosen_path(paths_[best], obstacle.position.z(), out);
}

MarkovPredictor::Belief MarkovPredictor::sweep_paths(const ObstacleState& obstacle,
                                                     const OccupancyQuery& map,
                                                     const FarFieldLayer* far_field,
                                                     PathPrediction* out) noexcept {
  const std::size_t l = library_.size();
  out->track_id = obstacle.track_id;
  out->num_paths = l;
  out->free_mask = 0;
  out->far_blocked_mask = 0;
  out->any_free = false;
  std::array<float, kMaxPaths> dist{};  // Dist_i of P_env
  std::array<PathClearance, kMaxPaths> clear{};
  sweep_library(obstacle, map, far_field, &clear);
  bool any_free = false;
  for (std::size_t i = 0; i < l; ++i) any_free = any_free || clear[i].free;
  if (!any_free && config_.turn_back_curvature > 0.0f) {
    retry_turning_back(obstacle, map, far_field, &clear);
  }
  float max_dist = 0.0f;
  for (std::size_t i = 0; i < l; ++i) {
    const PathClearance& c = clear[i];
    out->free_distance[i] = c.free_distance;
    if (c.far_blocked) out->far_blocked_mask |= 1u << i;
    if (c.free) {
      out->free_mask |= 1u << i;
      out->any_free = true;
    }
    dist[i] = c.free_distance;
    max_dist = i == 0 ? dist[i] : std::fmax(max_dist, dist[i]);
  }

  // P_env = softmax(beta * Dist), shifted by the maximum so the largest term is exactly 1.
  Belief env{};
  for (std::size_t i = 0; i < l; ++i) {
    env[i] = std::exp(static_cast<double>(config_.beta) * static_cast<double>(dist[i] - max_dist));
  }
  const bool env_ok = normalise(l, &env);  // sum >= 1 by construction
  if (!env_ok) {
    for (std::size_t i = 0; i < l; ++i) env[i] = 1.0 / static_cast<double>(l);
  }
  return env;
}

void MarkovPredictor::sweep_library(const ObstacleState& obstacle, const OccupancyQuery& map,
                                    const FarFieldLayer* far_field,
                                    std::array<PathClearance, kMaxPaths>* clear) noexcept {
  // Paths turning the same way share their arc up to where the gentler one goes straight. The
  // sharpest path of each side is swept first, its chords ending at the other paths' turn ends;
  // a gentler path takes its hit when it lies on the shared arc, else is swept from its own turn
  // end on. The same result as sweeping each path with those chord ends, for far less work with
  // turns past 90 degrees.
  const std::size_t l = library_.size();
  const Eigen::Vector2f origin = obstacle.position.head<2>();
  const float speed = obstacle.velocity.norm();
  std::array<std::size_t, kMaxPaths> turn_end{};
  std::array<std::uint32_t, 2> breaks{};  // per side: 0 left, 1 right
  std::array<int, kMaxPaths> side{};      // -1: straight
  for (std::size_t i = 0; i < l; ++i) {
    library_.sample(i, origin, obstacle.velocity, &paths_[i]);
    const float theta = library_.heading_change(i);
    side[i] = theta > 0.0f ? 0 : (theta < 0.0f ? 1 : -1);
    if (side[i] < 0) continue;
    turn_end[i] = library_.turn_end_sample(i, speed);
    breaks[static_cast<std::size_t>(side[i])] |= 1u << turn_end[i];
  }
  const std::array<std::size_t, 2> sharpest = {0, l - 1};
  std::array<PathClearance, 2> shared{};  // the sharpest paths' map sweeps
  for (std::size_t s = 0; s < 2; ++s) {
    const std::size_t i = sharpest[s];
    if (side[i] != static_cast<int>(s)) continue;
    shared[s] =
        sweep_path(map, paths_[i], obstacle, config_.clearance, nullptr, SweepSpan{0, breaks[s]});
    (*clear)[i] = add_far_field(shared[s], paths_[i], obstacle, config_.clearance, far_field);
  }
  for (std::size_t i = 0; i < l; ++i) {
    if (side[i] < 0) {
      (*clear)[i] = sweep_path(map, paths_[i], obstacle, config_.clearance, far_field);
      continue;
    }
    const auto s = static_cast<std::size_t>(side[i]);
    if (i == sharpest[s]) continue;
    const PathClearance& arc = shared[s];
    if (!arc.free && arc.hit_chord < turn_end[i]) {
      // Up to the hit the samples are the sharpest path's, and so is the far-field check.
      (*clear)[i] = (*clear)[sharpest[s]];
    } else {
      // The shared arc is free in the map, and the sharpest path's far-field check covered it.
      const PathClearance own = sweep_path(map, paths_[i], obstacle, config_.clearance, nullptr,
                                           SweepSpan{turn_end[i], 0});
      const float far_on_arc = (*clear)[sharpest[s]].far_distance;
      if (far_on_arc <= paths_[i].arc_length[turn_end[i]]) {
        (*clear)[i] = own;
        block_at_far_wall(far_on_arc, &(*clear)[i]);
      } else {
        (*clear)[i] =
            add_far_field(own, paths_[i], obstacle, config_.clearance, far_field, turn_end[i] + 1);
      }
    }
  }
}

void MarkovPredictor::retry_turning_back(const ObstacleState& obstacle, const OccupancyQuery& map,
                                         const FarFieldLayer* far_field,
                                         std::array<PathClearance, kMaxPaths>* clear) noexcept {
  // A quarter turn plus a hair, so float spacing never counts the 90-degree path as turning back.
  constexpr float kQuarterTurn = 1.5717963f;
  const Eigen::Vector2f origin = obstacle.position.head<2>();
  const float speed = obstacle.velocity.norm();
  for (std::size_t i = 0; i < library_.size(); ++i) {
    if (std::fabs(library_.heading_change(i)) <= kQuarterTurn) continue;
    turn_back_library_.sample(i, origin, obstacle.velocity, &turn_back_path_);
    const std::size_t end = turn_back_library_.turn_end_sample(i, speed);
    const PathClearance c = sweep_path(map, turn_back_path_, obstacle, config_.clearance, far_field,
                                       SweepSpan{0, 1u << end});
    if (c.free_distance > (*clear)[i].free_distance) {
      (*clear)[i] = c;
      paths_[i] = turn_back_path_;  // the chosen path's samples are written from paths_
    }
  }
}

MarkovPredictor::Belief MarkovPredictor::update_belief(std::uint32_t track_id,
                                                       const Belief& env) noexcept {
  // prior = P(t) * P_trans, or P_init for a new track; post = prior (.) P_env, normalised, is
  // what the choice is made on and what is kept for the next frame (P_env compounds).
  const std::size_t l = library_.size();
  bool inserted = false;
  Belief* state = beliefs_.find_or_insert(track_id, inserted);
  const bool fresh = inserted || state == nullptr;
  Belief prior{};
  if (fresh) {
    prior = initial_;
  } else {
    for (std::size_t j = 0; j < l; ++j) {
      double pred = 0.0;
      for (std::size_t i = 0; i < l; ++i) pred += (*state)[i] * trans_[i][j];
      prior[j] = pred;
    }
  }
  Belief post{};
  for (std::size_t j = 0; j < l; ++j) post[j] = prior[j] * env[j];
  if (!normalise(l, &post)) {
    // The old belief and the map disagree beyond double precision: restart from the prior.
    ++underflow_restarts_;
    for (std::size_t j = 0; j < l; ++j) post[j] = initial_[j] * env[j];
    if (!normalise(l, &post)) post = env;
  }
  if (state != nullptr) *state = post;  // nullptr only if the table were full (it cannot be)
  return post;
}

std::size_t MarkovPredictor::choose_path(const Belief& post,
                                         const PathPrediction& out) const noexcept {
  // Most likely path (among the free ones when choose_free and any is free). Exact ties go to
  // the one nearer the straight path, then (mirror pairs) to the one free for longer.
  const std::size_t l = library_.size();
  const float centre = library_.center_index();
  const bool only_free = config_.choose_free && out.any_free;
  std::size_t best = l;
  for (std::size_t i = 0; i < l; ++i) {
    if (only_free && !out.path_free(i)) continue;
    if (best == l) {
      best = i;
      continue;
    }
    const float off_i = std::fabs(static_cast<float>(i) - centre);
    const float off_best = std::fabs(static_cast<float>(best) - centre);
    const bool better = post[i] > post[best];
    const bool tie = post[i] == post[best];
    const bool tie_nearer = tie && off_i < off_best;
    const bool tie_seen =
        tie && off_i == off_best && out.free_distance[i] > out.free_distance[best];
    if (better || tie_nearer || tie_seen) best = i;
  }
  if (best == l) return 0;  // l >= 1: best == l only if no path was considered (cannot be)
  // Never prefer a worse bet: straight when it is free and no path is better supported.
  const std::size_t straight = (l - 1) / 2;  // the straight path when l is odd
  if (config_.straight_when_free && l % 2 == 1 && out.path_free(straight) &&
      out.free_distance[straight] >= out.free_distance[best]) {
    return straight;
  }
  return best;
}

}  // namespace dynamap
