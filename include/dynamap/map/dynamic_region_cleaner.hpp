// DynamicRegionCleaner: frees the occupancy-map voxels under dynamic tracks' recent boxes (the
// trail a walker leaves in the map) and remembers them in the clean history, which the map
// refiner counts as occupied. Work per frame is capped by a voxel budget.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>

#include <Eigen/Core>

#include "dynamap/core/constants.hpp"
#include "dynamap/core/status.hpp"
#include "dynamap/core/types.hpp"
#include "dynamap/map/clean_history.hpp"

namespace dynamap {

/// Upper bound of DynamicRegionCleanerConfig::max_voxels_per_frame.
inline constexpr std::size_t kMaxCleanerVoxelsPerFrame = 1'000'000;

/// Cleaning parameters. Original: f = 50 frames, boxes × 1.15 with z ± 0.2 m. The round robin
/// over older boxes and the voxel budget are ours (bounded work per frame).
struct DynamicRegionCleanerConfig {
  std::size_t frames = 50;  ///< f: past boxes per track considered (<= kMaxBoxHistory)
  float inflation = 1.15f;  ///< horizontal extent factor about the box centre
  float z_margin = 0.2f;    ///< metres added below and above
  /// Every frame each dynamic track clears its newest box plus about this many older ones, taken
  /// in turn, so every box of the last f frames is revisited at least every ceil((f - 1) / n)
  /// frames (0: newest box only).
  std::size_t older_boxes_per_frame = 3;
  /// A voxel occupied without a break since at least this many frames before a dynamic track
  /// started is static structure (a wall the walker brushes past, a box it turns in front of):
  /// that track's boxes never clear it. Walkers' trails became occupied after their track
  /// started and are cleared as before.
  bool keep_static = true;
  std::size_t static_margin_frames = 30;
  /// A track clears nothing until it has been dynamic this many frames in a row
  /// (TrackedObstacle::dynamic_frames): a label that holds for one frame is weak evidence, and
  /// in a run's first second, when no voxel is old enough for keep_static, one such label of a
  /// wall piece clears the wall along all its track's past boxes. The boxes stay in the history
  /// (f frames), so a walker's trail is cleared once its label has held.
  std::size_t min_dynamic_frames = 2;
  /// The same for a track that started in the run's first static_margin_frames frames, where
  /// keep_static has nothing old enough to keep: there a false label of a box face the camera
  /// saw from the start (a sliver at the image border of a flying camera) clears the face.
  /// Walkers' trails from the run's start wait longer; their boxes stay in the history.
  std::size_t early_min_dynamic_frames = 20;
  std::size_t max_voxels_per_frame = 100000;  ///< cap on voxels examined per frame (all tracks)
  std::size_t max_purge_per_frame = 4096;     ///< cap on expired history entries purged per frame

  /// kInvalidArgument when a field is outside its range (params::kDynamicRegionCleaner).
  Status validate() const noexcept;
};

/// What the last clean() did.
struct CleanStats {
  std::size_t dynamic_tracks = 0;
  std::size_t tracks_waiting = 0;  ///< dynamic, but for fewer than min_dynamic_frames frames
  std::size_t boxes_cleared = 0;
  std::size_t voxels_budgeted = 0;  ///< voxels the scanned boxes span (upper bound of work)
  std::size_t voxels_freed = 0;
  std::size_t boxes_skipped = 0;  ///< boxes left for later because the budget ran out
};

class DynamicRegionCleaner {
 public:
  /// Validates and applies `config`; nothing below height `min_z` (map frame, m) is ever cleared
  /// (the pipeline passes ground_height + refiner.floor_margin). Bad config or non-finite min_z:
  /// kInvalidArgument, nothing changes.
  [[nodiscard]] Status init(const DynamicRegionCleanerConfig& config, float min_z) noexcept {
    const Status s = config.validate();
    if (!ok(s)) return s;
    if (!std::isfinite(min_z)) return Status::kInvalidArgument;
    config_ = config;
    min_z_ = min_z;
    frame_ = 0;
    has_stamp_ = false;
    return Status::kOk;
  }

  /// Clears the recent boxes of every dynamic track of `tracker` (a Tracker, or anything with its
  /// size / obstacle / box_history_size / past_box) in `map` (an OccupancyMap, or anything with its
  /// clear_box / resolution / frames_integrated), keeping static structure (keep_static) and
  /// records freed voxels in `history` at `stamp`. kTimeNotIncreasing (nothing changes) when stamp
  /// is not after the previous call's.
  template <class Tracks, class Map, std::size_t Capacity>
  [[nodiscard]] Status clean(const Tracks& tracker, Map& map, BasicCleanHistory<Capacity>& history,
                             Stamp stamp) noexcept {
    if (has_stamp_ && stamp <= last_stamp_) return Status::kTimeNotIncreasing;
    last_stamp_ = stamp;
    has_stamp_ = true;
    stats_ = CleanStats{};
    history.expire(stamp, config_.max_purge_per_frame);

    const float res = map.resolution();
    std::size_t budget = config_.max_voxels_per_frame;
    auto record = [&history, stamp](std::uint64_t key, const Eigen::Vector3f&) {
      history.insert(key, stamp);
    };
    std::uint64_t keep_frames = 0;  // the current track's: older voxels are static structure
    const std::uint64_t run_frames = map.frames_integrated();  // this frame included
    auto clear_one = [&](const Box3& past) -> bool {
      const Box3 region = inflate(past);
      const std::size_t cost = voxel_span(region, res);
      if (cost > budget) {
        ++stats_.boxes_skipped;
        return false;
      }
      budget -= cost;
      stats_.voxels_budgeted += cost;
      stats_.voxels_freed += map.clear_box(region, cost, keep_frames, record);
      ++stats_.boxes_cleared;
      return true;
    };

    // Start with a different track each frame so a tight budget does not starve the same ones.
    const std::size_t n_tracks = tracker.size();
    for (std::size_t step = 0; step < n_tracks; ++step) {
      const std::size_t i = (step + frame_) % n_tracks;
      if (!tracker.obstacle(i).dynamic) continue;
      ++stats_.dynamic_tracks;
      if (tracker.obstacle(i).dynamic_frames < min_frames(tracker.obstacle(i).age, run_frames)) {
        ++stats_.tracks_waiting;
        continue;
      }
      keep_frames = config_.keep_static
                        ? std::uint64_t{tracker.obstacle(i).age} + config_.static_margin_frames
                        : ~std::uint64_t{0};
      std::size_t n_boxes = tracker.box_history_size(i);
      if (n_boxes > config_.frames) n_boxes = config_.frames;
      if (n_boxes == 0) continue;
      (void)clear_one(tracker.past_box(i, 0));  // where it is now
      if (config_.older_boxes_per_frame == 0) continue;
      // Older boxes in turn: box number b (counted since the track started) is revisited on the
      // frames where b = frame (mod period), i.e. at least once every `period` frames.
      const std::size_t period =
          (config_.frames - 1 + config_.older_boxes_per_frame - 1) / config_.older_boxes_per_frame;
      if (period == 0) continue;
      const std::size_t newest = tracker.obstacle(i).hits - 1;  // one box per matched frame
      const std::size_t phase = frame_ % period;
      std::size_t age = (newest + period - phase) % period;  // newest - age = phase (mod period)
      if (age == 0) age = period;
      for (; age < n_boxes; age += period) (void)clear_one(tracker.past_box(i, age));
    }
    ++frame_;
    return Status::kOk;
  }

  const CleanStats& last_stats() const noexcept { return stats_; }
  const DynamicRegionCleanerConfig& config() const noexcept { return config_; }

 private:
  /// Frames a track of `age` frames must have been dynamic before it clears, the map having
  /// integrated `run_frames` frames (this one included).
  std::size_t min_frames(std::uint64_t age, std::uint64_t run_frames) const noexcept {
    const std::uint64_t started = run_frames >= age ? run_frames - age : 0;
    const bool unprotected = config_.keep_static && started < config_.static_margin_frames;
    return unprotected ? std::max(config_.min_dynamic_frames, config_.early_min_dynamic_frames)
                       : config_.min_dynamic_frames;
  }

  Box3 inflate(const Box3& b) const noexcept {
    const Eigen::Vector3f c = b.center();
    const Eigen::Vector3f half = 0.5f * b.size();
    Box3 r;
    r.min.head<2>() = c.head<2>() - config_.inflation * half.head<2>();
    r.max.head<2>() = c.head<2>() + config_.inflation * half.head<2>();
    r.min.z() = std::fmax(b.min.z() - config_.z_margin, min_z_);
    r.max.z() = b.max.z() + config_.z_margin;
    return r;
  }
  /// Voxels a box spans (what clear_box may examine), with room for partial voxels at the edges
  /// and one visit per 8^3 block.
  static std::size_t voxel_span(const Box3& b, float res) noexcept {
    std::size_t voxels = 1;
    std::size_t blocks = 1;
    for (int a = 0; a < 3; ++a) {
      const float extent = b.max[a] - b.min[a];
      const std::size_t n = static_cast<std::size_t>(extent > 0.f ? extent / res : 0.f) + 2;
      voxels *= n;
      blocks *= n / 8 + 2;
    }
    return voxels + blocks;
  }

  DynamicRegionCleanerConfig config_{};
  float min_z_ = -1000.f;
  CleanStats stats_{};
  std::size_t frame_ = 0;
  Stamp last_stamp_ = 0;
  bool has_stamp_ = false;
};

}  // namespace dynamap
