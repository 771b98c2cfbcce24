// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief Reading MCAP files (https://mcap.dev/spec), the storage of ROS 2 bags: the schemas, the
///        channels (topic, message encoding), the topic list with counts and rates, and the messages
///        of chosen channels, streamed chunk by chunk so that a file of any size needs about one
///        chunk of memory. Chunk compression: none, lz4 (the LZ4 frame format) and zstd; a chunk's
///        uncompressed CRC32 and the summary's CRC32 (in the footer) are checked when not 0. The data
///        section's CRC32 (in DataEnd) is not: it would mean reading the whole file to open it.
///
/// With a summary section the schemas, channels, statistics and chunk indexes come from it (and the
/// per-topic times from the message indexes); without one (summary_start 0) opening scans the whole
/// data section. Every record is bounds-checked: a truncated or corrupt file gives plumb::Error
/// `FILE: offset N: message`, N the byte offset in the file of the record (for a record inside a
/// chunk: `offset N (chunk at M)`, N the offset in the uncompressed chunk).

#include <cstddef>
#include <cstdint>
#include <functional>
#include <istream>
#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "plumb/io/recording.hpp"

namespace plumb::io {

/// @brief The 8 bytes every MCAP file starts and ends with.
inline constexpr char kMcapMagic[] = "\x89MCAP0\r\n";
inline constexpr std::size_t kMcapMagicSize = 8;

/// @brief A schema record: how a channel's messages are defined.
struct McapSchema {
  std::uint16_t id = 0;
  std::string name;      ///< e.g. "sensor_msgs/msg/PointCloud2"
  std::string encoding;  ///< e.g. "ros2msg"
  std::string data;      ///< the definition's text
};

/// @brief A channel record: one topic with its message encoding.
struct McapChannel {
  std::uint16_t id = 0;
  std::uint16_t schema_id = 0;  ///< 0: no schema
  std::string topic;
  std::string message_encoding;  ///< e.g. "cdr"
};

/// @brief One message, valid during the callback of McapReader::read().
struct McapMessage {
  const McapChannel* channel = nullptr;
  std::uint32_t sequence = 0;
  std::uint64_t log_time = 0;  ///< [ns]
  std::uint64_t publish_time = 0;
  const std::uint8_t* data = nullptr;
  std::size_t size = 0;
  std::uint64_t chunk_offset = 0;  ///< file offset of the chunk (or of the record, outside chunks)
  std::uint64_t offset = 0;        ///< offset of its record in the uncompressed chunk
};

/// @brief An MCAP file opened for reading. Not thread safe.
class McapReader final : public Recording {
 public:
  /// @throws plumb::Error naming the file and the offset when it is not MCAP, truncated or corrupt.
  explicit McapReader(const std::string& path);
  /// @brief An MCAP file read from `in`, called `name` in messages.
  McapReader(std::unique_ptr<std::istream> in, const std::string& name);

  std::string format() const override { return "MCAP (ROS 2)"; }
  const std::string& path() const override { return path_; }
  std::uint64_t file_size() const override { return file_size_; }
  std::uint64_t num_messages() const override;
  std::size_t num_chunks() const override { return chunks_.size(); }
  RosTime start_time() const override;
  RosTime end_time() const override;
  std::vector<std::pair<std::string, std::size_t>> compression() const override;
  std::vector<BagTopic> topics() const override;
  /// @brief The schema of every channel of `topic` must be named the ROS 2 form of `ros1_type`
  ///        ("sensor_msgs/msg/PointCloud2") with encoding ros2msg, its messages encoded cdr.
  void check_type(const std::string& topic, const std::string& ros1_type) const override;
  void read_topics(const std::vector<std::string>& topics, const std::function<bool(const RecordedMessage&)>& f,
                   const std::function<void(std::uint64_t, std::uint64_t)>& progress = {}) const override;

  const std::vector<McapSchema>& schemas() const { return schemas_; }
  const std::vector<McapChannel>& channels() const { return channels_; }
  /// @brief The schema of `c`, nullptr when it has none.
  const McapSchema* schema(const McapChannel& c) const;
  /// @brief Whether the file has a summary section (else opening scanned the data section).
  bool has_summary() const { return summary_; }

  /// @brief Call `f` for every message of the channels `ids`: chunk by chunk in the order of their
  ///        start times, the messages of a chunk in log-time order (chunks that overlap in time,
  ///        which writers do not produce, are not merged). Stops when `f` returns false.
  /// @throws plumb::Error naming the file and the offset on a corrupt chunk or record
  void read(const std::vector<std::uint16_t>& ids, const std::function<bool(const McapMessage&)>& f,
            const std::function<void(std::uint64_t, std::uint64_t)>& progress = {}) const;

  struct ChunkInfo {
    std::uint64_t pos = 0, length = 0;  ///< of the chunk record (opcode included)
    std::uint64_t start = 0, end = 0;   ///< message log times [ns]
    std::string compression;
    std::vector<std::pair<std::uint16_t, std::uint64_t>> index_offsets;  ///< channel, message index record
    bool indexed = false;  ///< index_offsets lists every channel of the chunk
  };
  struct ChannelStats {
    std::uint64_t count = 0, first = 0, last = 0;
  };

 private:
  void open();
  void read_summary(std::uint64_t begin, std::uint64_t end);
  void scan();
  void add_schema(McapSchema s, std::uint64_t at);
  void add_channel(McapChannel c, std::uint64_t at);
  void count(std::uint16_t channel, std::uint64_t log_time, std::uint64_t at);
  // Decompress the chunk record at `c.pos` into chunk_ (checking its CRC).
  void load_chunk(const ChunkInfo& c) const;
  // The records of chunk_ (or of one loose record) with `f(opcode, content, size, offset)`.
  void for_each_record(const std::function<void(std::uint8_t, const std::uint8_t*, std::uint64_t, std::uint64_t)>& f,
                       std::uint64_t chunk_pos) const;

  std::string path_;
  std::unique_ptr<std::istream> in_;
  std::uint64_t file_size_ = 0;
  std::uint64_t data_begin_ = 0, data_end_ = 0;  ///< the records after the header, up to the summary
  bool summary_ = false;
  bool loose_ = false;  ///< messages outside chunks: read() scans the data section
  std::vector<McapSchema> schemas_;
  std::vector<McapChannel> channels_;
  std::vector<ChunkInfo> chunks_;
  std::map<std::uint16_t, ChannelStats> stats_;  ///< from the scan (no summary or loose messages)
  bool have_stats_ = false, have_statistics_ = false;
  std::uint64_t message_count_ = 0, start_ = 0, end_ = 0;
  mutable std::vector<std::uint8_t> compressed_, chunk_;
  mutable std::uint64_t chunk_start_ = 0, chunk_end_ = 0;  ///< of the chunk load_chunk() read last
  mutable std::string chunk_compression_;
};

}  // namespace plumb::io
