// OccupancyMap: log-odds occupancy on a hashed voxel grid with a budget fixed at compile time.
// Blocks of 8x8x8 voxels live in an inline pool located through an open-addressing table, so
// the object never allocates after construction and can be a static global (it is ~9 MB: never
// put one on the stack). See docs/occupancy_map.md for the layout, update rule and eviction.
#pragma once

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstddef>
#include <cstdint>

#include <Eigen/Core>

#include "dynamap/core/constants.hpp"
#include "dynamap/core/status.hpp"
#include "dynamap/core/types.hpp"
#include "dynamap/map/detail/block_store.hpp"
#include "dynamap/map/detail/map_integrator.hpp"
#include "dynamap/map/occupancy_map_config.hpp"

namespace dynamap {

/// The static occupancy map. Single-threaded: integrate() and clear_box() mutate; the const
/// queries may run concurrently with each other but not with a mutation.
class OccupancyMap {
 public:
  using VoxelKey = std::uint64_t;  ///< packed signed integer voxel indices (i, j, k), 21 bits each

  static constexpr int kBlockBits = detail::kBlockBits;
  static constexpr int kBlockEdge = detail::kBlockEdge;  ///< voxels per block edge
  static constexpr std::size_t kBlockVoxels = detail::kBlockVoxels;
  /// Hash table slots: power of two, load <= kMaxMapBlocks / kBlockTableCapacity = 0.5.
  static constexpr std::size_t kBlockTableCapacity = detail::BlockStore::kTableCapacity;
  /// Voxel indices representable in a key: [-kKeyHalfRange, kKeyHalfRange).
  static constexpr std::int32_t kKeyHalfRange = detail::kKeyHalfRange;
  /// Upper bound on DDA steps of one segment query (longer segments are cut there).
  static constexpr std::size_t kMaxSegmentVisits = 1 << 16;
  /// Cells of the per-frame dense block cache over the local region (default region: 3179).
  static constexpr std::size_t kLocalGridCells = detail::kLocalGridCells;
  /// Log-odds are stored as int16 in units of 1/kLogOddsScale.
  static constexpr float kLogOddsScale = detail::kLogOddsScale;

  OccupancyMap() noexcept;

  OccupancyMap(const OccupancyMap&) = delete;
  OccupancyMap& operator=(const OccupancyMap&) = delete;

  /// Validates `config` and empties the map. kInvalidArgument (map unchanged) when
  /// inconsistent or while a frame's integration is open (begin_integration()).
  [[nodiscard]] Status init(const OccupancyMapConfig& config) noexcept;
  /// Cells of the dense per-frame block grid over `config`'s local region (one block margin each
  /// side); tiled carving (carve_tiles > 0) needs at most kMaxTileCells.
  static std::size_t local_grid_cells(const OccupancyMapConfig& config) noexcept;
  /// Integrates one depth frame taken at T_map_camera. On any bad input returns its Status and
  /// changes nothing: kOutOfRange when the camera lies beyond max_abs_translation() (see
  /// check_pose_range()). Never fails for lack of space: far blocks are evicted instead.
  /// `team` (optional, the caller's): the tiled carving (carve_tiles > 0) runs on its members;
  /// the map is the same for every team. Without one, on the calling thread.
  [[nodiscard]] Status integrate(const DepthView& depth, const CameraIntrinsics& cam,
                                 const Pose& T_map_camera, Stamp stamp,
                                 TaskTeam* team = nullptr) noexcept;

  /// integrate() in three steps, for a team's owner that runs other work beside the carving
  /// (the pipeline runs detection): begin_integration() checks the input as integrate() does
  /// (nothing changed on a refusal; kInvalidArgument while a frame is open) and does the set-up
  /// and pass 1 on `team`; then every member m of one team.run() calls carve_share(m); then
  /// end_integration() applies the marks and closes the frame. Query the map only after it.
  [[nodiscard]] Status begin_integration(const DepthView& depth, const CameraIntrinsics& cam,
                                         const Pose& T_map_camera, Stamp stamp,
                                         TaskTeam& team) noexcept;
  void carve_share(unsigned member) noexcept { integrator_.carve_share(member); }
  void end_integration() noexcept { integrator_.finish(); }
  /// Where keep_unknown_backed does not apply: the cells `trail` marks as recently crossed by
  /// dynamic tracks (the pipeline's; nullptr, the default: everywhere). Read while integrating.
  void set_trail(const TrailGrid* trail) noexcept { integrator_.set_trail(trail); }

  Occupancy state(const Eigen::Vector3f& p) const noexcept;
  Occupancy state(VoxelKey key) const noexcept;
  float log_odds(const Eigen::Vector3f& p) const noexcept;  ///< 0 when unknown
  bool is_occupied(const Eigen::Vector3f& p) const noexcept;
  /// First occupied voxel on the segment a->b (3-D DDA); fills *hit (voxel centre) when found.
  bool first_occupied_on_segment(const Eigen::Vector3f& a, const Eigen::Vector3f& b,
                                 Eigen::Vector3f* hit) const noexcept;
  /// First voxel on the segment a->b that is not observed free (unknown or occupied), with the
  /// same 3-D DDA: fills *hit (voxel centre) and *state when found. Planners and the predictor
  /// use it to tell space seen to be free from space never seen
  /// (src/map/occupancy_map_queries.cpp). Work: one step per voxel crossed (no block is
  /// skipped), at most kMaxSegmentVisits; a longer segment reports its first unchecked voxel as
  /// unknown.
  bool first_non_free_on_segment(const Eigen::Vector3f& a, const Eigen::Vector3f& b,
                                 Eigen::Vector3f* hit, Occupancy* state = nullptr) const noexcept;

  /// Visits occupied voxels whose centre lies inside `box`; examines at most `max_voxels`
  /// (each block position looked up and each voxel read counts one).
  /// f(VoxelKey, const Eigen::Vector3f& centre). Returns the number of voxels visited.
  template <class F>
  std::size_t for_each_occupied_in_box(const Box3& box, std::size_t max_voxels, F&& f) const;
  /// Sets occupied voxels whose centre lies inside `box` to free (clamp minimum), except those
  /// occupied without a break for at least `keep_frames` frames (static structure; pass
  /// kKeepNone to clear all); on_cleared(VoxelKey, centre) for each changed voxel. Same budget
  /// as above. Returns the number of voxels changed.
  template <class F>
  std::size_t clear_box(const Box3& box, std::size_t max_voxels, std::uint64_t keep_frames,
                        F&& on_cleared);
  static constexpr std::uint64_t kKeepNone = ~std::uint64_t{0};
  /// Frames the voxel at p has been occupied without a break (to kSinceTickFrames; ages over
  /// kMaxSinceAgeTicks ticks read as that), 0 when it is not occupied.
  std::uint64_t occupied_frames(const Eigen::Vector3f& p) const noexcept;

  /// Sets one voxel's log-odds (clamped). kCapacityExceeded when its block cannot be allocated.
  [[nodiscard]] Status set_log_odds(const Eigen::Vector3f& p, float log_odds) noexcept;
  VoxelKey key_of(const Eigen::Vector3f& p) const noexcept;  ///< clamps to the key range
  /// Largest |component| (m) of a camera position integrate() accepts: half the key range
  /// (kKeyHalfRange / 2 voxels, 52 km at 0.1 m), so the local region around the camera and every
  /// ray in it stay far inside the key range.
  float max_abs_translation() const noexcept {
    return 0.5f * static_cast<float>(kKeyHalfRange) * params_.resolution;
  }
  /// kOk for a camera pose integrate() can represent; kNonFinite for NaN/inf; kOutOfRange for a
  /// finite translation beyond max_abs_translation() on some axis.
  [[nodiscard]] Status check_pose_range(const Pose& T_map_camera) const noexcept {
    if (!T_map_camera.translation.allFinite()) return Status::kNonFinite;
    if ((T_map_camera.translation.array().abs() > max_abs_translation()).any()) {
      return Status::kOutOfRange;
    }
    return Status::kOk;
  }
  Eigen::Vector3f center_of(VoxelKey key) const noexcept;
  float resolution() const noexcept { return params_.resolution; }
  float occupied_log_odds() const noexcept {
    return dequantize(params_.q_occupied);
  }  ///< threshold
  /// Whole footprint of the object (pool, table, scratch): sizeof, independent of contents.
  std::size_t memory_bytes() const noexcept { return sizeof(*this); }
  const IntegrationStats& last_stats() const noexcept { return integrator_.stats(); }
  /// Hash of all allocated blocks' voxel log-odds (order independent), for "unchanged" tests.
  std::uint64_t checksum() const noexcept;
  /// Whole map, tools only: f(VoxelKey, const Eigen::Vector3f& centre) for each occupied voxel.
  template <class F>
  void for_each_occupied(F&& f) const;
  /// Tests and tools only (O(pool)): f(VoxelKey, bool hit) for each voxel the last integrate()
  /// updated, hit (true) or miss (false).
  template <class F>
  void for_each_updated_last_frame(F&& f) const;

  // Added beyond the shared contract.
  const OccupancyMapConfig& config() const noexcept { return params_.config; }
  /// Changes the pixel sampling stride between frames (the pipeline's adaptive budget mode
  /// coarsens it under load). kInvalidArgument, and no change, outside 1..kMaxImageWidth.
  [[nodiscard]] Status set_pixel_stride(int stride) noexcept {
    if (stride < 1 || stride > kMaxImageWidth) return Status::kInvalidArgument;
    params_.config.pixel_stride = stride;
    return Status::kOk;
  }
  bool initialized() const noexcept { return initialized_; }
  std::size_t blocks_in_use() const noexcept { return store_.blocks_in_use(); }
  std::size_t total_blocks_evicted() const noexcept { return store_.total_evicted(); }
  std::uint64_t frames_integrated() const noexcept { return store_.frames(); }

 private:
  void reset_storage() noexcept;  // empties the block store and the counters
  using Voxel = detail::Voxel;
  using Block = detail::Block;
  using IndexVec = detail::IndexVec;
  static constexpr std::int16_t kUnknown = detail::kUnknownLogOdds;
  static constexpr std::uint16_t kQueued = detail::kStampQueued;
  static constexpr std::uint16_t kHit = detail::kStampHit;
  static constexpr std::uint16_t kMiss = detail::kStampMiss;
  static constexpr std::uint64_t kSinceTickFrames = detail::BlockStore::kSinceTickFrames;
  static constexpr std::uint16_t kMaxSinceAgeTicks = detail::BlockStore::kMaxSinceAgeTicks;
  std::uint16_t since_tick() const noexcept { return store_.since_tick(); }

  static float dequantize(std::int32_t q) noexcept { return static_cast<float>(q) / kLogOddsScale; }
  static std::uint64_t pack(std::int32_t i, std::int32_t j, std::int32_t k) noexcept {
    return detail::pack_key(i, j, k);
  }
  static IndexVec unpack(std::uint64_t key) noexcept { return detail::unpack_key(key); }
  static std::size_t local_index(std::int32_t i, std::int32_t j, std::int32_t k) noexcept {
    return detail::local_index(i, j, k);
  }
  bool index_of(const Eigen::Vector3f& p, IndexVec& idx) const noexcept;  ///< false if outside
  const Block* find_block(std::int32_t bi, std::int32_t bj, std::int32_t bk) const noexcept {
    return store_.find(bi, bj, bk);
  }
  const Voxel* find_voxel(const IndexVec& idx) const noexcept;
  Occupancy classify(std::int16_t q) const noexcept {
    if (q == kUnknown) return Occupancy::kUnknown;
    if (q > params_.q_occupied) return Occupancy::kOccupied;
    // Free needs the evidence to say more likely empty than not (p < 0.5, as OctoMap's
    // threshold); between 0.5 and prob_occupied it is undecided, which is not free.
    return q < 0 ? Occupancy::kFree : Occupancy::kUnknown;
  }
  Eigen::Vector3f center_of(const IndexVec& idx) const noexcept {
    return {(static_cast<float>(idx[0]) + 0.5f) * params_.resolution,
            (static_cast<float>(idx[1]) + 0.5f) * params_.resolution,
            (static_cast<float>(idx[2]) + 0.5f) * params_.resolution};
  }
  /// Voxel index range [lo, hi] of the voxels whose centres lie in `box`; false if empty.
  bool box_range(const Box3& box, IndexVec& lo, IndexVec& hi) const noexcept;
  template <class Visit>
  std::size_t scan_box(const Box3& box, std::size_t max_voxels, Visit&& visit) const;

  // --- configuration (derived at init) ---
  detail::MapParams params_{};
  bool initialized_ = false;
  // --- map state ---
  detail::BlockStore store_;
  Stamp last_stamp_ = 0;
  // --- integration of a frame (its scratch is the integrator's) ---
  detail::MapIntegrator integrator_{store_, params_};
};

// ---------------------------------------------------------------------------------------------
// Template members.

template <class Visit>
std::size_t OccupancyMap::scan_box(const Box3& box, std::size_t max_voxels, Visit&& visit) const {
  IndexVec lo{}, hi{};
  if (!initialized_ || !box_range(box, lo, hi)) return 0;
  std::size_t examined = 0;
  std::size_t visited = 0;
  const std::int32_t b_lo[3] = {lo[0] >> kBlockBits, lo[1] >> kBlockBits, lo[2] >> kBlockBits};
  const std::int32_t b_hi[3] = {hi[0] >> kBlockBits, hi[1] >> kBlockBits, hi[2] >> kBlockBits};
  for (std::int32_t bk = b_lo[2]; bk <= b_hi[2]; ++bk) {
    for (std::int32_t bj = b_lo[1]; bj <= b_hi[1]; ++bj) {
      for (std::int32_t bi = b_lo[0]; bi <= b_hi[0]; ++bi) {
        if (examined >= max_voxels) return visited;
        ++examined;
        const Block* block = find_block(bi, bj, bk);
        if (block == nullptr) continue;
        const std::int32_t i0 = std::max(lo[0], bi * kBlockEdge);
        const std::int32_t i1 = std::min(hi[0], bi * kBlockEdge + kBlockEdge - 1);
        const std::int32_t j0 = std::max(lo[1], bj * kBlockEdge);
        const std::int32_t j1 = std::min(hi[1], bj * kBlockEdge + kBlockEdge - 1);
        const std::int32_t k0 = std::max(lo[2], bk * kBlockEdge);
        const std::int32_t k1 = std::min(hi[2], bk * kBlockEdge + kBlockEdge - 1);
        for (std::int32_t k = k0; k <= k1; ++k) {
          for (std::int32_t j = j0; j <= j1; ++j) {
            for (std::int32_t i = i0; i <= i1; ++i) {
              if (examined >= max_voxels) return visited;
              ++examined;
              const std::size_t li = local_index(i, j, k);
              if (classify(block->voxels[li].log_odds) != Occupancy::kOccupied) continue;
              if (visit(block, li, IndexVec{i, j, k})) ++visited;
            }
          }
        }
      }
    }
  }
  return visited;
}

template <class F>
std::size_t OccupancyMap::for_each_occupied_in_box(const Box3& box, std::size_t max_voxels,
                                                   F&& f) const {
  return scan_box(box, max_voxels, [&](const Block*, std::size_t, const IndexVec& idx) {
    const Eigen::Vector3f c = center_of(idx);
    f(pack(idx[0], idx[1], idx[2]), c);
    return true;
  });
}

template <class F>
std::size_t OccupancyMap::clear_box(const Box3& box, std::size_t max_voxels,
                                    std::uint64_t keep_frames, F&& on_cleared) {
  const std::uint16_t now = since_tick();
  const std::uint64_t keep_ticks =
      keep_frames == kKeepNone ? kKeepNone : keep_frames / kSinceTickFrames;
  return scan_box(box, max_voxels, [&](const Block* block, std::size_t li, const IndexVec& idx) {
    const auto age = static_cast<std::uint16_t>(now - block->occupied_since[li]);
    if (age >= keep_ticks) return false;  // static structure: kept
    // scan_box is const; the block lives in our own pool, so writing through it is sound.
    Block* mutable_block = &store_.block(store_.slot_of(block));
    mutable_block->voxels[li].log_odds = params_.q_min;  // q_min <= q_occupied (init checks it)
    --mutable_block->occupied;
    const Eigen::Vector3f c = center_of(idx);
    on_cleared(pack(idx[0], idx[1], idx[2]), c);
    return true;
  });
}

template <class F>
void OccupancyMap::for_each_occupied(F&& f) const {
  if (!initialized_) return;
  for (std::size_t s = 0; s < kMaxMapBlocks; ++s) {
    if (!store_.used(s)) continue;
    const Block& b = store_.block(s);
    for (std::int32_t k = 0; k < kBlockEdge; ++k) {
      for (std::int32_t j = 0; j < kBlockEdge; ++j) {
        for (std::int32_t i = 0; i < kBlockEdge; ++i) {
          const std::size_t li = local_index(i, j, k);
          if (classify(b.voxels[li].log_odds) != Occupancy::kOccupied) continue;
          const IndexVec idx{b.index[0] * kBlockEdge + i, b.index[1] * kBlockEdge + j,
                             b.index[2] * kBlockEdge + k};
          const Eigen::Vector3f c = center_of(idx);
          f(pack(idx[0], idx[1], idx[2]), c);
        }
      }
    }
  }
}

template <class F>
void OccupancyMap::for_each_updated_last_frame(F&& f) const {
  if (!initialized_ || store_.frames() == 0) return;
  const std::uint16_t hit_stamp = store_.stamp(kHit);
  const std::uint16_t miss_stamp = store_.stamp(kMiss);
  for (std::size_t s = 0; s < kMaxMapBlocks; ++s) {
    if (!store_.used(s)) continue;
    const Block& b = store_.block(s);
    for (std::size_t li = 0; li < kBlockVoxels; ++li) {
      const std::uint16_t stamp = b.voxels[li].stamp;
      if (stamp != hit_stamp && stamp != miss_stamp) continue;
      const auto i = static_cast<std::int32_t>(li & (kBlockEdge - 1));
      const auto j = static_cast<std::int32_t>((li >> kBlockBits) & (kBlockEdge - 1));
      const auto k = static_cast<std::int32_t>(li >> (2 * kBlockBits));
      f(pack(b.index[0] * kBlockEdge + i, b.index[1] * kBlockEdge + j, b.index[2] * kBlockEdge + k),
        stamp == hit_stamp);
    }
  }
}

}  // namespace dynamap
