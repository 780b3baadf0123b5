#include "dynamap/map/detail/block_store.hpp"

#include <algorithm>

namespace dynamap::detail {
namespace {

/// Eviction passes allowed per frame; each frees a batch of far blocks (bounded O(pool) work).
constexpr std::size_t kMaxEvictionPassesPerFrame = 8;
/// Stamps per frame tag: 4 * tag + {kStampQueued, kStampHit, kStampMiss}; 4 * 16383 + 3 fits
/// in uint16.
constexpr std::uint16_t kMaxFrameTag = 16383;

}  // namespace

void BlockStore::reset(std::size_t max_blocks, float resolution) noexcept {
  max_blocks_ = max_blocks;
  resolution_ = resolution;
  table_.clear();
  for (std::size_t s = 0; s < kMaxMapBlocks; ++s) {
    free_slots_[s] = static_cast<std::uint32_t>(kMaxMapBlocks - 1 - s);  // pop yields 0, 1, ...
  }
  slot_used_.fill(0);
  free_count_ = kMaxMapBlocks;
  blocks_in_use_ = 0;
  total_evicted_ = 0;
  allocated_this_frame_ = 0;
  evicted_this_frame_ = 0;
  eviction_passes_ = 0;
  frames_ = 0;
  frame_tag_ = 0;
  keep_near_ = Eigen::Vector3f::Zero();
}

bool BlockStore::begin_frame(const Eigen::Vector3f& keep_near) noexcept {
  ++frames_;
  allocated_this_frame_ = 0;
  evicted_this_frame_ = 0;
  eviction_passes_ = 0;
  keep_near_ = keep_near;
  bool wrapped = false;
  if (frame_tag_ >= kMaxFrameTag) {
    // Rare wrap (every ~9 min at 30 Hz): old stamps could alias new ones, so clear them all;
    // and cap occupied ages (at most 9 min = 2048 ticks more by the next wrap, far below 2^15).
    const std::uint16_t now = since_tick();
    for (std::size_t s = 0; s < kMaxMapBlocks; ++s) {
      if (!slot_used_[s]) continue;
      Block& b = pool_[s];
      for (Voxel& v : b.voxels) v.stamp = 0;
      for (std::uint16_t& since : b.occupied_since) {
        if (static_cast<std::uint16_t>(now - since) > kMaxSinceAgeTicks) {
          since = static_cast<std::uint16_t>(now - kMaxSinceAgeTicks);
        }
      }
    }
    frame_tag_ = 0;
    wrapped = true;
  }
  ++frame_tag_;
  return wrapped;
}

Block* BlockStore::allocate(std::int32_t bi, std::int32_t bj, std::int32_t bk) noexcept {
  if (free_count_ == 0 || blocks_in_use_ >= max_blocks_) return nullptr;
  const std::uint64_t key = pack_key(bi, bj, bk);
  const std::uint32_t slot = free_slots_[free_count_ - 1];
  if (!ok(table_.insert_or_assign(key, slot))) return nullptr;  // cannot happen at load <= 0.5
  --free_count_;
  ++blocks_in_use_;
  slot_used_[slot] = 1;
  slot_key_[slot] = key;
  Block& b = pool_[slot];
  b.voxels.fill(Voxel{kUnknownLogOdds, 0});
  b.index = {bi, bj, bk};
  b.occupied = 0;
  b.last_frame = frames_;
  b.occupied_since.fill(0);
  ++allocated_this_frame_;
  return &b;
}

void BlockStore::release(std::uint32_t slot) noexcept {
  table_.erase(slot_key_[slot]);
  slot_used_[slot] = 0;
  free_slots_[free_count_++] = slot;
  --blocks_in_use_;
}

std::size_t BlockStore::evict_far_blocks() noexcept {
  if (eviction_passes_ >= kMaxEvictionPassesPerFrame) return 0;
  ++eviction_passes_;
  std::size_t n = 0;
  const float half_block = 0.5f * static_cast<float>(kBlockEdge);
  for (std::size_t s = 0; s < kMaxMapBlocks; ++s) {
    // Blocks touched this frame stay: they may hold this frame's hits and cached pointers.
    if (!slot_used_[s] || pool_[s].last_frame == frames_) continue;
    const Block& b = pool_[s];
    Eigen::Vector3f c;
    for (int a = 0; a < 3; ++a) {
      c[a] = (static_cast<float>(b.index[static_cast<std::size_t>(a)] * kBlockEdge) + half_block) *
             resolution_;
    }
    eviction_[n++] =
        EvictionCandidate{(c - keep_near_).squaredNorm(), static_cast<std::uint32_t>(s)};
  }
  if (n == 0) return 0;
  const std::size_t batch = std::min(n, std::max<std::size_t>(1, max_blocks_ / 16));
  const auto farther = [](const EvictionCandidate& x, const EvictionCandidate& y) {
    return x.distance_sq > y.distance_sq;
  };
  std::nth_element(eviction_.begin(), eviction_.begin() + static_cast<std::ptrdiff_t>(batch - 1),
                   eviction_.begin() + static_cast<std::ptrdiff_t>(n), farther);
  for (std::size_t e = 0; e < batch; ++e) release(eviction_[e].slot);
  evicted_this_frame_ += batch;
  total_evicted_ += batch;
  return batch;
}

Block* BlockStore::acquire(std::int32_t bi, std::int32_t bj, std::int32_t bk) noexcept {
  Block* b = find(bi, bj, bk);
  if (b == nullptr) {
    b = allocate(bi, bj, bk);
    if (b == nullptr && evict_far_blocks() > 0) b = allocate(bi, bj, bk);
    if (b == nullptr) return nullptr;
  }
  b->last_frame = frames_;
  return b;
}

}  // namespace dynamap::detail
