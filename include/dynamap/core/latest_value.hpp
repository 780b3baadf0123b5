// LatestValue: lock-free triple buffer for "newest snapshot wins" hand-off (pipeline outputs to
// a planner). One writer and one reader, never blocking each other; the reader always sees a
// whole snapshot, and snapshots it was too slow to take are simply skipped.
#pragma once

#include <atomic>
#include <cstdint>

#include "dynamap/core/constants.hpp"

namespace dynamap {

/// Triple buffer. The writer owns one buffer (write_buffer), the reader owns one (read_buffer)
/// and the third sits in the middle, swapped atomically by publish() and update(). Exactly one
/// thread writes (write_buffer, publish) and one thread reads (update, read_buffer,
/// read_sequence); publish_count() is safe from any thread. Holds three T inline.
template <typename T>
class LatestValue {
 public:
  LatestValue() = default;
  LatestValue(const LatestValue&) = delete;
  LatestValue& operator=(const LatestValue&) = delete;

  // ---- writer -------------------------------------------------------------------------------

  /// The buffer to fill. It holds an older snapshot (or T{}), not the last published one:
  /// overwrite every field you use.
  T& write_buffer() noexcept { return slots_[writer_index_].value; }

  /// Makes the write buffer the newest snapshot and hands the writer a free buffer. Never blocks.
  void publish() noexcept {
    const std::uint64_t seq = published_.load(std::memory_order_relaxed) + 1;
    slots_[writer_index_].sequence = seq;
    // acq_rel: release makes the snapshot visible to the reader's exchange; acquire makes the
    // reader's last reads of the buffer we get back complete before we overwrite it.
    const std::uint32_t prev =
        middle_.exchange(writer_index_ | kFreshBit, std::memory_order_acq_rel);
    writer_index_ = prev & kIndexMask;
    published_.store(seq, std::memory_order_relaxed);  // single writer: no RMW needed
  }

  // ---- reader -------------------------------------------------------------------------------

  /// Takes the newest published snapshot if there is one the reader has not seen yet.
  /// Returns true when read_buffer() changed.
  bool update() noexcept {
    // Cheap relaxed peek; the exchange below is what synchronises.
    if ((middle_.load(std::memory_order_relaxed) & kFreshBit) == 0) return false;
    const std::uint32_t prev = middle_.exchange(reader_index_, std::memory_order_acq_rel);
    reader_index_ = prev & kIndexMask;
    return true;
  }

  /// The snapshot taken by the last successful update() (T{} before the first one).
  const T& read_buffer() const noexcept { return slots_[reader_index_].value; }

  /// 1-based publish number of read_buffer()'s snapshot; 0 before the first update().
  std::uint64_t read_sequence() const noexcept { return slots_[reader_index_].sequence; }

  // ---- observers (any thread) ---------------------------------------------------------------

  /// Number of publish() calls so far.
  std::uint64_t publish_count() const noexcept {
    return published_.load(std::memory_order_relaxed);
  }

 private:
  static constexpr std::uint32_t kIndexMask = 0x3;
  static constexpr std::uint32_t kFreshBit = 0x4;  // middle holds a snapshot not yet taken

  struct alignas(kCacheLine) Slot {
    T value{};
    std::uint64_t sequence = 0;
  };

  Slot slots_[3]{};
  alignas(kCacheLine) std::uint32_t writer_index_ = 0;  // writer-private
  std::atomic<std::uint64_t> published_{0};             // written by the writer only
  alignas(kCacheLine) std::atomic<std::uint32_t> middle_{1};
  alignas(kCacheLine) std::uint32_t reader_index_ = 2;  // reader-private
};

}  // namespace dynamap
