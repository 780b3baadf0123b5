// Internal: include/dynamap/track/detail/ is installed because Tracker holds its track histories
// inline, but it is not a stable API.
#pragma once

#include <array>
#include <cstddef>

namespace dynamap {

/// Fixed ring of the last `length` values (length <= N chosen at run time); age 0 is the newest.
template <typename T, std::size_t N>
class HistoryRing {
 public:
  void clear() noexcept { head_ = count_ = 0; }
  void push(const T& v, std::size_t length) noexcept {
    data_[head_] = v;
    head_ = (head_ + 1) % N;
    if (count_ < length) ++count_;
  }
  std::size_t size() const noexcept { return count_; }
  /// Adds `d` to every stored value (a change of reference, e.g. a shifted bias correction).
  void add_to_all(const T& d) noexcept {
    for (std::size_t age = 0; age < count_; ++age) data_[(head_ + N - 1 - age) % N] += d;
  }
  /// The value pushed `age` pushes ago (age < size()).
  const T& at_age(std::size_t age) const noexcept { return data_[(head_ + N - 1 - age) % N]; }

 private:
  std::array<T, N> data_{};
  std::size_t head_ = 0;
  std::size_t count_ = 0;
};

}  // namespace dynamap
