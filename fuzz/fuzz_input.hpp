// Reads typed values from a libFuzzer input; past the end every read gives zero bytes, so a
// target never needs to check the length.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <string>

namespace dynamap::fuzz {

class FuzzInput {
 public:
  FuzzInput(const std::uint8_t* data, std::size_t size) : data_(data), size_(size) {}

  template <class T>
  T take() {
    T v{};
    unsigned char bytes[sizeof(T)] = {};
    for (std::size_t i = 0; i < sizeof(T) && pos_ < size_; ++i) bytes[i] = data_[pos_++];
    std::memcpy(&v, bytes, sizeof(T));
    return v;
  }
  /// Bytes up to (not including) the next `separator`, or to the end.
  std::string take_until(char separator) {
    std::string s;
    while (pos_ < size_ && static_cast<char>(data_[pos_]) != separator) {
      s.push_back(static_cast<char>(data_[pos_++]));
    }
    if (pos_ < size_) ++pos_;
    return s;
  }
  std::size_t remaining() const { return size_ - pos_; }

 private:
  const std::uint8_t* data_;
  std::size_t size_;
  std::size_t pos_ = 0;
};

/// A per-process scratch path for targets whose reader takes a file name.
std::string scratch_path(const char* name);

}  // namespace dynamap::fuzz
