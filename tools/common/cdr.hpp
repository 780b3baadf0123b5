// CDR (OMG XCDR1 plain CDR, as ROS 2's rmw layers serialise messages): the 4-byte encapsulation
// header (CDR_BE 00 00 / CDR_LE 00 01, two option bytes) and primitives aligned to their own size
// counted from the end of that header; strings as uint32 length (with the NUL) + bytes + NUL,
// sequences as uint32 count + elements. Host tools only.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

#include "common/text_io.hpp"

namespace dynamap::tools::cdr {

/// Malformed CDR data; the caller adds bag, topic and time.
class Error : public ToolError {
 public:
  using ToolError::ToolError;
};

class Reader {
 public:
  /// Reads and checks the encapsulation header. Throws Error.
  Reader(const std::uint8_t* data, std::size_t size);

  void align(std::size_t n) {
    const std::size_t rel = pos_ - kOrigin;
    const std::size_t pad = (n - rel % n) % n;
    need(pad);
    pos_ += pad;
  }
  template <class T>
  T read() {
    align(sizeof(T));
    need(sizeof(T));
    T v{};
    std::memcpy(&v, data_ + pos_, sizeof(T));
    if (big_endian_ && sizeof(T) > 1) swap(&v, sizeof(T));
    pos_ += sizeof(T);
    return v;
  }
  std::string string();
  /// A sequence/array length prefix, checked against the bytes left (each element >= min_size).
  std::uint32_t length(std::size_t min_element_size);
  /// `n` raw bytes (uint8[] payloads) without a copy.
  const std::uint8_t* bytes(std::size_t n) {
    need(n);
    const std::uint8_t* p = data_ + pos_;
    pos_ += n;
    return p;
  }
  std::size_t position() const { return pos_; }
  std::size_t left() const { return size_ - pos_; }
  bool big_endian() const { return big_endian_; }

 private:
  static constexpr std::size_t kOrigin = 4;
  void need(std::size_t n) const;
  static void swap(void* v, std::size_t n);
  const std::uint8_t* data_;
  std::size_t size_;
  std::size_t pos_ = kOrigin;
  bool big_endian_ = false;
};

/// Little-endian CDR writer (header 00 01 00 00).
class Writer {
 public:
  Writer() : buf_{0x00, 0x01, 0x00, 0x00} {}
  void align(std::size_t n) {
    while ((buf_.size() - 4) % n != 0) buf_.push_back(0);
  }
  template <class T>
  void write(T v) {
    align(sizeof(T));
    const std::size_t at = buf_.size();
    buf_.resize(at + sizeof(T));
    std::memcpy(buf_.data() + at, &v, sizeof(T));
  }
  void string(const std::string& s) {
    write<std::uint32_t>(static_cast<std::uint32_t>(s.size() + 1));
    buf_.insert(buf_.end(), s.begin(), s.end());
    buf_.push_back(0);
  }
  void bytes(const void* p, std::size_t n) {
    const auto* b = static_cast<const std::uint8_t*>(p);
    buf_.insert(buf_.end(), b, b + n);
  }
  const std::vector<std::uint8_t>& data() const { return buf_; }
  std::vector<std::uint8_t>& data() { return buf_; }

 private:
  std::vector<std::uint8_t> buf_;
};

}  // namespace dynamap::tools::cdr
