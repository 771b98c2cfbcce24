// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief MCAP files and CDR messages built byte by byte from their specifications
///        (https://mcap.dev/spec; OMG CDR as ROS 2 serializes), for the reader's unit tests and the
///        import benchmark. gtest-free.

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

namespace plumb::test {

/// @brief Little-endian values, uint32-prefixed strings: MCAP's record fields.
struct McapFields {
  std::string s;
  template <class T>
  McapFields& num(T v) {
    char b[sizeof(T)];
    std::memcpy(b, &v, sizeof(T));
    s.append(b, sizeof(T));
    return *this;
  }
  McapFields& str(const std::string& v) {
    num<std::uint32_t>(static_cast<std::uint32_t>(v.size()));
    s += v;
    return *this;
  }
};

inline const std::string kMcapMagicBytes("\x89MCAP0\r\n", 8);

/// @brief A record: opcode, uint64 length, content.
inline std::string mcap_record(std::uint8_t op, const std::string& content) {
  McapFields r;
  r.num(op).num<std::uint64_t>(content.size());
  return r.s + content;
}

/// @brief CRC-32 (ISO-HDLC, as zlib computes it), bit by bit.
inline std::uint32_t crc32_of(const std::string& s) {
  std::uint32_t c = 0xffffffffu;
  for (unsigned char b : s) {
    c ^= b;
    for (int k = 0; k < 8; ++k) c = (c >> 1) ^ (0xedb88320u & (0u - (c & 1u)));
  }
  return ~c;
}

/// @brief An uncompressed chunk of `records` (message log times start..end), its CRC right unless
///        `crc_offset` spoils it.
inline std::string mcap_chunk(const std::string& records, std::uint64_t start, std::uint64_t end,
                              std::uint32_t crc_offset = 0) {
  McapFields c;
  c.num(start).num(end).num<std::uint64_t>(records.size()).num<std::uint32_t>(crc32_of(records) + crc_offset);
  c.str("").num<std::uint64_t>(records.size());
  return mcap_record(0x06, c.s + records);
}

inline std::string mcap_header() { return mcap_record(0x01, McapFields().str("ros2").str("plumb test").s); }
inline std::string mcap_schema(std::uint16_t id, const std::string& name) {
  return mcap_record(0x03, McapFields().num(id).str(name).str("ros2msg").str("(definition)").s);
}
inline std::string mcap_channel(std::uint16_t id, std::uint16_t schema, const std::string& topic) {
  return mcap_record(0x04, McapFields().num(id).num(schema).str(topic).str("cdr").num<std::uint32_t>(0).s);
}
inline std::string mcap_message(std::uint16_t channel, std::uint64_t t, const std::string& data) {
  return mcap_record(0x05, McapFields().num(channel).num<std::uint32_t>(0).num(t).num(t).s + data);
}
inline std::string mcap_footer(std::uint64_t summary_start) {
  return mcap_record(0x02, McapFields().num(summary_start).num<std::uint64_t>(0).num<std::uint32_t>(0).s);
}
inline std::string mcap_data_end() { return mcap_record(0x0F, McapFields().num<std::uint32_t>(0).s); }

/// @brief A chunk index of the chunk record at `pos` of `length` bytes, without message indexes.
inline std::string mcap_chunk_index(std::uint64_t start, std::uint64_t end, std::uint64_t pos, std::uint64_t length) {
  McapFields ci;
  ci.num(start).num(end).num(pos).num(length).str("").num<std::uint64_t>(0);
  ci.str("").num<std::uint64_t>(0).num<std::uint64_t>(0);
  return mcap_record(0x08, ci.s);
}

/// @brief CDR as ROS 2 writes it: the 4-byte encapsulation header (either byte order), then every
///        primitive aligned to its size counted from the header's end; strings with their NUL.
struct CdrFields {
  bool big;
  std::string s;
  explicit CdrFields(bool big_endian) : big(big_endian) {
    s = std::string("\0", 1) + (big ? '\0' : '\1') + std::string(2, '\0');
  }
  template <class T>
  CdrFields& num(T v) {
    while ((s.size() - 4) % sizeof(T) != 0) s += '\x77';  // padding, any value
    char b[sizeof(T)];
    std::memcpy(b, &v, sizeof(T));
    if (big) std::reverse(b, b + sizeof(T));
    s.append(b, sizeof(T));
    return *this;
  }
  CdrFields& str(const std::string& v) {
    num<std::uint32_t>(static_cast<std::uint32_t>(v.size() + 1));
    s += v;
    s += '\0';
    return *this;
  }
  /// std_msgs/msg/Header: int32 sec, uint32 nanosec, frame_id.
  CdrFields& header(std::int32_t sec, std::uint32_t nsec, const std::string& frame) {
    return num(sec).num(nsec).str(frame);
  }
  const std::uint8_t* data() const { return reinterpret_cast<const std::uint8_t*>(s.data()); }
};

/// @brief A sensor_msgs/msg/PointCloud2 in CDR: fields (name, offset, datatype), count 1 each.
struct CdrPointField {
  std::string name;
  std::uint32_t offset;
  std::uint8_t datatype;
};
inline std::string cdr_point_cloud2(bool big, std::int32_t sec, std::uint32_t nsec, std::uint32_t height,
                                    std::uint32_t width, const std::vector<CdrPointField>& fields, bool is_bigendian,
                                    std::uint32_t point_step, std::uint32_t row_step, const std::string& data) {
  CdrFields c(big);
  c.header(sec, nsec, "lidar").num(height).num(width).num<std::uint32_t>(static_cast<std::uint32_t>(fields.size()));
  for (const CdrPointField& f : fields) c.str(f.name).num(f.offset).num(f.datatype).num<std::uint32_t>(1);
  c.num<std::uint8_t>(is_bigendian ? 1 : 0).num(point_step).num(row_step);
  c.num<std::uint32_t>(static_cast<std::uint32_t>(data.size()));
  c.s += data;
  c.num<std::uint8_t>(1);
  return c.s;
}

}  // namespace plumb::test
