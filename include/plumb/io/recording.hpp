// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief One interface over the recordings `plumb import` reads: ROS 1 bags (io::BagReader) and
///        ROS 2 bags in MCAP (io::McapReader). io::open_recording() chooses by the file's first
///        bytes. A ROS 2 sqlite3 bag (.db3) is refused with a message suggesting `ros2 bag convert`.

#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace plumb::io {

/// @brief A ROS time: seconds and nanoseconds since the epoch (or since any origin).
struct RosTime {
  std::uint32_t sec = 0;
  std::uint32_t nsec = 0;
  /// @brief The time in seconds: the nanoseconds divided by 10^9, correctly rounded (so a stamp
  ///        written from a double of up to about 10^6 s reads back as that double).
  double seconds() const { return static_cast<double>(nanoseconds()) / 1e9; }
  /// @brief The time in nanoseconds.
  std::int64_t nanoseconds() const { return static_cast<std::int64_t>(sec) * 1000000000 + nsec; }
};

/// @brief One topic of a recording (a ROS 1 bag's connections together), as `rosbag info` lists it.
struct BagTopic {
  std::string topic;
  std::string type;
  std::string md5sum;  ///< ROS 1 only (empty in MCAP)
  std::uint64_t messages = 0;
  RosTime first, last;  ///< record times of the first and the last message
  /// @brief Mean message rate (messages - 1) / (last - first) [Hz]; 0 with fewer than two messages.
  double rate_hz = 0.0;
};

/// @brief How a recording serializes its messages (the decoders of ros_messages.hpp read both).
enum class RosSerialization {
  kRos1,  ///< ROS 1: little-endian, no alignment, strings and arrays prefixed by a uint32 length
  kCdr,   ///< ROS 2: OMG CDR with its 4-byte encapsulation header (either byte order, aligned)
};

/// @brief One message handed to Recording::read_topics(); valid during the callback.
struct RecordedMessage {
  const std::string* topic = nullptr;
  RosTime time;                        ///< when it was recorded (not the header stamp)
  const std::uint8_t* data = nullptr;  ///< the serialized message
  std::size_t size = 0;
  RosSerialization serialization = RosSerialization::kRos1;
  std::uint64_t chunk_offset = 0;  ///< file offset of the chunk (or record) holding it
  std::uint64_t offset = 0;        ///< offset of its record in the uncompressed chunk
};

/// @brief A recording of ROS messages opened for reading.
class Recording {
 public:
  virtual ~Recording() = default;
  Recording() = default;
  Recording(const Recording&) = delete;
  Recording& operator=(const Recording&) = delete;

  /// @brief "ROS 1 bag 2.0" or "MCAP (ROS 2)".
  virtual std::string format() const = 0;
  virtual const std::string& path() const = 0;
  virtual std::uint64_t file_size() const = 0;
  virtual std::uint64_t num_messages() const = 0;
  virtual std::size_t num_chunks() const = 0;
  virtual RosTime start_time() const = 0;  ///< earliest record time (0 when empty)
  virtual RosTime end_time() const = 0;    ///< latest record time
  /// @brief Chunks by compression, e.g. {"lz4", 12}.
  virtual std::vector<std::pair<std::string, std::size_t>> compression() const = 0;
  /// @brief The topics in name order with their types as the recording names them
  ///        ("sensor_msgs/PointCloud2" in ROS 1, "sensor_msgs/msg/PointCloud2" in ROS 2).
  virtual std::vector<BagTopic> topics() const = 0;
  /// @brief Check that `topic` (if the recording has it) carries `ros1_type` (e.g.
  ///        "sensor_msgs/PointCloud2", or its ROS 2 name) in the version the decoders read.
  /// @throws plumb::Error naming the file and the topic otherwise.
  virtual void check_type(const std::string& topic, const std::string& ros1_type) const = 0;
  /// @brief Call `f` for every message of `topics` in log-time order (ROS 1: bag order), reading
  ///        one chunk at a time. Stops when `f` returns false.
  /// @param progress called after each chunk with (bytes done, file size); may be empty
  /// @throws plumb::Error naming the file and the offset on a corrupt chunk
  virtual void read_topics(const std::vector<std::string>& topics,
                           const std::function<bool(const RecordedMessage&)>& f,
                           const std::function<void(std::uint64_t, std::uint64_t)>& progress = {}) const = 0;
};

/// @brief A ROS type name in its ROS 1 spelling: "sensor_msgs/msg/PointCloud2" becomes
///        "sensor_msgs/PointCloud2"; a ROS 1 name is returned as it is.
std::string ros1_type_name(const std::string& type);

/// @brief Open a ROS 1 bag or an MCAP file, chosen by its first bytes.
/// @throws plumb::Error naming the file when it is neither (a ROS 2 sqlite3 bag gets a message
///         suggesting `ros2 bag convert` to MCAP), or as the readers' constructors.
std::unique_ptr<Recording> open_recording(const std::string& path);

}  // namespace plumb::io
