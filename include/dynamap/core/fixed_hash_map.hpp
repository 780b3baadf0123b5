// FixedHashMap / FixedHashSet: open-addressing hash tables with inline storage of Capacity slots.
// Linear probing with backward-shift deletion, so erasing never leaves tombstones and lookups do
// not degrade over a long flight. Capacity must be a power of two; keep the load below ~0.75.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <type_traits>

#include "dynamap/core/status.hpp"

namespace dynamap {

/// splitmix64 finaliser: cheap, well-mixed hash for integer keys.
struct IntegerHash {
  std::uint64_t operator()(std::uint64_t x) const noexcept {
    x ^= x >> 30;
    x *= 0xbf58476d1ce4e5b9ULL;
    x ^= x >> 27;
    x *= 0x94d049bb133111ebULL;
    x ^= x >> 31;
    return x;
  }
};

template <typename Key, typename Value, std::size_t Capacity, typename Hash = IntegerHash>
class FixedHashMap {
  static_assert(Capacity >= 2 && (Capacity & (Capacity - 1)) == 0,
                "FixedHashMap capacity must be a power of two");

 public:
  static constexpr std::size_t capacity() noexcept { return Capacity; }
  std::size_t size() const noexcept { return size_; }
  bool empty() const noexcept { return size_ == 0; }
  /// Refuses inserts above this many entries so probe chains stay short.
  static constexpr std::size_t max_load() noexcept { return Capacity - Capacity / 8; }

  void clear() noexcept {
    used_.fill(0);
    size_ = 0;
  }

  Value* find(const Key& key) noexcept {
    const std::size_t i = locate(key);
    return i == kNotFound ? nullptr : &values_[i];
  }
  const Value* find(const Key& key) const noexcept {
    const std::size_t i = locate(key);
    return i == kNotFound ? nullptr : &values_[i];
  }
  bool contains(const Key& key) const noexcept { return locate(key) != kNotFound; }

  /// Inserts key -> value, or overwrites the value of an existing key.
  /// kCapacityExceeded (and nothing changes) when the table is at max_load().
  Status insert_or_assign(const Key& key, const Value& value) noexcept {
    bool inserted = false;
    Value* v = find_or_insert(key, inserted);
    if (v == nullptr) return Status::kCapacityExceeded;
    *v = value;
    return Status::kOk;
  }

  /// Returns the value slot of `key`, inserting a value-initialised one if absent.
  /// `inserted` tells which happened; nullptr when a new key does not fit.
  Value* find_or_insert(const Key& key, bool& inserted) noexcept {
    std::size_t i = home(key);
    while (used_[i]) {
      if (keys_[i] == key) {
        inserted = false;
        return &values_[i];
      }
      i = (i + 1) & kMask;
    }
    if (size_ >= max_load()) {
      inserted = false;
      return nullptr;
    }
    used_[i] = 1;
    keys_[i] = key;
    values_[i] = Value{};
    ++size_;
    inserted = true;
    return &values_[i];
  }

  /// Removes `key`; false when it was absent. Shifts later entries of the probe chain back.
  bool erase(const Key& key) noexcept {
    std::size_t hole = locate(key);
    if (hole == kNotFound) return false;
    std::size_t j = hole;
    for (;;) {
      j = (j + 1) & kMask;
      if (!used_[j]) break;
      const std::size_t want = home(keys_[j]);
      // Move j into the hole unless its home lies cyclically in (hole, j].
      const bool stays = (hole <= j) ? (hole < want && want <= j) : (hole < want || want <= j);
      if (!stays) {
        keys_[hole] = keys_[j];
        values_[hole] = values_[j];
        hole = j;
      }
    }
    used_[hole] = 0;
    --size_;
    return true;
  }

  /// Calls f(key, value) for every entry. f must not insert or erase.
  template <typename F>
  void for_each(F&& f) {
    for (std::size_t i = 0; i < Capacity; ++i) {
      if (used_[i]) f(keys_[i], values_[i]);
    }
  }
  template <typename F>
  void for_each(F&& f) const {
    for (std::size_t i = 0; i < Capacity; ++i) {
      if (used_[i]) f(keys_[i], values_[i]);
    }
  }

 private:
  static constexpr std::size_t kMask = Capacity - 1;
  static constexpr std::size_t kNotFound = ~std::size_t{0};

  std::size_t home(const Key& key) const noexcept {
    return static_cast<std::size_t>(Hash{}(key)) & kMask;
  }
  std::size_t locate(const Key& key) const noexcept {
    std::size_t i = home(key);
    while (used_[i]) {
      if (keys_[i] == key) return i;
      i = (i + 1) & kMask;
    }
    return kNotFound;
  }

  std::array<Key, Capacity> keys_{};
  std::array<Value, Capacity> values_{};
  std::array<std::uint8_t, Capacity> used_{};
  std::size_t size_ = 0;
};

/// A set: FixedHashMap with an empty value.
template <typename Key, std::size_t Capacity, typename Hash = IntegerHash>
class FixedHashSet {
 public:
  static constexpr std::size_t capacity() noexcept { return Capacity; }
  std::size_t size() const noexcept { return map_.size(); }
  bool empty() const noexcept { return map_.empty(); }
  void clear() noexcept { map_.clear(); }
  bool contains(const Key& k) const noexcept { return map_.contains(k); }
  /// kOk when inserted or already present; kCapacityExceeded when full.
  Status insert(const Key& k) noexcept {
    bool inserted = false;
    return map_.find_or_insert(k, inserted) ? Status::kOk : Status::kCapacityExceeded;
  }
  bool erase(const Key& k) noexcept { return map_.erase(k); }
  template <typename F>
  void for_each(F&& f) const {
    map_.for_each([&](const Key& k, const Empty&) { f(k); });
  }

 private:
  struct Empty {};
  FixedHashMap<Key, Empty, Capacity, Hash> map_;
};

}  // namespace dynamap
