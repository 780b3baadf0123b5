// CleanHistory: the voxels the dynamic-region cleaner freed recently. A fixed-capacity hash set
// with aging: entries expire after max_age, and when it is full the oldest entry is evicted, so
// it can never grow (the original's std::set of cleaned voxels did). The map refiner counts these
// voxels as occupied, through contains_thunk as a {ctx, fn} lookup callback.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>

#include "dynamap/core/fixed_hash_map.hpp"
#include "dynamap/core/status.hpp"
#include "dynamap/core/types.hpp"

namespace dynamap {

/// Default number of voxels remembered (a walker's 50-frame trail is a few thousand voxels).
inline constexpr std::size_t kCleanHistoryCapacity = 8192;

/// Capacity (a power of two) is fixed at compile time; the object holds all storage inline.
template <std::size_t Capacity>
class BasicCleanHistory {
  static_assert(Capacity >= 2 && (Capacity & (Capacity - 1)) == 0,
                "CleanHistory capacity must be a power of two");

 public:
  static constexpr std::size_t capacity() noexcept { return Capacity; }

  /// Entries older than max_age (ns) no longer count and are purged; 0 means they never expire.
  [[nodiscard]] Status init(Stamp max_age) noexcept {
    max_age_ = max_age;
    clear();
    return Status::kOk;
  }
  void clear() noexcept {
    index_.clear();
    head_ = count_ = 0;
    now_ = 0;
  }

  /// Records `key` as cleaned at `stamp` (refreshing its stamp if present). When full, the
  /// least recently refreshed entry is evicted first. Stamps should not go backwards.
  void insert(std::uint64_t key, Stamp stamp) noexcept {
    if (stamp > now_) now_ = stamp;
    if (const std::uint32_t* seq = index_.find(key)) {
      Entry& e = ring_[slot_of(*seq)];
      if (stamp > e.stamp) e.stamp = stamp;  // refreshed in place; requeued lazily
      return;
    }
    if (count_ == Capacity) {
      // Second chance: refreshed entries at the head move to the back (bounded), then the head
      // (the oldest) is evicted.
      for (std::size_t i = 0; i < kMaxRequeuePerInsert && refreshed(ring_[head_]); ++i) {
        requeue_head();
      }
      evict_head();
    }
    push_back(Entry{key, stamp, stamp, 0});
  }

  /// True when `key` was cleaned within max_age of the latest stamp seen.
  bool contains(std::uint64_t key) const noexcept {
    const std::uint32_t* seq = index_.find(key);
    if (seq == nullptr) return false;
    if (max_age_ == 0) return true;
    return now_ - ring_[slot_of(*seq)].stamp <= max_age_;
  }

  /// Moves `now` to `stamp` and purges expired entries; at most max_work entries are looked at
  /// (bounded work). Returns the number purged.
  std::size_t expire(Stamp stamp, std::size_t max_work = Capacity) noexcept {
    if (stamp > now_) now_ = stamp;
    std::size_t purged = 0;
    for (std::size_t work = 0; max_age_ != 0 && count_ > 0 && work < max_work; ++work) {
      const Entry& e = ring_[head_];
      if (now_ - e.stamp > max_age_) {
        evict_head();
        ++purged;
      } else if (refreshed(e)) {
        requeue_head();
      } else {
        break;  // the ring is ordered by queue time: everything behind is younger
      }
    }
    return purged;
  }

  /// Live keys (expired ones not yet purged included).
  std::size_t size() const noexcept { return index_.size(); }
  Stamp now() const noexcept { return now_; }

  /// Callback adaptor for the map refiner: VoxelLookup{&history, &CleanHistory::contains_thunk}.
  static bool contains_thunk(const void* ctx, std::uint64_t key) noexcept {
    return static_cast<const BasicCleanHistory*>(ctx)->contains(key);
  }

 private:
  struct Entry {
    std::uint64_t key = 0;
    Stamp stamp = 0;   ///< last time the voxel was cleaned
    Stamp queued = 0;  ///< stamp when the entry was put at the back of the ring
    std::uint32_t seq = 0;
  };
  static constexpr std::size_t kMaxRequeuePerInsert = 8;

  static bool refreshed(const Entry& e) noexcept { return e.stamp != e.queued; }

  // Ring entries have consecutive sequence numbers, so a seq maps straight to its slot
  // (unsigned wrap-around keeps the difference right after 2^32 inserts).
  std::size_t slot_of(std::uint32_t seq) const noexcept {
    const std::uint32_t oldest_seq = next_seq_ - static_cast<std::uint32_t>(count_);
    return (head_ + static_cast<std::size_t>(static_cast<std::uint32_t>(seq - oldest_seq))) %
           Capacity;
  }

  void push_back(Entry e) noexcept {
    e.seq = next_seq_++;
    ring_[(head_ + count_) % Capacity] = e;
    ++count_;
    bool inserted = false;
    std::uint32_t* s = index_.find_or_insert(e.key, inserted);
    if (s != nullptr) *s = e.seq;  // the index has room for every ring entry: never null
  }
  Entry pop_head() noexcept {
    const Entry e = ring_[head_];
    head_ = (head_ + 1) % Capacity;
    --count_;
    return e;
  }
  void evict_head() noexcept { index_.erase(pop_head().key); }
  void requeue_head() noexcept {
    Entry e = pop_head();
    e.queued = e.stamp;
    push_back(e);
  }

  std::array<Entry, Capacity> ring_{};
  FixedHashMap<std::uint64_t, std::uint32_t, 2 * Capacity> index_;  // key -> seq of newest entry
  std::size_t head_ = 0;
  std::size_t count_ = 0;
  std::uint32_t next_seq_ = 0;
  Stamp now_ = 0;
  Stamp max_age_ = 3'000'000'000ULL;
};

/// The clean history the pipeline uses.
using CleanHistory = BasicCleanHistory<kCleanHistoryCapacity>;

}  // namespace dynamap
