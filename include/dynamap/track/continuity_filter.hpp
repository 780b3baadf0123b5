// Static/dynamic identification of a track: the continuity filter (does the obstacle keep moving
// in a consistent direction?) gives a per-frame vote, and DynamicVoter turns the last c votes
// into a label with hysteresis. See docs/tracker.md for the direction of the C_con test.
#pragma once

#include <cstddef>
#include <cstdint>

#include <Eigen/Core>

#include "dynamap/core/status.hpp"

namespace dynamap {

/// Longest voting window DynamicVoter can hold (one bit per vote).
inline constexpr std::size_t kMaxVoteWindow = 64;

/// Parameters of the continuity filter and the vote. Defaults follow the original code
/// (n = 10, v_min = 0.4 m/s, c = 20, T_c = 16, static at <= 4); T_con = 0.7 is ours.
struct ContinuityConfig {
  std::size_t displacement_frames = 10;  ///< n: displacements span n history states
  float continuity_threshold = 0.7f;     ///< T_con: C_con >= T_con passes (see docs)
  float min_speed = 0.4f;                ///< v_min (m/s): slower obstacles vote static
  std::size_t vote_window = 20;          ///< c: votes kept (<= kMaxVoteWindow)
  std::size_t dynamic_votes = 16;        ///< T_c: >= this many dynamic votes -> dynamic
  std::size_t static_votes = 4;          ///< <= this many dynamic votes -> static
  /// Plausibility test on the obstacle size: a frame votes dynamic only when min_size <= size <=
  /// max_size on every axis. On by default with upper limits only: the pieces of wall that slide
  /// as the camera moves are as tall as the wall in view (2.5 m), people are not; a box wider
  /// than 1 m spans two people or a person and the background between them (real depth);
  /// partly hidden people have small boxes, so there is no lower limit (docs/tracker.md,
  /// "Static or dynamic"). Raise max_size to track larger movers (vehicles), or turn it off.
  bool check_size = true;
  Eigen::Vector3f min_size{0.f, 0.f, 0.f};
  Eigen::Vector3f max_size{1.0f, 1.0f, 2.2f};

  /// kInvalidArgument when a field is outside its range or breaks a relation with another
  /// (params::kContinuity and kContinuityRelations, track_params.hpp).
  Status validate() const noexcept;
};

/// C_con of a position history (oldest first): displacement d_i = p[i + n] - p[i] for every i,
/// then the mean cosine of the angle between consecutive displacements d_i, d_(i+1).
/// Returns false (and leaves *score alone) when count < n + 2, i.e. fewer than two displacements.
/// A zero-length displacement has no direction and contributes a cosine of 0.
bool continuity_score(const Eigen::Vector2f* positions, std::size_t count, std::size_t n,
                      float* score) noexcept;

/// Per-frame vote of the continuity filter: dynamic when speed > v_min, C_con >= T_con and (if
/// enabled) the size is plausible.
class ContinuityFilter {
 public:
  explicit ContinuityFilter(const ContinuityConfig& config = {}) noexcept : config_(config) {}
  bool vote(float speed, float c_con, const Eigen::Vector3f& size) const noexcept;
  const ContinuityConfig& config() const noexcept { return config_; }

 private:
  ContinuityConfig config_;
};

/// Sliding window of the last c votes with hysteresis: >= T_c dynamic votes -> dynamic,
/// <= static_votes -> static, otherwise the label stays. Fixed size (a 64-bit ring).
class DynamicVoter {
 public:
  void reset() noexcept { *this = DynamicVoter{}; }
  /// Adds one vote (dropping the oldest once c are held) and updates the label.
  void push(bool dynamic_vote, const ContinuityConfig& config) noexcept;
  bool dynamic() const noexcept { return dynamic_; }
  std::size_t dynamic_votes() const noexcept { return dynamic_votes_; }
  std::size_t votes() const noexcept { return count_; }

 private:
  std::uint64_t bits_ = 0;  ///< bit i = vote i frames ago
  std::size_t count_ = 0;
  std::size_t dynamic_votes_ = 0;
  bool dynamic_ = false;
};

}  // namespace dynamap
