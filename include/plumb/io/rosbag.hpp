// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief Reading ROS 1 bags (format 2.0, http://wiki.ros.org/Bags/Format/2.0): the connections
///        (topic, type, md5sum, message definition), the topic list with counts and rates, and the
///        messages of chosen connections, streamed chunk by chunk so that a bag of any size needs
///        about one chunk of memory. Chunk compression: none, bz2 and lz4 (the LZ4 frame format
///        that ROS's roslz4 writes). ROS 2 bags in MCAP are read by io::McapReader (mcap.hpp);
///        io::open_recording() (recording.hpp) opens either.
///
/// Every record is bounds-checked: a truncated or corrupt bag gives plumb::Error
/// `BAG: offset N: message`, N the byte offset in the file of the record (for a record inside a
/// chunk: `offset N (chunk at M)`, N the offset in the uncompressed chunk).

#include <cstddef>
#include <cstdint>
#include <functional>
#include <istream>
#include <memory>
#include <string>
#include <vector>

#include "plumb/io/recording.hpp"

namespace plumb::io {

/// @brief A connection record: one publisher's topic and message type.
struct BagConnection {
  std::uint32_t id = 0;
  std::string topic;
  std::string type;                ///< e.g. "sensor_msgs/PointCloud2"
  std::string md5sum;              ///< of the message definition, 32 hex digits
  std::string message_definition;  ///< the full text (may be empty)
};

/// @brief One message, valid during the callback of BagReader::read().
struct BagMessage {
  const BagConnection* connection = nullptr;
  RosTime time;                        ///< when it was recorded (not the header stamp)
  const std::uint8_t* data = nullptr;  ///< the serialized message
  std::size_t size = 0;
  std::uint64_t chunk_offset = 0;  ///< file offset of the chunk holding it
  std::uint64_t offset = 0;        ///< offset of its record in the uncompressed chunk
};

/// @brief A ROS 1 bag opened for reading. Opening reads the bag header, the connection records and
///        the chunk index at the end of the file (not the messages).
/// @note A bag whose recording was interrupted has no index: it is refused with a message that
///       suggests `rosbag reindex`. Not thread safe.
class BagReader final : public Recording {
 public:
  /// @throws plumb::Error naming the file and the offset when it is not a ROS bag 2.0, is truncated
  ///         or corrupt, or has no index.
  explicit BagReader(const std::string& path);
  /// @brief A bag read from `in` (e.g. a std::istringstream of its bytes), called `name` in messages.
  /// @throws plumb::Error as the other constructor.
  BagReader(std::unique_ptr<std::istream> in, const std::string& name);

  std::string format() const override { return "ROS 1 bag 2.0"; }
  const std::string& path() const override { return path_; }
  std::uint64_t file_size() const override { return file_size_; }
  const std::vector<BagConnection>& connections() const { return connections_; }
  std::size_t num_chunks() const override { return chunks_.size(); }
  std::uint64_t num_messages() const override;  ///< from the index
  RosTime start_time() const override;          ///< earliest record time (0 for an empty bag)
  RosTime end_time() const override;            ///< latest record time
  /// @brief Chunks by compression, e.g. {"bz2", 12}; reads the chunk headers.
  std::vector<std::pair<std::string, std::size_t>> compression() const override;

  /// @brief The topics in name order with counts and rates, read from the index records that
  ///        follow every chunk (not the messages). @throws plumb::Error on a corrupt index.
  std::vector<BagTopic> topics() const override;

  /// @brief Every connection of `topic` must carry `ros1_type` with the md5sum the decoders know.
  void check_type(const std::string& topic, const std::string& ros1_type) const override;
  /// @brief read() of the connections of `topics`, in bag (file) order.
  void read_topics(const std::vector<std::string>& topics, const std::function<bool(const RecordedMessage&)>& f,
                   const std::function<void(std::uint64_t, std::uint64_t)>& progress = {}) const override;

  /// @brief Call `f` for every message of the connections `ids`, in bag (file) order, reading only
  ///        the chunks that hold them, one at a time. Stops when `f` returns false.
  /// @param progress called after each chunk read with (bytes done, file size); may be empty
  /// @throws plumb::Error naming the file and the offset on a corrupt chunk
  void read(const std::vector<std::uint32_t>& ids, const std::function<bool(const BagMessage&)>& f,
            const std::function<void(std::uint64_t, std::uint64_t)>& progress = {}) const;

 private:
  struct ChunkInfo {
    std::uint64_t pos = 0;
    RosTime start, end;
    std::vector<std::pair<std::uint32_t, std::uint32_t>> counts;  // connection, messages
  };
  void open();
  std::string path_;
  std::unique_ptr<std::istream> in_;
  std::uint64_t file_size_ = 0;
  std::vector<BagConnection> connections_;
  std::vector<ChunkInfo> chunks_;
  mutable std::vector<std::uint8_t> compressed_, chunk_;
};

}  // namespace plumb::io
