// TrailGrid: the floor cells that dynamic tracks' boxes covered in the last few seconds. The
// occupancy map keeps a box face whose inside it never saw (OccupancyMapConfig::
// keep_unknown_backed), but a walker leaving the view at the image's side looks the same to the
// map; where a dynamic track has been, the map lowers such voxels as before. Fixed size, no heap;
// the horizontal axes wrap (a cell remembers which column it holds, as EverFreeGrid's do).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>

#include <Eigen/Core>

#include "dynamap/core/status.hpp"
#include "dynamap/core/types.hpp"

namespace dynamap {

/// Cells per horizontal axis (the grid wraps: 64 x 0.25 m = 16 m, more than the map's local
/// region, before a cell is reused).
inline constexpr int kTrailColumns = 64;

/// Parameters of the trail grid; defaults in docs/occupancy_map.md.
struct TrailGridConfig {
  float resolution = 0.25f;    ///< cell edge (m)
  std::uint32_t frames = 150;  ///< a mark counts for this many frames (5 s at 30 Hz)
  float margin = 0.2f;         ///< metres added around each box before marking

  /// kInvalidArgument when a field is outside its range (params::kTrailGrid).
  Status validate() const noexcept;
};

class TrailGrid {
 public:
  /// Validates and applies `config` (kInvalidArgument, nothing changed, when out of range) and
  /// forgets every mark.
  [[nodiscard]] Status init(const TrailGridConfig& config) noexcept;
  void clear() noexcept;

  /// Starts a frame: marks older than `frames` frames stop counting.
  void next_frame() noexcept { ++frame_; }
  /// Marks the cells under `box` grown by `margin` (at most kTrailColumns per axis; a
  /// non-finite box marks nothing).
  void mark(const Box3& box) noexcept;
  /// Marks where the dynamic tracks of `tracker` (a Tracker, or anything with its size /
  /// obstacle / box_history_size / past_box) are and, in turn, where they were: every frame a
  /// track's newest box and every kOlderBoxPeriod-th of its older ones, so its whole history is
  /// marked within kOlderBoxPeriod frames of its label.
  template <class Tracks>
  void mark_dynamic_tracks(const Tracks& tracker) noexcept {
    for (std::size_t i = 0; i < tracker.size(); ++i) {
      if (!tracker.obstacle(i).dynamic) continue;
      const std::size_t n = tracker.box_history_size(i);
      for (std::size_t b = 0; b < n; ++b) {
        if (b == 0 || (b + frame_) % kOlderBoxPeriod == 0) mark(tracker.past_box(i, b));
      }
    }
  }
  /// True when the column holding `p` was marked within the last `frames` frames.
  bool recent(const Eigen::Vector3f& p) const noexcept;
  const TrailGridConfig& config() const noexcept { return config_; }

  static constexpr std::size_t kOlderBoxPeriod = 8;

 private:
  struct Cell {
    std::int32_t x = 0, y = 0;
    std::uint64_t frame = 0;  // frame_ when last marked; 0: never
  };
  static std::size_t slot(std::int32_t x, std::int32_t y) noexcept {
    constexpr std::int32_t m = kTrailColumns - 1;
    return static_cast<std::size_t>(y & m) * kTrailColumns + static_cast<std::size_t>(x & m);
  }

  TrailGridConfig config_{};
  float inv_resolution_ = 4.f;
  std::uint64_t frame_ = 1;
  std::array<Cell, static_cast<std::size_t>(kTrailColumns) * kTrailColumns> cells_{};
};

}  // namespace dynamap
