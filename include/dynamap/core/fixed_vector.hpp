// FixedVector: a vector with inline storage of N elements and no heap, ever.
// push_back reports "full" instead of growing; element storage is value-initialised at
// construction.
#pragma once

#include <array>
#include <cstddef>

#include "dynamap/core/status.hpp"

namespace dynamap {

template <typename T, std::size_t N>
class FixedVector {
 public:
  using value_type = T;
  using iterator = T*;
  using const_iterator = const T*;

  static constexpr std::size_t capacity() noexcept { return N; }
  std::size_t size() const noexcept { return size_; }
  bool empty() const noexcept { return size_ == 0; }
  bool full() const noexcept { return size_ == N; }

  /// Appends a copy of `v`; kCapacityExceeded (and nothing changes) when full.
  Status push_back(const T& v) noexcept {
    if (size_ == N) return Status::kCapacityExceeded;
    data_[size_++] = v;
    return Status::kOk;
  }
  /// Appends a value-initialised element and returns it, or nullptr when full.
  T* emplace_back() noexcept {
    if (size_ == N) return nullptr;
    data_[size_] = T{};
    return &data_[size_++];
  }
  void pop_back() noexcept {
    if (size_ > 0) --size_;
  }
  void clear() noexcept { size_ = 0; }
  /// Removes element i by moving the last element into its place (order not kept, O(1)).
  void swap_erase(std::size_t i) noexcept {
    if (i >= size_) return;
    --size_;
    if (i != size_) data_[i] = data_[size_];
  }

  T& operator[](std::size_t i) noexcept { return data_[i]; }
  const T& operator[](std::size_t i) const noexcept { return data_[i]; }
  T& back() noexcept { return data_[size_ - 1]; }
  const T& back() const noexcept { return data_[size_ - 1]; }
  T* data() noexcept { return data_.data(); }
  const T* data() const noexcept { return data_.data(); }
  iterator begin() noexcept { return data_.data(); }
  iterator end() noexcept { return data_.data() + size_; }
  const_iterator begin() const noexcept { return data_.data(); }
  const_iterator end() const noexcept { return data_.data() + size_; }

 private:
  std::array<T, N> data_{};
  std::size_t size_ = 0;
};

}  // namespace dynamap
