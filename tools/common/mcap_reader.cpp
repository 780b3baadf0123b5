#include "common/mcap_reader.hpp"

#include <fcntl.h>
#include <lz4frame.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>
#include <zlib.h>
#include <zstd.h>

#include <algorithm>
#include <cstring>

#include "common/text_io.hpp"

namespace dynamap::tools::mcap {

std::uint32_t crc32(const std::uint8_t* data, std::size_t size, std::uint32_t crc) {
  // zlib's crc32 is CRC-32/ISO-HDLC, the one MCAP specifies; fed in pieces below 4 GiB.
  uLong c = crc;
  while (size > 0) {
    const std::size_t n = std::min<std::size_t>(size, 1u << 30);
    c = ::crc32(c, data, static_cast<uInt>(n));
    data += n;
    size -= n;
  }
  return static_cast<std::uint32_t>(c);
}

bool decompress(const std::string& compression, const std::uint8_t* data, std::size_t size,
                std::uint64_t uncompressed_size, std::vector<std::uint8_t>* out,
                std::string* problem) {
  constexpr std::uint64_t kMaxChunk = 1ull << 32;  // 4 GiB: larger is a corrupt size field
  if (uncompressed_size > kMaxChunk) {
    *problem = "uncompressed size " + std::to_string(uncompressed_size) + " is implausible";
    return false;
  }
  // A compressed chunk expands at most ~4096 times (LZ4 at most 255): a larger size is corrupt,
  // and must not be allocated.
  const std::uint64_t most =
      compression.empty() ? size : 4096 * static_cast<std::uint64_t>(size) + 65536;
  if (uncompressed_size > most) {
    *problem = "a chunk of " + std::to_string(size) + " bytes cannot hold the " +
               std::to_string(uncompressed_size) + " bytes it says";
    return false;
  }
  out->resize(uncompressed_size);
  if (compression.empty()) {
    if (size != uncompressed_size) {
      *problem = "uncompressed chunk of " + std::to_string(size) + " bytes says it holds " +
                 std::to_string(uncompressed_size);
      return false;
    }
    if (size > 0) std::memcpy(out->data(), data, size);
    return true;
  }
  if (compression == "zstd") {
    const std::size_t n = ZSTD_decompress(out->data(), out->size(), data, size);
    if (ZSTD_isError(n) != 0u || n != uncompressed_size) {
      *problem = std::string("zstd: ") +
                 (ZSTD_isError(n) != 0u ? ZSTD_getErrorName(n) : "size differs from the header");
      return false;
    }
    return true;
  }
  if (compression == "lz4") {
    LZ4F_dctx* ctx = nullptr;
    if (LZ4F_isError(LZ4F_createDecompressionContext(&ctx, LZ4F_VERSION)) != 0u) {
      *problem = "lz4: cannot create a context";
      return false;
    }
    std::size_t done = 0, used = 0;
    std::size_t ret = 1;
    while (ret != 0 && used < size) {
      std::size_t dst = out->size() - done, src = size - used;
      ret = LZ4F_decompress(ctx, out->data() + done, &dst, data + used, &src, nullptr);
      if (LZ4F_isError(ret) != 0u) break;
      done += dst;
      used += src;
      if (dst == 0 && src == 0) break;
    }
    LZ4F_freeDecompressionContext(ctx);
    if (LZ4F_isError(ret) != 0u || ret != 0 || done != uncompressed_size) {
      *problem = std::string("lz4: ") +
                 (LZ4F_isError(ret) != 0u ? LZ4F_getErrorName(ret) : "incomplete or wrong size");
      return false;
    }
    return true;
  }
  *problem = "unknown compression '" + compression + "' (known: none, zstd, lz4)";
  return false;
}

namespace {

struct Overrun {};

}  // namespace

/// Little-endian reads within [p, end); past the end throws Overrun (caught per record).
struct Reader::Cursor {
  const std::uint8_t* p;
  const std::uint8_t* end;
  std::size_t left() const { return static_cast<std::size_t>(end - p); }
  void need(std::uint64_t n) const {
    if (n > left()) throw Overrun{};
  }
  template <class T>
  T num() {
    need(sizeof(T));
    T v{};
    std::memcpy(&v, p, sizeof(T));  // MCAP is little-endian, as every host we build on
    p += sizeof(T);
    return v;
  }
  std::string str() {
    const std::uint32_t n = num<std::uint32_t>();
    need(n);
    std::string s(reinterpret_cast<const char*>(p), n);
    p += n;
    return s;
  }
  std::map<std::string, std::string> string_map() {
    const std::uint32_t n = num<std::uint32_t>();
    need(n);
    Cursor inner{p, p + n};
    p += n;
    std::map<std::string, std::string> m;
    while (inner.left() > 0) {
      std::string k = inner.str();
      m[k] = inner.str();
    }
    return m;
  }
};

Reader::Reader(const std::string& path) : path_(path) {
  const int fd = ::open(path.c_str(), O_RDONLY);
  if (fd < 0) throw ToolError(path + ": cannot open (" + std::strerror(errno) + ")");
  struct stat st {};
  if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
    ::close(fd);
    throw ToolError(path + ": not a regular file");
  }
  size_ = static_cast<std::size_t>(st.st_size);
  if (size_ > 0) {
    void* m = ::mmap(nullptr, size_, PROT_READ, MAP_PRIVATE, fd, 0);
    if (m == MAP_FAILED) {
      ::close(fd);
      throw ToolError(path + ": cannot map the file (" + std::strerror(errno) + ")");
    }
    file_ = static_cast<const std::uint8_t*>(m);
  }
  ::close(fd);
  if (size_ < sizeof(kMagic) || std::memcmp(file_, kMagic, sizeof(kMagic)) != 0) {
    if (file_ != nullptr) ::munmap(const_cast<std::uint8_t*>(file_), size_);
    throw ToolError(path + ": not an MCAP file (no MCAP magic at the start)");
  }
  if (!read_summary()) linear_scan();
}

Reader::~Reader() {
  if (file_ != nullptr) ::munmap(const_cast<std::uint8_t*>(file_), size_);
}

std::string Reader::where(std::uint64_t offset) const {
  return path_ + " at byte " + std::to_string(offset);
}

void Reader::parse_record(std::uint8_t op, const std::uint8_t* body, std::uint64_t size,
                          std::uint64_t at, std::uint32_t chunk) {
  Cursor c{body, body + size};
  switch (op) {
    case kHeader:
      profile_ = c.str();
      break;
    case kSchema: {
      Schema s;
      s.id = c.num<std::uint16_t>();
      s.name = c.str();
      s.encoding = c.str();
      s.data = c.str();
      if (s.id != 0) schemas_[s.id] = std::move(s);
      break;
    }
    case kChannel: {
      Channel ch;
      ch.id = c.num<std::uint16_t>();
      ch.schema_id = c.num<std::uint16_t>();
      ch.topic = c.str();
      ch.message_encoding = c.str();
      ch.metadata = c.string_map();
      channels_[ch.id] = std::move(ch);
      break;
    }
    case kMessage: {
      MessageRef m;
      m.channel_id = c.num<std::uint16_t>();
      m.sequence = c.num<std::uint32_t>();
      m.log_time = c.num<std::uint64_t>();
      m.publish_time = c.num<std::uint64_t>();
      m.chunk = chunk;
      m.size = c.left();
      m.record_offset = at;
      const std::uint8_t* base = chunk == MessageRef::kNoChunk ? file_ : cache_.data();
      m.offset = static_cast<std::uint64_t>(c.p - base);
      if (chunk != MessageRef::kNoChunk) {
        m.copy = static_cast<std::uint32_t>(copies_.size());
        const std::size_t n = m.size <= kCopyBytes ? m.size : kPrefixBytes;
        copies_.emplace_back(reinterpret_cast<const char*>(c.p), n);
      }
      messages_.push_back(m);
      break;
    }
    case kChunk:
      if (chunk != MessageRef::kNoChunk) throw Overrun{};  // a chunk inside a chunk is corrupt
      read_chunk(body, size, at);
      break;
    case kMetadata: {
      MetadataRecord r;
      r.name = c.str();
      r.values = c.string_map();
      metadata_.push_back(std::move(r));
      break;
    }
    default:  // indexes, attachments, statistics, unknown opcodes: not needed / skipped
      break;
  }
}

void Reader::read_chunk(const std::uint8_t* body, std::uint64_t size, std::uint64_t at) {
  Cursor c{body, body + size};
  ChunkInfo info;
  info.file_offset = at;
  info.start_time = c.num<std::uint64_t>();
  info.end_time = c.num<std::uint64_t>();
  info.uncompressed_size = c.num<std::uint64_t>();
  info.uncompressed_crc = c.num<std::uint32_t>();
  info.compression = c.str();
  info.data_size = c.num<std::uint64_t>();
  c.need(info.data_size);
  info.data_offset = static_cast<std::uint64_t>(c.p - file_);
  chunks_.push_back(info);
  std::string problem;
  if (!chunk_records(static_cast<std::uint32_t>(chunks_.size() - 1), &problem)) {
    warnings_.push_back(where(at) + ": chunk of messages " + std::to_string(info.start_time) +
                        ".." + std::to_string(info.end_time) + " ns skipped: " + problem);
  }
}

const std::vector<std::uint8_t>* Reader::decompress(std::uint32_t index, bool check_crc,
                                                    std::string* problem) {
  if (cached_chunk_ == index) return &cache_;
  cached_chunk_ = MessageRef::kNoChunk;
  const ChunkInfo& info = chunks_[index];
  if (!mcap::decompress(info.compression, file_ + info.data_offset, info.data_size,
                        info.uncompressed_size, &cache_, problem)) {
    return nullptr;
  }
  if (check_crc && info.uncompressed_crc != 0) {
    const std::uint32_t crc = crc32(cache_.data(), cache_.size());
    if (crc != info.uncompressed_crc) {
      *problem = "CRC mismatch (computed " + std::to_string(crc) + ", recorded " +
                 std::to_string(info.uncompressed_crc) + ")";
      return nullptr;
    }
  }
  cached_chunk_ = index;
  return &cache_;
}

bool Reader::chunk_records(std::uint32_t index, std::string* problem) {
  const std::vector<std::uint8_t>* records = decompress(index, true, problem);
  if (records == nullptr) return false;
  const std::size_t before = messages_.size();
  std::uint64_t pos = 0;
  while (pos < records->size()) {
    if (records->size() - pos < 9) {
      *problem = "a record inside the chunk is cut at byte " + std::to_string(pos);
      messages_.resize(before);
      return false;
    }
    const std::uint8_t op = (*records)[pos];
    std::uint64_t len = 0;
    std::memcpy(&len, records->data() + pos + 1, 8);
    if (len > records->size() - pos - 9) {
      *problem = "record " + std::to_string(op) + " inside the chunk runs past its end";
      messages_.resize(before);
      return false;
    }
    try {
      parse_record(op, records->data() + pos + 9, len, chunks_[index].file_offset, index);
    } catch (const Overrun&) {
      *problem = "record " + std::to_string(op) + " inside the chunk is malformed";
      messages_.resize(before);
      return false;
    }
    pos += 9 + len;
  }
  return true;
}

bool Reader::read_indexed(const std::vector<std::uint64_t>& chunk_offsets,
                          const std::vector<std::uint64_t>& metadata_offsets,
                          std::uint64_t footer) {
  for (const std::uint64_t at : chunk_offsets) {
    if (at >= footer || footer - at < 9 || file_[at] != kChunk) {
      warnings_.push_back(where(at) + ": chunk index points at no chunk; scanning instead");
      return false;
    }
    std::uint64_t len = 0;
    std::memcpy(&len, file_ + at + 1, 8);
    if (len > footer - at - 9) return false;
    try {
      read_chunk(file_ + at + 9, len, at);
    } catch (const Overrun&) {
      warnings_.push_back(where(at) + ": malformed chunk record; scanning instead");
      return false;
    }
  }
  for (const std::uint64_t at : metadata_offsets) {
    std::uint64_t len = 0;
    if (at >= footer || footer - at < 9 || file_[at] != kMetadata) continue;
    std::memcpy(&len, file_ + at + 1, 8);
    if (len > footer - at - 9) continue;
    try {
      parse_record(kMetadata, file_ + at + 9, len, at, MessageRef::kNoChunk);
    } catch (const Overrun&) {
      warnings_.push_back(where(at) + ": malformed metadata record skipped");
    }
  }
  return true;
}

bool Reader::read_summary() {
  constexpr std::uint64_t kFooterSize = 9 + 20;
  if (size_ < 2 * sizeof(kMagic) + kFooterSize) return false;
  if (std::memcmp(file_ + size_ - sizeof(kMagic), kMagic, sizeof(kMagic)) != 0) return false;
  const std::uint64_t footer = size_ - sizeof(kMagic) - kFooterSize;
  Cursor f{file_ + footer, file_ + footer + kFooterSize};
  if (f.num<std::uint8_t>() != kFooter || f.num<std::uint64_t>() != 20) return false;
  const std::uint64_t summary_start = f.num<std::uint64_t>();
  f.num<std::uint64_t>();  // summary_offset_start: the offsets are not needed
  const std::uint32_t summary_crc = f.num<std::uint32_t>();
  if (summary_start == 0) return false;  // no summary: scan
  if (summary_start < sizeof(kMagic) || summary_start > footer) {
    warnings_.push_back(where(footer) + ": footer points outside the file; scanning instead");
    return false;
  }
  if (summary_crc != 0 &&
      crc32(file_ + summary_start, footer + kFooterSize - 4 - summary_start) != summary_crc) {
    warnings_.push_back(where(summary_start) + ": summary CRC mismatch; scanning instead");
    return false;
  }
  std::vector<std::uint64_t> chunk_offsets, metadata_offsets;
  std::uint64_t expected = 0;
  try {
    Cursor h{file_ + sizeof(kMagic), file_ + size_};
    if (h.num<std::uint8_t>() == kHeader) {
      h.num<std::uint64_t>();
      profile_ = h.str();
    }
    for (std::uint64_t pos = summary_start; pos < footer;) {
      Cursor c{file_ + pos, file_ + footer};
      const std::uint8_t op = c.num<std::uint8_t>();
      const std::uint64_t len = c.num<std::uint64_t>();
      c.need(len);
      Cursor body{c.p, c.p + len};
      if (op == kSchema || op == kChannel) parse_record(op, c.p, len, pos, MessageRef::kNoChunk);
      if (op == kChunkIndex) {
        body.num<std::uint64_t>();
        body.num<std::uint64_t>();
        chunk_offsets.push_back(body.num<std::uint64_t>());
      } else if (op == kMetadataIndex) {
        metadata_offsets.push_back(body.num<std::uint64_t>());
      } else if (op == kStatistics) {
        expected = body.num<std::uint64_t>();
      }
      pos += 9 + len;
    }
  } catch (const Overrun&) {
    warnings_.push_back(where(summary_start) + ": malformed summary section; scanning instead");
    return false;
  }
  if (chunk_offsets.empty() && expected > 0) return false;  // unchunked messages: scan
  if (!read_indexed(chunk_offsets, metadata_offsets, footer)) return false;
  if (messages_.size() != expected && warnings_.empty()) {
    warnings_.push_back(path_ + ": the statistics count " + std::to_string(expected) +
                        " messages, the chunk indexes lead to " + std::to_string(messages_.size()) +
                        "; scanning instead");
    return false;
  }
  used_summary_ = true;
  return true;
}

void Reader::linear_scan() {
  schemas_.clear();
  channels_.clear();
  messages_.clear();
  metadata_.clear();
  chunks_.clear();
  copies_.clear();
  cached_chunk_ = MessageRef::kNoChunk;
  std::uint64_t pos = sizeof(kMagic);
  bool data_end = false;
  while (!data_end) {
    if (pos == size_) {
      damage_ = where(pos) + ": the file ends without a data-end record (truncated)";
      return;
    }
    if (size_ - pos < 9) {
      damage_ = where(pos) + ": a record header is cut by the end of the file (truncated)";
      return;
    }
    const std::uint8_t op = file_[pos];
    std::uint64_t len = 0;
    std::memcpy(&len, file_ + pos + 1, 8);
    if (len > size_ - pos - 9) {
      damage_ = where(pos) + ": record (opcode " + std::to_string(op) + ") of " +
                std::to_string(len) + " bytes runs past the end of the file (truncated?)";
      return;
    }
    if (op == kDataEnd) {
      data_end = true;
      if (len >= 4) {
        std::uint32_t crc = 0;
        std::memcpy(&crc, file_ + pos + 9, 4);
        if (crc != 0 && crc != crc32(file_, pos)) {
          warnings_.push_back(where(pos) + ": data section CRC mismatch (the data is corrupt)");
        }
      }
    }
    try {
      parse_record(op, file_ + pos + 9, len, pos, MessageRef::kNoChunk);
    } catch (const Overrun&) {
      damage_ = where(pos) + ": malformed record (opcode " + std::to_string(op) + ")";
      return;
    }
    pos += 9 + len;
  }
}

Bytes Reader::prefix(const MessageRef& m) const {
  if (m.chunk == MessageRef::kNoChunk) return {file_ + m.offset, m.size};
  const std::string& c = copies_.at(m.copy);
  return {reinterpret_cast<const std::uint8_t*>(c.data()), c.size()};
}

Bytes Reader::data(const MessageRef& m) {
  if (m.chunk == MessageRef::kNoChunk) return {file_ + m.offset, m.size};
  if (m.size <= kCopyBytes) return prefix(m);
  std::string problem;
  const std::vector<std::uint8_t>* records = decompress(m.chunk, false, &problem);
  if (records == nullptr) throw ToolError(where(chunks_.at(m.chunk).file_offset) + ": " + problem);
  return {records->data() + m.offset, m.size};
}

}  // namespace dynamap::tools::mcap
