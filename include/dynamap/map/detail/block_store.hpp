// BlockStore: the occupancy map's storage, apart from how it is filled or queried. Blocks of
// 8x8x8 voxels live in an inline pool located through an open-addressing table keyed by block
// coordinates; far blocks are evicted when the pool is full. It also keeps the frame count and
// the per-frame voxel stamps, which are stored in the voxels. Held inline by OccupancyMap
// (include/dynamap/map/occupancy_map.hpp); see docs/occupancy_map.md, "Parts".
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>

#include <Eigen/Core>

#include "dynamap/core/fixed_hash_map.hpp"

namespace dynamap {

/// Compile-time pool capacity in blocks (8^3 voxels each).
inline constexpr std::size_t kMaxMapBlocks = 4096;

namespace detail {

inline constexpr int kBlockBits = 3;
inline constexpr int kBlockEdge = 1 << kBlockBits;  ///< voxels per block edge
inline constexpr std::size_t kBlockVoxels = std::size_t{1} << (3 * kBlockBits);
/// Voxel indices representable in a key: [-kKeyHalfRange, kKeyHalfRange).
inline constexpr std::int32_t kKeyHalfRange = 1 << 20;

using IndexVec = std::array<std::int32_t, 3>;

/// Packs signed voxel (or block) indices, 21 bits each, into one key.
inline std::uint64_t pack_key(std::int32_t i, std::int32_t j, std::int32_t k) noexcept {
  constexpr std::uint64_t kMask = (std::uint64_t{1} << 21) - 1;
  return (static_cast<std::uint64_t>(i + kKeyHalfRange) & kMask) |
         ((static_cast<std::uint64_t>(j + kKeyHalfRange) & kMask) << 21) |
         ((static_cast<std::uint64_t>(k + kKeyHalfRange) & kMask) << 42);
}
inline IndexVec unpack_key(std::uint64_t key) noexcept {
  constexpr std::uint64_t kMask = (std::uint64_t{1} << 21) - 1;
  return {static_cast<std::int32_t>(key & kMask) - kKeyHalfRange,
          static_cast<std::int32_t>((key >> 21) & kMask) - kKeyHalfRange,
          static_cast<std::int32_t>((key >> 42) & kMask) - kKeyHalfRange};
}
/// floor(x) for x well inside the int32 range, without a libm call.
inline std::int32_t fast_floor(float x) noexcept {
  const auto i = static_cast<std::int32_t>(x);
  return i - static_cast<std::int32_t>(x < static_cast<float>(i));
}
/// The voxel indices of point p (voxels of 1 / inv_resolution); false outside the key range.
inline bool voxel_index(const Eigen::Vector3f& p, float inv_resolution, IndexVec& idx) noexcept {
  constexpr float kLimit = static_cast<float>(kKeyHalfRange);
  for (int a = 0; a < 3; ++a) {
    const float x = p[a] * inv_resolution;
    if (!(x >= -kLimit && x < kLimit)) return false;  // also rejects NaN
    idx[static_cast<std::size_t>(a)] = fast_floor(x);
  }
  return idx[0] < kKeyHalfRange && idx[1] < kKeyHalfRange && idx[2] < kKeyHalfRange;
}
/// Index of voxel (i, j, k) inside its block.
inline std::size_t local_index(std::int32_t i, std::int32_t j, std::int32_t k) noexcept {
  constexpr std::int32_t m = kBlockEdge - 1;
  return static_cast<std::size_t>((i & m) | ((j & m) << kBlockBits) |
                                  ((k & m) << (2 * kBlockBits)));
}

/// int16 log-odds (x1000: 0.001 resolution, +-32 range) + uint16 frame stamp = 4 bytes, half a
/// float+stamp record: twice the voxels per cache line, and integer clamping is exact.
struct Voxel {
  std::int16_t log_odds;
  std::uint16_t stamp;
};
inline constexpr std::int16_t kUnknownLogOdds = INT16_MIN;  ///< sentinel: never observed
// Voxel stamps are 4 * frame tag + one of these, so a new frame needs no clearing.
inline constexpr std::uint16_t kStampQueued = 1;  ///< a free ray ends here this frame
inline constexpr std::uint16_t kStampHit = 2;     ///< hit applied this frame
inline constexpr std::uint16_t kStampMiss = 3;    ///< miss applied this frame

struct Block {
  std::array<Voxel, kBlockVoxels> voxels;
  std::array<std::int32_t, 3> index;  ///< block coordinates (voxel index >> kBlockBits)
  /// Occupied voxels in the block, kept exact on every log-odds change, so the segment query
  /// can step over a block without any occupied voxel in one go.
  std::uint16_t occupied;
  std::uint64_t last_frame;  ///< frames() when last touched by integration
  /// Per voxel: since_tick() when it last became occupied (read only while it is). Apart from
  /// the voxels so integration's hot loops do not carry it.
  std::array<std::uint16_t, kBlockVoxels> occupied_since;
};

/// The block pool, its hash table and eviction, and the frame clock the voxels' stamps and
/// occupied-since ticks count in. Single-threaded: blocks are allocated and evicted only by
/// the thread that integrates (workers write voxels of blocks already acquired).
class BlockStore {
 public:
  /// Hash table slots: power of two, load <= kMaxMapBlocks / kTableCapacity = 0.5.
  static constexpr std::size_t kTableCapacity = 2 * kMaxMapBlocks;
  /// occupied_since counts ticks of kSinceTickFrames frames, modulo 2^16; the frame-tag wrap
  /// caps ages at kMaxSinceAgeTicks so the modular difference stays exact.
  static constexpr std::uint64_t kSinceTickFrames = 8;
  static constexpr std::uint16_t kMaxSinceAgeTicks = 16384;

  /// Empties the store: at most max_blocks (<= kMaxMapBlocks) blocks of `resolution` (m) voxels.
  void reset(std::size_t max_blocks, float resolution) noexcept;
  /// A new frame: counts it, moves the stamps on (clearing them all on the rare wrap; returns
  /// true then) and sets the point eviction keeps blocks near (the camera).
  bool begin_frame(const Eigen::Vector3f& keep_near) noexcept;

  const Block* find(std::int32_t bi, std::int32_t bj, std::int32_t bk) const noexcept {
    const std::uint32_t* slot = table_.find(pack_key(bi, bj, bk));
    return slot == nullptr ? nullptr : &pool_[*slot];
  }
  Block* find(std::int32_t bi, std::int32_t bj, std::int32_t bk) noexcept {
    const std::uint32_t* slot = table_.find(pack_key(bi, bj, bk));
    return slot == nullptr ? nullptr : &pool_[*slot];
  }
  /// A new empty block, or nullptr when the pool is at its capacity.
  Block* allocate(std::int32_t bi, std::int32_t bj, std::int32_t bk) noexcept;
  /// The block, allocated (evicting far blocks when the pool is full) if needed and marked as
  /// touched this frame (never evicted this frame); nullptr when none can be had.
  Block* acquire(std::int32_t bi, std::int32_t bj, std::int32_t bk) noexcept;

  Block& block(std::size_t slot) noexcept { return pool_[slot]; }
  const Block& block(std::size_t slot) const noexcept { return pool_[slot]; }
  std::size_t slot_of(const Block* b) const noexcept {
    return static_cast<std::size_t>(b - pool_.data());
  }
  bool used(std::size_t slot) const noexcept { return slot_used_[slot] != 0; }
  std::uint64_t key(std::size_t slot) const noexcept { return slot_key_[slot]; }

  std::uint64_t frames() const noexcept { return frames_; }
  std::uint16_t frame_tag() const noexcept { return frame_tag_; }
  /// This frame's stamp of kind kStampQueued / kStampHit / kStampMiss.
  std::uint16_t stamp(std::uint16_t kind) const noexcept {
    return static_cast<std::uint16_t>(frame_tag_ * 4u + kind);
  }
  std::uint16_t since_tick() const noexcept {
    return static_cast<std::uint16_t>(frames_ / kSinceTickFrames);
  }

  std::size_t blocks_in_use() const noexcept { return blocks_in_use_; }
  std::size_t total_evicted() const noexcept { return total_evicted_; }
  /// Blocks allocated and evicted since the last begin_frame() (or reset()).
  std::size_t allocated_this_frame() const noexcept { return allocated_this_frame_; }
  std::size_t evicted_this_frame() const noexcept { return evicted_this_frame_; }

 private:
  struct EvictionCandidate {
    float distance_sq;
    std::uint32_t slot;
  };
  std::size_t evict_far_blocks() noexcept;
  void release(std::uint32_t slot) noexcept;

  std::array<Block, kMaxMapBlocks> pool_;
  FixedHashMap<std::uint64_t, std::uint32_t, kTableCapacity> table_;
  std::array<std::uint32_t, kMaxMapBlocks> free_slots_{};
  std::array<std::uint64_t, kMaxMapBlocks> slot_key_{};  ///< table key of each used slot
  std::array<std::uint8_t, kMaxMapBlocks> slot_used_{};
  std::array<EvictionCandidate, kMaxMapBlocks> eviction_{};
  std::size_t free_count_ = 0;
  std::size_t blocks_in_use_ = 0;
  std::size_t max_blocks_ = kMaxMapBlocks;
  float resolution_ = 0.1f;
  Eigen::Vector3f keep_near_ = Eigen::Vector3f::Zero();
  std::size_t total_evicted_ = 0;
  std::size_t allocated_this_frame_ = 0, evicted_this_frame_ = 0;
  std::size_t eviction_passes_ = 0;  ///< this frame's
  std::uint64_t frames_ = 0;
  std::uint16_t frame_tag_ = 0;  ///< per-frame stamp base / 4 (cycles, stamps cleared on wrap)
};

}  // namespace detail
}  // namespace dynamap
