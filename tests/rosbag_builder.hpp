// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief ROS 1 bags (format 2.0, uncompressed chunks) and serialized messages built byte by byte
///        from the format's description (http://wiki.ros.org/Bags/Format/2.0, the ROS 1
///        serialization), for the reader's unit tests and the import benchmark. gtest-free.

#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

namespace plumb::test {

/// @brief ROS 1 serialization: little-endian values unless `big` is asked for.
struct RosWriter {
  std::string s;
  template <class T>
  RosWriter& put(T v, bool big = false) {
    char b[sizeof(T)];
    std::memcpy(b, &v, sizeof(T));
    for (std::size_t k = 0; k < sizeof(T); ++k) s += b[big ? sizeof(T) - 1 - k : k];
    return *this;
  }
  RosWriter& u32(std::uint32_t v) { return put(v); }
  RosWriter& str(const std::string& v) {
    u32(static_cast<std::uint32_t>(v.size()));
    s += v;
    return *this;
  }
  /// std_msgs/Header (seq 7).
  RosWriter& header(std::uint32_t sec, std::uint32_t nsec, const std::string& frame) {
    return u32(7).u32(sec).u32(nsec).str(frame);
  }
};

/// @brief A sensor_msgs/PointField of a PointCloud2 (count 1).
struct RosPointField {
  std::string name;
  std::uint32_t offset;
  std::uint8_t datatype;  ///< 1 INT8 .. 8 FLOAT64
};

/// @brief A serialized sensor_msgs/PointCloud2 with the points' bytes `data`.
inline std::string ros_point_cloud2(std::uint32_t sec, std::uint32_t nsec, std::uint32_t height, std::uint32_t width,
                                    const std::vector<RosPointField>& fields, bool big, std::uint32_t point_step,
                                    std::uint32_t row_step, const std::string& data) {
  RosWriter w;
  w.header(sec, nsec, "lidar").u32(height).u32(width).u32(static_cast<std::uint32_t>(fields.size()));
  for (const RosPointField& f : fields) w.str(f.name).u32(f.offset).put(f.datatype).u32(1);
  w.put<std::uint8_t>(big ? 1 : 0).u32(point_step).u32(row_step).str(data).put<std::uint8_t>(1);
  return w.s;
}

/// @brief `n` bytes of `v`, little-endian.
inline std::string bag_le(std::uint64_t v, int n) {
  std::string out;
  for (int k = 0; k < n; ++k) out += static_cast<char>(v >> (8 * k) & 0xff);
  return out;
}
/// @brief A record header field "name=value".
inline std::string bag_field(const std::string& name, const std::string& value) {
  return bag_le(name.size() + 1 + value.size(), 4) + name + "=" + value;
}
/// @brief A record: header length, header, data length, data.
inline std::string bag_record(const std::string& header, const std::string& data) {
  return bag_le(header.size(), 4) + header + bag_le(data.size(), 4) + data;
}
inline std::string bag_op(int code) { return bag_field("op", std::string(1, static_cast<char>(code))); }
inline std::string bag_time(std::uint32_t sec, std::uint32_t nsec) { return bag_le(sec, 4) + bag_le(nsec, 4); }

struct BagBuilderConnection {
  std::string topic, type, md5sum;
};
struct BagBuilderMessage {
  std::uint32_t conn, sec, nsec;
  std::string data;
};

/// @brief A bag of the connections (ids 0, 1, ...) and messages, `per_chunk` messages to a chunk,
///        each chunk followed by its index records, and the index (connections, chunk infos) at the
///        end. The chunk header says `compression` but the data is stored as it is. Without
///        `with_index` the bag header's index_pos is 0, as in a bag whose recording was interrupted.
inline std::string build_bag(const std::vector<BagBuilderConnection>& connections,
                             const std::vector<BagBuilderMessage>& messages, std::size_t per_chunk = 1000000,
                             const std::string& compression = "none", bool with_index = true) {
  const auto nconn = static_cast<std::uint32_t>(connections.size());
  std::vector<std::string> conn_records;
  for (std::uint32_t c = 0; c < nconn; ++c) {
    const BagBuilderConnection& bc = connections[c];
    conn_records.push_back(bag_record(bag_op(7) + bag_field("conn", bag_le(c, 4)) + bag_field("topic", bc.topic),
                                      bag_field("topic", bc.topic) + bag_field("type", bc.type) +
                                          bag_field("md5sum", bc.md5sum) + bag_field("message_definition", "# def\n")));
  }
  const std::string magic = "#ROSBAG V2.0\n";
  const std::size_t num_chunks = messages.empty() ? 0 : (messages.size() + per_chunk - 1) / per_chunk;
  auto bag_header = [&](std::uint64_t index_pos) {
    return bag_record(bag_op(3) + bag_field("index_pos", bag_le(index_pos, 8)) + bag_field("conn_count", bag_le(nconn, 4)) +
                          bag_field("chunk_count", bag_le(num_chunks, 4)),
                      std::string(64, ' '));
  };
  std::string body, chunk_infos;
  const std::uint64_t data_start = magic.size() + bag_header(0).size();
  for (std::size_t first = 0; first < messages.size(); first += per_chunk) {
    std::string chunk;
    for (const std::string& r : conn_records) chunk += r;
    std::vector<std::string> index(nconn);
    std::vector<std::uint32_t> counts(nconn, 0);
    const std::size_t end = std::min(messages.size(), first + per_chunk);
    for (std::size_t i = first; i < end; ++i) {
      const BagBuilderMessage& m = messages[i];
      index[m.conn] += bag_time(m.sec, m.nsec) + bag_le(chunk.size(), 4);
      ++counts[m.conn];
      chunk += bag_record(bag_op(2) + bag_field("conn", bag_le(m.conn, 4)) + bag_field("time", bag_time(m.sec, m.nsec)),
                          m.data);
    }
    const std::uint64_t chunk_pos = data_start + body.size();
    body += bag_record(bag_op(5) + bag_field("compression", compression) + bag_field("size", bag_le(chunk.size(), 4)),
                       chunk);
    std::string info_data;
    for (std::uint32_t c = 0; c < nconn; ++c) {
      body += bag_record(bag_op(4) + bag_field("ver", bag_le(1, 4)) + bag_field("conn", bag_le(c, 4)) +
                             bag_field("count", bag_le(counts[c], 4)),
                         index[c]);
      info_data += bag_le(c, 4) + bag_le(counts[c], 4);
    }
    chunk_infos += bag_record(bag_op(6) + bag_field("ver", bag_le(1, 4)) + bag_field("chunk_pos", bag_le(chunk_pos, 8)) +
                                  bag_field("start_time", bag_time(messages[first].sec, 0)) +
                                  bag_field("end_time", bag_time(messages[end - 1].sec, 0)) +
                                  bag_field("count", bag_le(nconn, 4)),
                              info_data);
  }
  const std::uint64_t index_pos = data_start + body.size();
  std::string index;
  for (const std::string& r : conn_records) index += r;
  return magic + bag_header(with_index ? index_pos : 0) + body + index + chunk_infos;
}

}  // namespace plumb::test
