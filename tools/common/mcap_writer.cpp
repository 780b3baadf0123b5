#include "common/mcap_writer.hpp"

#include <lz4frame.h>
#include <zstd.h>

#include <algorithm>
#include <cstring>

#include "common/mcap_reader.hpp"
#include "common/text_io.hpp"

namespace dynamap::tools::mcap {
namespace {

// A record being built: opcode, a length patched in at the end, the fields.
struct Record {
  std::vector<std::uint8_t> b;
  explicit Record(std::uint8_t op) : b(9, 0) { b[0] = op; }
  template <class T>
  Record& num(T v) {
    const std::size_t at = b.size();
    b.resize(at + sizeof(T));
    std::memcpy(b.data() + at, &v, sizeof(T));
    return *this;
  }
  Record& str(const std::string& s) {
    num<std::uint32_t>(static_cast<std::uint32_t>(s.size()));
    b.insert(b.end(), s.begin(), s.end());
    return *this;
  }
  Record& string_map(const std::map<std::string, std::string>& m) {
    std::uint32_t n = 0;
    for (const auto& [k, v] : m) n += static_cast<std::uint32_t>(8 + k.size() + v.size());
    num(n);
    for (const auto& [k, v] : m) str(k).str(v);
    return *this;
  }
  std::vector<std::uint8_t>& done() {
    const std::uint64_t len = b.size() - 9;
    std::memcpy(b.data() + 1, &len, 8);
    return b;
  }
};

std::vector<std::uint8_t> compress(const std::string& how, const std::vector<std::uint8_t>& in) {
  if (how.empty()) return in;
  std::vector<std::uint8_t> out;
  if (how == "zstd") {
    out.resize(ZSTD_compressBound(in.size()));
    const std::size_t n = ZSTD_compress(out.data(), out.size(), in.data(), in.size(), 1);
    if (ZSTD_isError(n) != 0u) throw ToolError(std::string("zstd: ") + ZSTD_getErrorName(n));
    out.resize(n);
    return out;
  }
  out.resize(LZ4F_compressFrameBound(in.size(), nullptr));
  const std::size_t n = LZ4F_compressFrame(out.data(), out.size(), in.data(), in.size(), nullptr);
  if (LZ4F_isError(n) != 0u) throw ToolError(std::string("lz4: ") + LZ4F_getErrorName(n));
  out.resize(n);
  return out;
}

}  // namespace

Writer::Writer(const std::string& path, const std::string& profile, const std::string& compression,
               std::size_t chunk_size)
    : path_(path), compression_(compression), chunk_size_(chunk_size) {
  if (!compression.empty() && compression != "zstd" && compression != "lz4") {
    throw ToolError(path + ": unknown compression '" + compression + "' (none, zstd, lz4)");
  }
  file_ = std::fopen(path.c_str(), "wb");
  if (file_ == nullptr) throw ToolError(path + ": cannot create file");
  emit(std::vector<std::uint8_t>(kMagic, kMagic + sizeof(kMagic)));
  emit(Record(kHeader).str(profile).str("dynamap").done());
}

Writer::~Writer() {
  try {
    close();
  } catch (const ToolError&) {  // a destructor must not throw; close() explicitly to see errors
  }
}

void Writer::emit(const std::vector<std::uint8_t>& bytes) {
  if (std::fwrite(bytes.data(), 1, bytes.size(), file_) != bytes.size()) {
    throw ToolError(path_ + ": write error");
  }
  crc_ = crc32(bytes.data(), bytes.size(), crc_);
  position_ += bytes.size();
}

std::uint16_t Writer::add_schema(const std::string& name, const std::string& encoding,
                                 const std::string& data) {
  const auto id = static_cast<std::uint16_t>(schema_records_.size() + 1);
  schema_records_.push_back(Record(kSchema).num(id).str(name).str(encoding).str(data).done());
  emit(schema_records_.back());
  return id;
}

std::uint16_t Writer::add_channel(std::uint16_t schema, const std::string& topic,
                                  const std::string& message_encoding,
                                  const std::map<std::string, std::string>& metadata) {
  const auto id = static_cast<std::uint16_t>(channel_records_.size());
  channel_records_.push_back(Record(kChannel)
                                 .num(id)
                                 .num(schema)
                                 .str(topic)
                                 .str(message_encoding)
                                 .string_map(metadata)
                                 .done());
  emit(channel_records_.back());
  channel_counts_[id] = 0;
  return id;
}

void Writer::write(std::uint16_t channel, std::uint64_t log_time, std::uint64_t publish_time,
                   const void* data, std::size_t size) {
  if (chunk_.empty()) chunk_start_ = chunk_end_ = log_time;
  chunk_start_ = std::min(chunk_start_, log_time);
  chunk_end_ = std::max(chunk_end_, log_time);
  chunk_index_[channel].emplace_back(log_time, chunk_.size());
  Record r(kMessage);
  r.num(channel).num(sequence_++).num(log_time).num(publish_time);
  r.b.insert(r.b.end(), static_cast<const std::uint8_t*>(data),
             static_cast<const std::uint8_t*>(data) + size);
  const auto& rec = r.done();
  chunk_.insert(chunk_.end(), rec.begin(), rec.end());
  if (messages_ == 0) first_time_ = last_time_ = log_time;
  first_time_ = std::min(first_time_, log_time);
  last_time_ = std::max(last_time_, log_time);
  ++messages_;
  ++channel_counts_[channel];
  if (chunk_.size() >= chunk_size_) flush_chunk();
}

void Writer::flush_chunk() {
  if (chunk_.empty()) return;
  ChunkIndexEntry e;
  e.start = chunk_start_;
  e.end = chunk_end_;
  e.offset = position_;
  const std::vector<std::uint8_t> packed = compress(compression_, chunk_);
  Record c(kChunk);
  c.num(chunk_start_).num(chunk_end_).num<std::uint64_t>(chunk_.size());
  c.num(crc32(chunk_.data(), chunk_.size())).str(compression_).num<std::uint64_t>(packed.size());
  c.b.insert(c.b.end(), packed.begin(), packed.end());
  emit(c.done());
  e.length = position_ - e.offset;
  e.compressed = packed.size();
  e.uncompressed = chunk_.size();
  const std::uint64_t index_start = position_;
  for (const auto& [channel, entries] : chunk_index_) {
    e.index_offsets[channel] = position_;
    Record m(kMessageIndex);
    m.num(channel).num(static_cast<std::uint32_t>(entries.size() * 16));
    for (const auto& [t, off] : entries) m.num(t).num(off);
    emit(m.done());
  }
  e.index_length = position_ - index_start;
  chunks_.push_back(e);
  chunk_.clear();
  chunk_index_.clear();
}

void Writer::add_metadata(const std::string& name,
                          const std::map<std::string, std::string>& values) {
  flush_chunk();
  const std::uint64_t at = position_;
  emit(Record(kMetadata).str(name).string_map(values).done());
  metadata_index_.push_back(Record(kMetadataIndex).num(at).num(position_ - at).str(name).done());
}

void Writer::close() {
  if (closed_) return;
  closed_ = true;
  flush_chunk();
  emit(Record(kDataEnd).num(crc_).done());
  const std::uint64_t summary_start = position_;
  crc_ = 0;  // from here: the summary CRC
  std::vector<std::vector<std::uint8_t>> offsets;
  auto group = [&](std::uint8_t op, const std::vector<std::vector<std::uint8_t>>& records) {
    if (records.empty()) return;
    const std::uint64_t start = position_;
    for (const auto& r : records) emit(r);
    offsets.push_back(Record(kSummaryOffset).num(op).num(start).num(position_ - start).done());
  };
  group(kSchema, schema_records_);
  group(kChannel, channel_records_);
  Record st(kStatistics);
  st.num(messages_).num(static_cast<std::uint16_t>(schema_records_.size()));
  st.num(static_cast<std::uint32_t>(channel_records_.size())).num<std::uint32_t>(0);
  st.num(static_cast<std::uint32_t>(metadata_index_.size()));
  st.num(static_cast<std::uint32_t>(chunks_.size())).num(first_time_).num(last_time_);
  st.num(static_cast<std::uint32_t>(channel_counts_.size() * 10));
  for (const auto& [id, n] : channel_counts_) st.num(id).num(n);
  group(kStatistics, {st.done()});
  std::vector<std::vector<std::uint8_t>> indexes;
  for (const ChunkIndexEntry& e : chunks_) {
    Record r(kChunkIndex);
    r.num(e.start).num(e.end).num(e.offset).num(e.length);
    r.num(static_cast<std::uint32_t>(e.index_offsets.size() * 10));
    for (const auto& [id, off] : e.index_offsets) r.num(id).num(off);
    r.num(e.index_length).str(compression_).num(e.compressed).num(e.uncompressed);
    indexes.push_back(r.done());
  }
  group(kChunkIndex, indexes);
  group(kMetadataIndex, metadata_index_);
  const std::uint64_t offsets_start = position_;
  for (const auto& r : offsets) emit(r);
  Record footer(kFooter);
  footer.num(summary_start).num(offsets_start);
  std::vector<std::uint8_t> f = footer.b;
  const std::uint64_t len = 20;  // the two offsets and the CRC
  std::memcpy(f.data() + 1, &len, 8);
  // The summary CRC covers the summary section and the footer up to summary_offset_start.
  const std::uint32_t crc = crc32(f.data(), f.size(), crc_);
  f.resize(f.size() + 4);
  std::memcpy(f.data() + f.size() - 4, &crc, 4);
  emit(f);
  emit(std::vector<std::uint8_t>(kMagic, kMagic + sizeof(kMagic)));
  if (std::fclose(file_) != 0) {
    file_ = nullptr;
    throw ToolError(path_ + ": write error on close");
  }
  file_ = nullptr;
}

}  // namespace dynamap::tools::mcap
