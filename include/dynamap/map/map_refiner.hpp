// MapRefiner: tightens the detector's raw boxes against the occupancy map (docs/design.md §4.3).
// Each raw box is inflated by C_inflate; occupied voxels overlapping it (plus voxels of a caller's
// "clean history", which were freed because a dynamic obstacle passed but still count) that are
// above the floor band give the refined box, their tight voxel bounds. Bounded work per box.
#pragma once

#include <cstddef>
#include <cstdint>

#include "dynamap/core/detection.hpp"
#include "dynamap/core/fixed_vector.hpp"
#include "dynamap/core/status.hpp"
#include "dynamap/core/types.hpp"
#include "dynamap/map/occupancy_map.hpp"

namespace dynamap {

/// Non-virtual set-membership callback over voxel keys (e.g. the clean history of dynamic
/// regions). An empty lookup (contains == nullptr) contains nothing.
struct VoxelLookup {
  const void* ctx = nullptr;
  bool (*contains)(const void* ctx, std::uint64_t key) noexcept = nullptr;

  bool has(std::uint64_t key) const noexcept { return contains != nullptr && contains(ctx, key); }
  bool empty() const noexcept { return contains == nullptr; }
};

/// Upper bound of MapRefinerConfig::max_voxels_per_box (the pipeline bounds the product with
/// the detection count further, kMaxRefinerVoxelsPerFrame).
inline constexpr std::size_t kMaxRefinerVoxelsPerBox = std::size_t{1} << 20;

/// Parameters of the refinement (defaults from the original system).
/// Upper bound of MapRefinerConfig::static_frames (the map reads ages up to 2^14 ticks).
inline constexpr std::size_t kMaxStaticFrames = 100000;

struct MapRefinerConfig {
  float inflate = 1.15f;      ///< C_inflate: raw box extents are multiplied by this
  float floor_margin = 0.2f;  ///< voxels whose centre is below ground + margin are ignored
  std::size_t max_voxels_per_box = 16384;  ///< work cap per box and per pass (map, history)
  std::size_t min_support_voxels = 1;      ///< fewer support voxels -> keep the raw box
  /// Detection::static_share counts voxels occupied without a break for at least this many
  /// frames (1 s): longer than a walking body stays on a voxel.
  std::size_t static_frames = 30;
};

/// Counters of the last refine() call.
struct MapRefinerStats {
  std::size_t refined = 0;
  std::size_t unrefined = 0;       ///< no (or too little) support: raw box kept
  std::size_t truncated = 0;       ///< boxes larger than the voxel cap (partly examined)
  std::size_t support_voxels = 0;  ///< summed over boxes (map + history, may count twice)
};

/// Stateless apart from configuration and counters; refine() allocates nothing.
class MapRefiner {
 public:
  /// kInvalidArgument (previous configuration kept) when a parameter is out of range or
  /// `ground_height` (map-frame z of the floor, m; PipelineConfig::ground_height) is not finite.
  [[nodiscard]] Status init(const MapRefinerConfig& config, float ground_height) noexcept;
  /// Ground height may follow the vehicle's estimate frame by frame.
  [[nodiscard]] Status set_ground_height(float z) noexcept;

  /// Refines detections[0..count): box = tight voxel box of the support (refined = true), or
  /// box = raw_box (refined = false). raw_box is the input and is never modified. On bad input
  /// (non-finite or inverted raw box, uninitialised map or refiner) nothing is changed.
  [[nodiscard]] Status refine(const OccupancyMap& map, const VoxelLookup& clean_history,
                              Detection* detections, std::size_t count) noexcept;
  template <std::size_t N>
  [[nodiscard]] Status refine(const OccupancyMap& map, const VoxelLookup& clean_history,
                              FixedVector<Detection, N>& detections) noexcept {
    return refine(map, clean_history, detections.data(), detections.size());
  }

  const MapRefinerConfig& config() const noexcept { return config_; }
  float ground_height() const noexcept { return ground_height_; }
  const MapRefinerStats& last_stats() const noexcept { return stats_; }

 private:
  void refine_one(const OccupancyMap& map, const VoxelLookup& clean, Detection& d) noexcept;
  /// Sets d.box from the support's voxel bounds `refined` (or keeps the raw box).
  void apply_support(Box3 refined, std::size_t support, Detection& d) noexcept;
  /// Detection::static_share of a raw box.
  float static_share(const OccupancyMap& map, const Box3& raw_box, float floor_top) const noexcept;

  MapRefinerConfig config_{};
  float ground_height_ = 0.f;
  bool initialized_ = false;
  MapRefinerStats stats_{};
};

}  // namespace dynamap
