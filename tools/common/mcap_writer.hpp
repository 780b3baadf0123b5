// Writer of MCAP files: chunked (none / zstd / lz4), with message indexes, and a summary section
// (schemas, channels, statistics, chunk and metadata indexes, summary offsets), data-end and
// footer CRCs, so that indexed readers (Foxglove, @mcap/core) and linear ones both read it.
#pragma once

#include <cstdint>
#include <cstdio>
#include <map>
#include <string>
#include <vector>

namespace dynamap::tools::mcap {

class Writer {
 public:
  /// Creates `path`; compression "", "zstd" or "lz4". Throws ToolError.
  Writer(const std::string& path, const std::string& profile, const std::string& compression,
         std::size_t chunk_size = 4u << 20);
  ~Writer();
  Writer(const Writer&) = delete;
  Writer& operator=(const Writer&) = delete;

  std::uint16_t add_schema(const std::string& name, const std::string& encoding,
                           const std::string& data);
  std::uint16_t add_channel(std::uint16_t schema, const std::string& topic,
                            const std::string& message_encoding,
                            const std::map<std::string, std::string>& metadata = {});
  void write(std::uint16_t channel, std::uint64_t log_time, std::uint64_t publish_time,
             const void* data, std::size_t size);
  void add_metadata(const std::string& name, const std::map<std::string, std::string>& values);
  /// Writes the summary and footer; throws ToolError on a write error. Idempotent.
  void close();

 private:
  struct ChunkIndexEntry {
    std::uint64_t start = 0, end = 0, offset = 0, length = 0, index_length = 0;
    std::uint64_t compressed = 0, uncompressed = 0;
    std::map<std::uint16_t, std::uint64_t> index_offsets;
  };
  void emit(const std::vector<std::uint8_t>& bytes);
  void flush_chunk();

  std::string path_;
  std::string compression_;
  std::size_t chunk_size_;
  std::FILE* file_ = nullptr;
  std::uint64_t position_ = 0;
  std::uint32_t crc_ = 0;
  bool closed_ = false;
  std::vector<std::vector<std::uint8_t>> schema_records_, channel_records_;
  std::vector<std::uint8_t> chunk_;
  std::map<std::uint16_t, std::vector<std::pair<std::uint64_t, std::uint64_t>>> chunk_index_;
  std::uint64_t chunk_start_ = 0, chunk_end_ = 0;
  std::vector<ChunkIndexEntry> chunks_;
  std::vector<std::vector<std::uint8_t>> metadata_index_;
  std::map<std::uint16_t, std::uint64_t> channel_counts_;
  std::uint64_t messages_ = 0, first_time_ = 0, last_time_ = 0;
  std::uint32_t sequence_ = 0;
};

}  // namespace dynamap::tools::mcap
