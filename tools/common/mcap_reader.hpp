// Reader of MCAP files (the open container format ROS 2's rosbag2 writes by default): magic,
// records, chunked and unchunked data sections, the summary and its indexes when present and a
// linear scan when not, CRCs checked, chunk compression none / zstd / lz4. Host tools only.
//
// The whole file is memory-mapped; messages are located once when the file is opened and their
// bytes are handed out on request (a compressed chunk is decompressed into a one-chunk cache).
// Damage never throws once the magic was seen: the reader keeps every message before the damage
// and says where it is (damage()), and a bad chunk (CRC, unknown compression) is skipped with a
// warning naming its byte offset and time range.
#pragma once

#include <cstddef>
#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

namespace dynamap::tools::mcap {

/// The eight bytes at both ends of an MCAP file.
inline constexpr std::uint8_t kMagic[8] = {0x89, 'M', 'C', 'A', 'P', '0', '\r', '\n'};

enum Opcode : std::uint8_t {
  kHeader = 0x01,
  kFooter = 0x02,
  kSchema = 0x03,
  kChannel = 0x04,
  kMessage = 0x05,
  kChunk = 0x06,
  kMessageIndex = 0x07,
  kChunkIndex = 0x08,
  kAttachment = 0x09,
  kAttachmentIndex = 0x0A,
  kStatistics = 0x0B,
  kMetadata = 0x0C,
  kMetadataIndex = 0x0D,
  kSummaryOffset = 0x0E,
  kDataEnd = 0x0F,
};

/// CRC-32 (ISO-HDLC, as MCAP uses), continued from `crc` (0 to start).
std::uint32_t crc32(const std::uint8_t* data, std::size_t size, std::uint32_t crc = 0);

struct Schema {
  std::uint16_t id = 0;
  std::string name;
  std::string encoding;  ///< "ros2msg", "jsonschema", ...
  std::string data;
};

struct Channel {
  std::uint16_t id = 0;
  std::uint16_t schema_id = 0;
  std::string topic;
  std::string message_encoding;  ///< "cdr", "json", ...
  std::map<std::string, std::string> metadata;
};

/// Where one message lies: in the file (chunk == kNoChunk) or in a chunk's uncompressed records.
struct MessageRef {
  static constexpr std::uint32_t kNoChunk = 0xffffffffu;
  std::uint16_t channel_id = 0;
  std::uint32_t sequence = 0;
  std::uint64_t log_time = 0;
  std::uint64_t publish_time = 0;
  std::uint32_t chunk = kNoChunk;
  std::uint64_t offset = 0;  ///< of the message's data
  std::uint64_t size = 0;
  std::uint64_t record_offset = 0;  ///< file offset of the record (or of its chunk)
  std::uint32_t copy = kNoChunk;    ///< chunked: index of its copy (whole or first bytes)
};

struct ChunkInfo {
  std::uint64_t file_offset = 0;  ///< of the chunk record
  std::uint64_t data_offset = 0;  ///< of its (compressed) records in the file
  std::uint64_t data_size = 0;
  std::uint64_t uncompressed_size = 0;
  std::uint32_t uncompressed_crc = 0;
  std::uint64_t start_time = 0, end_time = 0;
  std::string compression;
};

struct MetadataRecord {
  std::string name;
  std::map<std::string, std::string> values;
};

/// A bytes view into the mapped file or the chunk cache (valid until the next data() call).
struct Bytes {
  const std::uint8_t* data = nullptr;
  std::size_t size = 0;
};

class Reader {
 public:
  /// Maps and scans `path`. Throws ToolError when it cannot be opened or is not MCAP at all.
  explicit Reader(const std::string& path);
  ~Reader();
  Reader(const Reader&) = delete;
  Reader& operator=(const Reader&) = delete;

  const std::string& path() const { return path_; }
  const std::string& profile() const { return profile_; }
  const std::map<std::uint16_t, Schema>& schemas() const { return schemas_; }
  const std::map<std::uint16_t, Channel>& channels() const { return channels_; }
  /// Every message found, in file order (chunk by chunk).
  const std::vector<MessageRef>& messages() const { return messages_; }
  const std::vector<MetadataRecord>& metadata() const { return metadata_; }
  const std::vector<ChunkInfo>& chunks() const { return chunks_; }
  /// Problems that did not stop the reading (bad chunk CRC, unknown compression, ...).
  const std::vector<std::string>& warnings() const { return warnings_; }
  /// Empty for an intact file; else where the file is damaged (truncated, corrupt record):
  /// messages() holds what lies before it.
  const std::string& damage() const { return damage_; }
  /// True when the summary section's indexes were used (false: linear scan).
  bool used_summary() const { return used_summary_; }

  /// The bytes of a message (decompressing its chunk when needed); throws ToolError on a chunk
  /// that cannot be decompressed (it was reported at open time and its messages left out).
  Bytes data(const MessageRef& message);
  /// At least the first kPrefixBytes of a message (all of it when shorter) without
  /// decompressing anything: messages in chunks are copied (up to kCopyBytes whole, else their
  /// first kPrefixBytes) when the file is opened, so headers and small messages cost one pass.
  Bytes prefix(const MessageRef& message) const;
  static constexpr std::size_t kPrefixBytes = 512;
  static constexpr std::size_t kCopyBytes = 64 * 1024;

 private:
  struct Cursor;
  bool read_summary();
  bool read_indexed(const std::vector<std::uint64_t>& chunk_offsets,
                    const std::vector<std::uint64_t>& metadata_offsets, std::uint64_t footer);
  void linear_scan();
  void parse_record(std::uint8_t op, const std::uint8_t* body, std::uint64_t size, std::uint64_t at,
                    std::uint32_t chunk);
  void read_chunk(const std::uint8_t* body, std::uint64_t size, std::uint64_t at);
  bool chunk_records(std::uint32_t index, std::string* problem);
  const std::vector<std::uint8_t>* decompress(std::uint32_t index, bool check_crc,
                                              std::string* problem);
  std::string where(std::uint64_t offset) const;

  std::string path_;
  std::string profile_;
  const std::uint8_t* file_ = nullptr;
  std::size_t size_ = 0;
  std::map<std::uint16_t, Schema> schemas_;
  std::map<std::uint16_t, Channel> channels_;
  std::vector<MessageRef> messages_;
  std::vector<MetadataRecord> metadata_;
  std::vector<ChunkInfo> chunks_;
  std::vector<std::string> warnings_;
  std::string damage_;
  bool used_summary_ = false;
  std::uint32_t cached_chunk_ = MessageRef::kNoChunk;
  std::vector<std::uint8_t> cache_;
  std::vector<std::string> copies_;
};

/// Decompresses `size` bytes of `compression` ("", "zstd", "lz4") into exactly
/// `uncompressed_size` bytes; false with a reason on failure or an unknown compression.
bool decompress(const std::string& compression, const std::uint8_t* data, std::size_t size,
                std::uint64_t uncompressed_size, std::vector<std::uint8_t>* out,
                std::string* problem);

}  // namespace dynamap::tools::mcap
