#include "dynamap/track/continuity_filter.hpp"

#include <cmath>

#include "dynamap/track/track_params.hpp"

namespace dynamap {

Status ContinuityConfig::validate() const noexcept {
  return all_in_range(*this, params::kContinuity) && all_hold(*this, params::kContinuityRelations)
             ? Status::kOk
             : Status::kInvalidArgument;
}

bool continuity_score(const Eigen::Vector2f* positions, std::size_t count, std::size_t n,
                      float* score) noexcept {
  if (positions == nullptr || n == 0 || count < n + 2) return false;
  const std::size_t displacements = count - n;
  float sum = 0.f;
  Eigen::Vector2f previous = positions[n] - positions[0];
  for (std::size_t i = 1; i < displacements; ++i) {
    const Eigen::Vector2f d = positions[i + n] - positions[i];
    const float norms = previous.norm() * d.norm();
    if (norms > 1e-12f) sum += previous.dot(d) / norms;
    previous = d;
  }
  *score = sum / static_cast<float>(displacements - 1);
  return true;
}

bool ContinuityFilter::vote(float speed, float c_con, const Eigen::Vector3f& size) const noexcept {
  // The original code (and the maths: consistent motion gives cosines near 1) marks a candidate
  // dynamic when C_con >= T_con; the paper's text states the opposite inequality.
  if (!(speed > config_.min_speed) || !(c_con >= config_.continuity_threshold)) return false;
  if (config_.check_size) {
    if ((size.array() < config_.min_size.array()).any()) return false;
    if ((size.array() > config_.max_size.array()).any()) return false;
  }
  return true;
}

void DynamicVoter::push(bool dynamic_vote, const ContinuityConfig& config) noexcept {
  const std::size_t window = config.vote_window;
  if (count_ == window) {
    // The oldest vote falls out of the window.
    if ((bits_ >> (window - 1)) & 1u) --dynamic_votes_;
  } else {
    ++count_;
  }
  const std::uint64_t mask = window >= 64 ? ~std::uint64_t{0} : ((std::uint64_t{1} << window) - 1);
  bits_ = ((bits_ << 1) | (dynamic_vote ? 1u : 0u)) & mask;
  if (dynamic_vote) ++dynamic_votes_;
  if (dynamic_votes_ >= config.dynamic_votes) {
    dynamic_ = true;
  } else if (dynamic_votes_ <= config.static_votes) {
    dynamic_ = false;
  }
}

}  // namespace dynamap
