#include "common/cdr.hpp"

#include <algorithm>

namespace dynamap::tools::cdr {

Reader::Reader(const std::uint8_t* data, std::size_t size) : data_(data), size_(size) {
  if (size < kOrigin)
    throw Error("CDR: " + std::to_string(size) + " bytes, no encapsulation header");
  if (data[0] != 0 || (data[1] != 0 && data[1] != 1)) {
    throw Error("CDR: encapsulation " + std::to_string(data[0]) + " " + std::to_string(data[1]) +
                " is not plain CDR (00 00 big-endian or 00 01 little-endian)");
  }
  big_endian_ = data[1] == 0;
}

void Reader::need(std::size_t n) const {
  if (n > size_ - pos_) {
    throw Error("CDR: message ends at byte " + std::to_string(size_) + " but " + std::to_string(n) +
                " more bytes are needed at byte " + std::to_string(pos_));
  }
}

void Reader::swap(void* v, std::size_t n) {
  auto* b = static_cast<std::uint8_t*>(v);
  std::reverse(b, b + n);
}

std::string Reader::string() {
  const std::uint32_t n = read<std::uint32_t>();
  if (n == 0) return {};  // some writers omit the NUL of an empty string
  const std::uint8_t* p = bytes(n);
  // The length counts the terminating NUL; tolerate a writer that left it out.
  const std::size_t len = p[n - 1] == 0 ? n - 1 : n;
  return std::string(reinterpret_cast<const char*>(p), len);
}

std::uint32_t Reader::length(std::size_t min_element_size) {
  const std::uint32_t n = read<std::uint32_t>();
  if (min_element_size > 0 && n > left() / min_element_size) {
    throw Error("CDR: a sequence of " + std::to_string(n) + " elements at byte " +
                std::to_string(pos_) + " is longer than the " + std::to_string(left()) +
                " bytes left");
  }
  return n;
}

}  // namespace dynamap::tools::cdr
