// MarkovPredictor: environment-aware trajectory prediction (docs/design.md §4.6). Per track, a
// belief P over the l library paths evolves as P(t+1) = normalise((P(t) * P_trans) (.) P_env(t+1)),
// where P_env = softmax(beta * Dist) rewards paths with a long free distance in the static map.
// All state is inline (fixed capacity); predict() never allocates and does bounded work.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>

#include "dynamap/core/constants.hpp"
#include "dynamap/core/fixed_hash_map.hpp"
#include "dynamap/core/status.hpp"
#include "dynamap/predict/detail/path_sweep.hpp"
#include "dynamap/predict/path_library.hpp"
#include "dynamap/predict/prediction.hpp"

namespace dynamap {

/// Path family, footprint check and the Markov chain's parameters.
struct MarkovPredictorConfig {
  PathLibraryConfig paths{};
  ClearanceConfig clearance{};
  /// Standard deviations, in radians of heading change (converted to path indices with the
  /// library's spacing 2*max_heading_change/(l-1)), so the chain behaves alike for any l.
  /// The defaults are one path spacing of the default library (45 degrees).
  float sigma_init = 0.7853982f;   ///< of P_init around the straight path
  float sigma_trans = 0.7853982f;  ///< of each P_trans row around its diagonal
  float beta = 2.0f;  ///< 1/m: P_env = softmax(beta * free distance); 0 ignores the map
  /// Output the most likely of the paths that are free in the map, when at least one is, instead
  /// of the most likely path overall. P_env is soft (a path blocked at 2.9 m of a 3 m horizon
  /// scores nearly as well as a free one), so the plain maximum can pick a path the predictor
  /// itself knows collides (out->failed) while a free one is almost as likely. The belief and
  /// the probabilities are the same either way; only the choice differs. false: the plain
  /// maximum (docs/design.md §4.6 as written).
  bool choose_free = true;
  /// Output the straight path whenever it is free (map and far-field layer) and no path has a
  /// larger Dist (P_env's support): a turn is chosen only when the environment argues for it.
  /// The compounded belief keeps old turns and drifts to the middle of the free set along a wall
  /// (docs/predictor.md, "Choice"), and with nothing in the map to tell them apart it picked
  /// turns into walls it had not seen. Only the choice changes, not the belief.
  bool straight_when_free = true;
  /// 1/m; 0 = off. When no path is free in the map and the far-field layer, the paths turning
  /// back (more than 90 degrees) are swept again at this curvature (1/3 m radius: about a
  /// body's) and keep whichever radius runs freer: a walker facing a wall or standing in a bay
  /// turns on the spot, tighter than the library's corner radius. Tighter U-turns for every
  /// walker lost where a wider turn was free (rooms, corridor corners), so only then.
  float turn_back_curvature = 3.0f;
};

/// Slots of the per-track belief table (power of two, max load 7/8 >= kMaxTracks).
inline constexpr std::size_t kPredictorTrackSlots = 64;
static_assert(kPredictorTrackSlots - kPredictorTrackSlots / 8 >= kMaxTracks,
              "belief table must hold every track");

/// The Markov-chain predictor. Holds one belief vector per track id, forgets a track as soon as
/// a frame arrives without it. Probabilities are kept in double and renormalised every frame.
class MarkovPredictor {
 public:
  using Belief = std::array<double, kMaxPaths>;

  /// kInvalidArgument (and nothing changes) on an out-of-range or non-finite parameter.
  [[nodiscard]] Status init(const MarkovPredictorConfig& config) noexcept;

  /// One frame: predicts obstacles[0..count) into out[0..count) (same order) against `map`.
  /// Tracks not in this call are forgotten; new ids start from P_init (.) P_env.
  /// Errors (state unchanged): kNotInitialized; kNullData (null arrays with count > 0, invalid
  /// map view); kCapacityExceeded (count > kMaxTracks); kNonFinite / kInvalidArgument (an
  /// obstacle's numbers, or a track id given twice).
  /// Work: count x l x (samples - 1) x lines x height_levels segment queries at most.
  [[nodiscard]] Status predict(const ObstacleState* obstacles, std::size_t count,
                               const OccupancyQuery& map, PathPrediction* out) noexcept {
    return predict(obstacles, count, map, nullptr, out);
  }
  /// The same with the far-field layer (nullptr or not enabled: not used): its remembered walls
  /// block paths like the map's occupied voxels (prediction.hpp, sweep_path).
  [[nodiscard]] Status predict(const ObstacleState* obstacles, std::size_t count,
                               const OccupancyQuery& map, const FarFieldLayer* far_field,
                               PathPrediction* out) noexcept;

  /// Forgets every track.
  void reset() noexcept { beliefs_.clear(); }

  const MarkovPredictorConfig& config() const noexcept { return config_; }
  const PathLibrary& library() const noexcept { return library_; }
  std::size_t num_paths() const noexcept { return library_.size(); }
  /// A sigma of the config in path indices.
  double sigma_in_indices(float sigma_rad) const noexcept;
  /// P_init[i].
  double initial(std::size_t i) const noexcept { return initial_[i]; }
  /// P_trans[from][to]: probability of switching from path `from` to path `to` in one frame.
  double transition(std::size_t from, std::size_t to) const noexcept { return trans_[from][to]; }
  /// Number of tracks with a belief.
  std::size_t tracked() const noexcept { return beliefs_.size(); }
  /// Copies the belief of `track_id` as kept for the next frame (the posterior); false when the
  /// track is unknown.
  bool belief(std::uint32_t track_id, Belief* out) const noexcept;
  /// Frames in which (P * P_trans) (.) P_env underflowed and the belief was restarted.
  std::uint64_t underflow_restarts() const noexcept { return underflow_restarts_; }

 private:
  void predict_one(const ObstacleState& obstacle, const OccupancyQuery& map,
                   const FarFieldLayer* far_field, PathPrediction* out) noexcept;
  // The steps of predict_one: sample and sweep every path (distances and masks into `out`) and
  // return P_env; update the track's belief with P_env and return the posterior; pick the path.
  Belief sweep_paths(const ObstacleState& obstacle, const OccupancyQuery& map,
                     const FarFieldLayer* far_field, PathPrediction* out) noexcept;
  // Samples every path into paths_ and sweeps it, sharing each side's turning arc.
  void sweep_library(const ObstacleState& obstacle, const OccupancyQuery& map,
                     const FarFieldLayer* far_field,
                     std::array<PathClearance, kMaxPaths>* clear) noexcept;
  // With nothing free, sweeps the paths turning back again at turn_back_curvature.
  void retry_turning_back(const ObstacleState& obstacle, const OccupancyQuery& map,
                          const FarFieldLayer* far_field,
                          std::array<PathClearance, kMaxPaths>* clear) noexcept;
  Belief update_belief(std::uint32_t track_id, const Belief& env) noexcept;
  std::size_t choose_path(const Belief& post, const PathPrediction& out) const noexcept;

  MarkovPredictorConfig config_{};
  PathLibrary library_{};
  PathLibrary turn_back_library_{};  // library_ at turn_back_curvature (when it is on)
  bool initialised_ = false;
  Belief initial_{};
  std::array<Belief, kMaxPaths> trans_{};
  FixedHashMap<std::uint32_t, Belief, kPredictorTrackSlots> beliefs_{};
  std::array<PathSamples, kMaxPaths> paths_{};  // scratch: one obstacle's sampled paths
  PathSamples turn_back_path_{};                // scratch: one path at turn_back_curvature
  std::uint64_t underflow_restarts_ = 0;
};

}  // namespace dynamap
