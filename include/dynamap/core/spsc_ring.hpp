// SpscRing: lock-free single-producer / single-consumer ring with inline storage of Capacity
// slots (a power of two fixed at compile time). Hands frames from a sensor thread to the pipeline
// and outputs to a planner without locks or allocation; a full ring rejects and counts the drop.
#pragma once

#include <atomic>
#include <cassert>
#include <cstddef>
#include <cstdint>
#include <type_traits>
#include <utility>

#include "dynamap/core/constants.hpp"
#include "dynamap/core/status.hpp"

namespace dynamap {

/// Bounded lock-free SPSC queue. Exactly one thread may call the producer functions (try_push,
/// try_begin_push, commit_push) and exactly one thread the consumer functions (try_pop,
/// try_front, pop_front); the observers (size_approx, empty_approx, drops) are safe from any
/// thread. Slots are live T objects, value-initialised at construction and reused in place:
/// the slot API lets a large element (a depth image) be written and read without extra copies.
/// All Capacity slots are usable. Large rings must not live on the stack (use a static or
/// std::make_unique at init).
template <typename T, std::size_t Capacity>
class SpscRing {
  static_assert(Capacity >= 2 && (Capacity & (Capacity - 1)) == 0,
                "SpscRing capacity must be a power of two >= 2");
  static_assert(std::is_default_constructible<T>::value,
                "SpscRing slots are constructed up front: T must be default-constructible");

 public:
  using value_type = T;

  SpscRing() = default;
  SpscRing(const SpscRing&) = delete;
  SpscRing& operator=(const SpscRing&) = delete;

  static constexpr std::size_t capacity() noexcept { return Capacity; }

  // ---- producer side ------------------------------------------------------------------------

  /// Copies `v` into the ring. kCapacityExceeded (and one drop counted) when full.
  Status try_push(const T& v) noexcept(std::is_nothrow_copy_assignable<T>::value) {
    const std::size_t head = head_.load(std::memory_order_relaxed);  // only we write head_
    if (!has_room(head)) return Status::kCapacityExceeded;
    slots_[head & kMask] = v;
    head_.store(head + 1, std::memory_order_release);
    return Status::kOk;
  }
  /// Moves `v` into the ring. kCapacityExceeded (and one drop counted) when full; `v` untouched.
  Status try_push(T&& v) noexcept(std::is_nothrow_move_assignable<T>::value) {
    const std::size_t head = head_.load(std::memory_order_relaxed);
    if (!has_room(head)) return Status::kCapacityExceeded;
    slots_[head & kMask] = std::move(v);
    head_.store(head + 1, std::memory_order_release);
    return Status::kOk;
  }

  /// Slot API, step 1: the free slot the producer may fill in place, or nullptr when the ring is
  /// full (one drop counted: the caller is expected to drop that element). The slot holds
  /// whatever an earlier element left there, so overwrite every field you use. Calling it again
  /// before commit_push() returns the same slot.
  T* try_begin_push() noexcept {
    const std::size_t head = head_.load(std::memory_order_relaxed);
    return has_room(head) ? &slots_[head & kMask] : nullptr;
  }

  /// Slot API, step 2: publishes the slot returned by the last successful try_begin_push().
  /// Precondition: that call returned non-null and nothing was committed since.
  void commit_push() noexcept {
    const std::size_t head = head_.load(std::memory_order_relaxed);
    assert(head - producer_.cached_tail < Capacity && "commit_push without a free slot");
    // Release: the slot's contents are visible before the consumer can see the new head.
    head_.store(head + 1, std::memory_order_release);
  }

  // ---- consumer side ------------------------------------------------------------------------

  /// Moves the oldest element into `out`. kEmpty (and `out` untouched) when the ring is empty.
  Status try_pop(T& out) noexcept(std::is_nothrow_move_assignable<T>::value) {
    const std::size_t tail = tail_.load(std::memory_order_relaxed);  // only we write tail_
    if (!has_data(tail)) return Status::kEmpty;
    out = std::move(slots_[tail & kMask]);
    tail_.store(tail + 1, std::memory_order_release);
    return Status::kOk;
  }

  /// Slot API: the oldest element, read in place, or nullptr when empty. It stays valid and
  /// unchanged until pop_front().
  const T* try_front() noexcept {
    const std::size_t tail = tail_.load(std::memory_order_relaxed);
    return has_data(tail) ? &slots_[tail & kMask] : nullptr;
  }

  /// Releases the element returned by try_front() back to the producer.
  /// Precondition: the last try_front() returned non-null and nothing was popped since.
  void pop_front() noexcept {
    const std::size_t tail = tail_.load(std::memory_order_relaxed);  // only we write tail_
    assert(consumer_.cached_head != tail && "pop_front on an empty ring");
    // Release: our reads of the slot happen before the producer may reuse it.
    tail_.store(tail + 1, std::memory_order_release);
  }

  // ---- observers (any thread) ---------------------------------------------------------------

  /// Number of elements at some instant during the call; exact when both sides are idle.
  std::size_t size_approx() const noexcept {
    const std::size_t tail = tail_.load(std::memory_order_acquire);
    const std::size_t head = head_.load(std::memory_order_acquire);
    const std::size_t n = head - tail;
    return n > Capacity ? Capacity : n;  // tail may be read before a racing pop+push
  }
  bool empty_approx() const noexcept { return size_approx() == 0; }
  /// Elements rejected because the ring was full, since construction.
  std::uint64_t drops() const noexcept { return producer_.drops.load(std::memory_order_relaxed); }

 private:
  static constexpr std::size_t kMask = Capacity - 1;

  // Producer: true when slot `head` is free; refreshes the cached tail only when the ring looks
  // full, and counts a drop when it really is.
  bool has_room(std::size_t head) noexcept {
    if (head - producer_.cached_tail != Capacity) return true;
    // Acquire pairs with the consumer's release of tail_: its reads of the slot we are about to
    // overwrite are complete before we write.
    producer_.cached_tail = tail_.load(std::memory_order_acquire);
    if (head - producer_.cached_tail != Capacity) return true;
    // Single writer: a load + store is enough and avoids a locked read-modify-write.
    producer_.drops.store(producer_.drops.load(std::memory_order_relaxed) + 1,
                          std::memory_order_relaxed);
    return false;
  }

  // Consumer: true when slot `tail` holds an element; refreshes the cached head only when the
  // ring looks empty.
  bool has_data(std::size_t tail) noexcept {
    if (tail != consumer_.cached_head) return true;
    // Acquire pairs with the producer's release of head_: the slot's contents are visible.
    consumer_.cached_head = head_.load(std::memory_order_acquire);
    return tail != consumer_.cached_head;
  }

  // Indices run freely (never wrapped to Capacity); unsigned differences stay correct across
  // overflow because Capacity divides 2^N. Each shared index and each side's private state sits
  // on its own cache line so the two threads only exchange lines when an index really moves.
  struct alignas(kCacheLine) ProducerState {
    std::size_t cached_tail = 0;          // producer's last view of tail_
    std::atomic<std::uint64_t> drops{0};  // written by the producer only
  };
  struct alignas(kCacheLine) ConsumerState {
    std::size_t cached_head = 0;  // consumer's last view of head_
  };

  alignas(kCacheLine) std::atomic<std::size_t> head_{0};  // next slot to fill
  ProducerState producer_;
  alignas(kCacheLine) std::atomic<std::size_t> tail_{0};  // next slot to read
  ConsumerState consumer_;
  alignas(kCacheLine) T slots_[Capacity]{};
};

}  // namespace dynamap
