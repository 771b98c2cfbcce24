// SPDX-License-Identifier: BSD-3-Clause
// MCAP (https://mcap.dev/spec). A file is the magic "\x89MCAP0\r\n", records, and the magic again.
// A record is uint8 opcode, uint64 content length, the content. Integers are little-endian; a
// string is a uint32 length and the bytes; a map or array a uint32 byte length and the entries.
//   0x01 Header        string profile, string library
//   0x02 Footer        uint64 summary_start, uint64 summary_offset_start, uint32 summary_crc
//   0x03 Schema        uint16 id, string name, string encoding, uint32-prefixed bytes data
//   0x04 Channel       uint16 id, uint16 schema_id, string topic, string message_encoding,
//                      map<string, string> metadata
//   0x05 Message       uint16 channel_id, uint32 sequence, uint64 log_time, uint64 publish_time,
//                      data (the rest of the record)
//   0x06 Chunk         uint64 message_start_time, uint64 message_end_time, uint64 uncompressed_size,
//                      uint32 uncompressed_crc, string compression, uint64-prefixed bytes records
//   0x07 MessageIndex  uint16 channel_id, array<(uint64 log_time, uint64 offset)>
//   0x08 ChunkIndex    uint64 message_start_time, uint64 message_end_time, uint64 chunk_start_offset,
//                      uint64 chunk_length, map<uint16, uint64> message_index_offsets,
//                      uint64 message_index_length, string compression, uint64 compressed_size,
//                      uint64 uncompressed_size
//   0x0B Statistics    uint64 message_count, uint16 schema_count, uint32 channel_count,
//                      uint32 attachment_count, uint32 metadata_count, uint32 chunk_count,
//                      uint64 message_start_time, uint64 message_end_time,
//                      map<uint16, uint64> channel_message_counts
//   0x0E SummaryOffset, 0x0F DataEnd (uint32 data_section_crc); attachments and metadata (0x09,
//   0x0A, 0x0C, 0x0D) are skipped.
// The data section (Header to DataEnd) holds the messages, in chunks or not; the summary section
// after it repeats the schemas and channels and holds the statistics and one index per chunk; the
// footer at the end says where the summary starts (0: there is none).
#include "plumb/io/mcap.hpp"

#include <zlib.h>

#include <algorithm>
#include <cstring>
#include <fstream>
#include <limits>
#include <sstream>

#include "plumb/core/error.hpp"
#include "plumb/io/input_file.hpp"
#include "detail_cloud_io.hpp"
#include "detail_decompress.hpp"

namespace plumb::io {
namespace {

constexpr std::uint8_t kOpHeader = 0x01, kOpFooter = 0x02, kOpSchema = 0x03, kOpChannel = 0x04, kOpMessage = 0x05,
                       kOpChunk = 0x06, kOpMessageIndex = 0x07, kOpChunkIndex = 0x08, kOpStatistics = 0x0B,
                       kOpDataEnd = 0x0F;
constexpr std::uint64_t kRecordHead = 9;          // opcode, length
constexpr std::uint64_t kFooterSize = 9 + 20;     // the footer record
constexpr std::uint64_t kMessageHead = 2 + 4 + 8 + 8;

// Where a record is, for messages: "FILE: offset N" or "FILE: offset N (chunk at M)".
struct Place {
  const std::string* path;
  std::uint64_t offset;
  std::uint64_t chunk = 0;
  bool in_chunk = false;
};
std::ostream& operator<<(std::ostream& os, const Place& p) {
  os << *p.path << ": offset " << p.offset;
  if (p.in_chunk) os << " (chunk at " << p.chunk << ')';
  return os;
}
std::string where(const Place& p) {
  std::ostringstream s;
  s << p;
  return s.str();
}

// Bounds-checked reader of a record's content.
class Fields {
 public:
  Fields(const std::uint8_t* p, std::uint64_t n, const char* record, const Place& at)
      : p_(p), n_(n), record_(record), at_(at) {}
  const std::uint8_t* take(std::uint64_t k, const char* what) {
    PLUMB_CHECK(k <= n_ - i_, at_ << ": " << record_ << " record cut short reading " << what << " (needs " << k
                                  << " bytes at byte " << i_ << " of " << n_ << ')');
    const std::uint8_t* at = p_ + i_;
    i_ += k;
    return at;
  }
  template <class T>
  T num(const char* what) {
    return cloud_detail::load<T>(reinterpret_cast<const char*>(take(sizeof(T), what)));
  }
  std::string str(const char* what) {
    const std::uint32_t len = num<std::uint32_t>(what);
    return std::string(reinterpret_cast<const char*>(take(len, what)), len);
  }
  // A uint32-prefixed map or array: its bytes, as Fields.
  Fields group(const char* what) {
    const std::uint32_t len = num<std::uint32_t>(what);
    return Fields(take(len, what), len, record_, at_);
  }
  std::uint64_t left() const { return n_ - i_; }
  const std::uint8_t* here() const { return p_ + i_; }

 private:
  const std::uint8_t* p_;
  std::uint64_t n_, i_ = 0;
  const char* record_;
  Place at_;
};

void read_at(std::istream& in, std::uint64_t pos, std::uint8_t* out, std::size_t n, const Place& at) {
  in.clear();
  in.seekg(static_cast<std::streamoff>(pos));
  in.read(reinterpret_cast<char*>(out), static_cast<std::streamsize>(n));
  PLUMB_CHECK(in.good(), at << ": read error");
}

// A record of the file between `pos` and `end`: its opcode and content length.
struct RecordHead {
  std::uint8_t op = 0;
  std::uint64_t length = 0;
  std::uint64_t content = 0, next = 0;
};
RecordHead record_head(std::istream& in, std::uint64_t pos, std::uint64_t end, const Place& at) {
  PLUMB_CHECK(end >= pos && end - pos >= kRecordHead,
              at << ": record cut off (" << (end >= pos ? end - pos : 0) << " bytes left before offset " << end
                 << "): the file is truncated or corrupt");
  std::uint8_t b[kRecordHead];
  read_at(in, pos, b, sizeof(b), at);
  RecordHead r;
  r.op = b[0];
  r.length = cloud_detail::load<std::uint64_t>(reinterpret_cast<const char*>(b + 1));
  r.content = pos + kRecordHead;
  PLUMB_CHECK(r.length <= end - r.content, at << ": record (opcode 0x" << std::hex << int(r.op) << std::dec << ") of "
                                              << r.length << " bytes overruns its section, which ends at offset " << end
                                              << ": the file is truncated or corrupt");
  r.next = r.content + r.length;
  return r;
}

// The CRC32 of the file's bytes begin..end, read a MiB at a time.
std::uint32_t file_crc32(std::istream& in, std::uint64_t begin, std::uint64_t end, const Place& at) {
  std::vector<std::uint8_t> buf(std::min<std::uint64_t>(end - begin, 1 << 20));
  uLong crc = crc32_z(0L, Z_NULL, 0);
  for (std::uint64_t pos = begin; pos < end;) {
    const std::size_t n = static_cast<std::size_t>(std::min<std::uint64_t>(end - pos, buf.size()));
    read_at(in, pos, buf.data(), n, at);
    crc = crc32_z(crc, buf.data(), n);
    pos += n;
  }
  return static_cast<std::uint32_t>(crc);
}

std::vector<std::uint8_t> content(std::istream& in, const RecordHead& r, const Place& at) {
  std::vector<std::uint8_t> data(static_cast<std::size_t>(r.length));
  if (!data.empty()) read_at(in, r.content, data.data(), data.size(), at);
  return data;
}

McapSchema parse_schema(Fields f) {
  McapSchema s;
  s.id = f.num<std::uint16_t>("id");
  s.name = f.str("name");
  s.encoding = f.str("encoding");
  s.data = f.str("data");
  return s;
}

McapChannel parse_channel(Fields f) {
  McapChannel c;
  c.id = f.num<std::uint16_t>("id");
  c.schema_id = f.num<std::uint16_t>("schema_id");
  c.topic = f.str("topic");
  c.message_encoding = f.str("message_encoding");
  f.group("metadata");
  return c;
}

McapMessage parse_message(const std::uint8_t* p, std::uint64_t n, const Place& at) {
  Fields f(p, n, "message", at);
  McapMessage m;
  const auto channel = f.num<std::uint16_t>("channel_id");
  m.sequence = f.num<std::uint32_t>("sequence");
  m.log_time = f.num<std::uint64_t>("log_time");
  m.publish_time = f.num<std::uint64_t>("publish_time");
  m.data = f.here();
  m.size = static_cast<std::size_t>(f.left());
  m.offset = channel;  // the caller resolves the channel
  return m;
}

RosTime ros_time(std::uint64_t ns, const Place& at) {
  PLUMB_CHECK(ns / 1000000000 <= std::numeric_limits<std::uint32_t>::max(),
              at << ": log time " << ns << " ns is after the year 2106");
  return {static_cast<std::uint32_t>(ns / 1000000000), static_cast<std::uint32_t>(ns % 1000000000)};
}

// "sensor_msgs/PointCloud2" -> "sensor_msgs/msg/PointCloud2".
std::string ros2_type_name(const std::string& ros1) {
  const std::size_t slash = ros1.find('/');
  if (slash == std::string::npos || ros1.compare(slash, 5, "/msg/") == 0) return ros1;
  return ros1.substr(0, slash) + "/msg" + ros1.substr(slash);
}

}  // namespace

McapReader::McapReader(const std::string& path)
    : path_(path), in_(std::make_unique<std::ifstream>(open_input_file(path))) {
  open();
}

McapReader::McapReader(std::unique_ptr<std::istream> in, const std::string& name) : path_(name), in_(std::move(in)) {
  open();
}

void McapReader::open() {
  std::istream& in = *in_;
  in.seekg(0, std::ios::end);
  file_size_ = static_cast<std::uint64_t>(in.tellg());
  char magic[kMcapMagicSize] = {};
  in.seekg(0);
  in.read(magic, kMcapMagicSize);
  PLUMB_CHECK(file_size_ >= kMcapMagicSize, path_ << ": offset 0: file of " << file_size_
                                                  << " bytes: truncated, or not an MCAP file");
  PLUMB_CHECK(in.good() && std::memcmp(magic, kMcapMagic, kMcapMagicSize) == 0,
              path_ << ": offset 0: not an MCAP file (no MCAP magic)");
  Place at{&path_, kMcapMagicSize};
  const RecordHead head = record_head(in, kMcapMagicSize, file_size_, at);
  PLUMB_CHECK(head.op == kOpHeader, at << ": expected the header record (opcode 0x01), found 0x" << std::hex
                                       << int(head.op));
  {
    const std::vector<std::uint8_t> h = content(in, head, at);
    Fields f(h.data(), h.size(), "header", at);
    f.str("profile");
    f.str("library");
  }
  data_begin_ = head.next;
  // The footer and the closing magic.
  at.offset = file_size_ >= kMcapMagicSize ? file_size_ - kMcapMagicSize : 0;
  PLUMB_CHECK(file_size_ - data_begin_ >= kFooterSize + kMcapMagicSize,
              at << ": no footer: the file is truncated (an interrupted recording?)");
  read_at(in, file_size_ - kMcapMagicSize, reinterpret_cast<std::uint8_t*>(magic), kMcapMagicSize, at);
  PLUMB_CHECK(std::memcmp(magic, kMcapMagic, kMcapMagicSize) == 0,
              at << ": no closing MCAP magic: the file is truncated (an interrupted recording?) or corrupt");
  const std::uint64_t footer = file_size_ - kMcapMagicSize - kFooterSize;
  at.offset = footer;
  const RecordHead fh = record_head(in, footer, file_size_ - kMcapMagicSize, at);
  PLUMB_CHECK(fh.op == kOpFooter && fh.length == 20, at << ": expected the footer record (opcode 0x02, 20 bytes)");
  const std::vector<std::uint8_t> fc = content(in, fh, at);
  Fields ff(fc.data(), fc.size(), "footer", at);
  const auto summary_start = ff.num<std::uint64_t>("summary_start");
  const auto summary_offset_start = ff.num<std::uint64_t>("summary_offset_start");
  const auto summary_crc = ff.num<std::uint32_t>("summary_crc");
  data_end_ = footer;
  if (summary_start != 0) {
    const std::uint64_t summary_end = summary_offset_start != 0 ? summary_offset_start : footer;
    PLUMB_CHECK(summary_start >= data_begin_ && summary_start <= summary_end && summary_end <= footer,
                at << ": summary section " << summary_start << ".." << summary_end << " outside the file's records ("
                   << data_begin_ << ".." << footer << ')');
    if (summary_crc != 0) {  // over the summary up to the footer's summary_offset_start
      const std::uint32_t got = file_crc32(in, summary_start, footer + kRecordHead + 16, at);
      PLUMB_CHECK(got == summary_crc, at << ": summary CRC32 " << got << " differs from the footer's " << summary_crc
                                         << ": the summary section is corrupt");
    }
    data_end_ = summary_start;
    summary_ = true;
    read_summary(summary_start, summary_end);
  }
  if (!summary_ || chunks_.empty()) scan();
  std::stable_sort(chunks_.begin(), chunks_.end(),
                   [](const ChunkInfo& a, const ChunkInfo& b) { return a.start < b.start; });
}

void McapReader::add_schema(McapSchema s, std::uint64_t at) {
  for (const McapSchema& o : schemas_) {
    if (o.id == s.id) {
      PLUMB_CHECK(o.name == s.name && o.encoding == s.encoding,
                  path_ << ": offset " << at << ": schema " << s.id << " redefined (" << o.name << ", then " << s.name << ')');
      return;
    }
  }
  PLUMB_CHECK(s.id != 0, path_ << ": offset " << at << ": schema id 0 is reserved");
  schemas_.push_back(std::move(s));
}

void McapReader::add_channel(McapChannel c, std::uint64_t at) {
  for (const McapChannel& o : channels_) {
    if (o.id == c.id) {
      PLUMB_CHECK(o.topic == c.topic && o.schema_id == c.schema_id,
                  path_ << ": offset " << at << ": channel " << c.id << " redefined (" << o.topic << ", then " << c.topic << ')');
      return;
    }
  }
  channels_.push_back(std::move(c));
}

void McapReader::count(std::uint16_t channel, std::uint64_t log_time, std::uint64_t at) {
  PLUMB_CHECK(std::any_of(channels_.begin(), channels_.end(), [&](const McapChannel& c) { return c.id == channel; }),
              path_ << ": offset " << at << ": message on channel " << channel << ", which no channel record defines");
  ChannelStats& s = stats_[channel];
  if (s.count == 0 || log_time < s.first) s.first = log_time;
  if (s.count == 0 || log_time > s.last) s.last = log_time;
  ++s.count;
}

void McapReader::read_summary(std::uint64_t begin, std::uint64_t end) {
  for (std::uint64_t pos = begin; pos < end;) {
    Place at{&path_, pos};
    const RecordHead r = record_head(*in_, pos, end, at);
    pos = r.next;
    if (r.op != kOpSchema && r.op != kOpChannel && r.op != kOpStatistics && r.op != kOpChunkIndex) continue;
    const std::vector<std::uint8_t> c = content(*in_, r, at);
    if (r.op == kOpSchema) {
      add_schema(parse_schema(Fields(c.data(), c.size(), "schema", at)), at.offset);
    } else if (r.op == kOpChannel) {
      add_channel(parse_channel(Fields(c.data(), c.size(), "channel", at)), at.offset);
    } else if (r.op == kOpStatistics) {
      Fields f(c.data(), c.size(), "statistics", at);
      message_count_ = f.num<std::uint64_t>("message_count");
      f.take(2 + 4 + 4 + 4 + 4, "counts");
      start_ = f.num<std::uint64_t>("message_start_time");
      end_ = f.num<std::uint64_t>("message_end_time");
      have_statistics_ = true;
    } else {
      Fields f(c.data(), c.size(), "chunk index", at);
      ChunkInfo ci;
      ci.start = f.num<std::uint64_t>("message_start_time");
      ci.end = f.num<std::uint64_t>("message_end_time");
      ci.pos = f.num<std::uint64_t>("chunk_start_offset");
      ci.length = f.num<std::uint64_t>("chunk_length");
      Fields offsets = f.group("message_index_offsets");
      while (offsets.left() > 0) {
        const auto channel = offsets.num<std::uint16_t>("message_index_offsets");
        ci.index_offsets.emplace_back(channel, offsets.num<std::uint64_t>("message_index_offsets"));
      }
      f.num<std::uint64_t>("message_index_length");
      ci.compression = f.str("compression");
      ci.indexed = true;
      PLUMB_CHECK(ci.pos >= data_begin_ && ci.pos <= data_end_ && ci.length <= data_end_ - ci.pos,
                  at << ": chunk at " << ci.pos << " (" << ci.length << " bytes) outside the data section ("
                     << data_begin_ << ".." << data_end_ << ')');
      chunks_.push_back(std::move(ci));
    }
  }
}

void McapReader::scan() {
  chunks_.clear();
  stats_.clear();
  for (std::uint64_t pos = data_begin_; pos < data_end_;) {
    Place at{&path_, pos};
    const RecordHead r = record_head(*in_, pos, data_end_, at);
    if (r.op == kOpDataEnd) break;
    if (r.op == kOpSchema || r.op == kOpChannel || r.op == kOpMessage) {
      const std::vector<std::uint8_t> c = content(*in_, r, at);
      if (r.op == kOpSchema) add_schema(parse_schema(Fields(c.data(), c.size(), "schema", at)), pos);
      if (r.op == kOpChannel) add_channel(parse_channel(Fields(c.data(), c.size(), "channel", at)), pos);
      if (r.op == kOpMessage) {
        const McapMessage m = parse_message(c.data(), c.size(), at);
        count(static_cast<std::uint16_t>(m.offset), m.log_time, pos);
        loose_ = true;
      }
    } else if (r.op == kOpChunk) {
      ChunkInfo ci;
      ci.pos = pos;
      ci.length = r.next - pos;
      load_chunk(ci);
      chunks_.push_back(ci);
      ChunkInfo& back = chunks_.back();
      back.compression = chunk_compression_;
      back.start = chunk_start_;
      back.end = chunk_end_;
      for_each_record(
          [&](std::uint8_t op, const std::uint8_t* p, std::uint64_t n, std::uint64_t offset) {
            const Place in{&path_, offset, pos, true};
            if (op == kOpSchema) add_schema(parse_schema(Fields(p, n, "schema", in)), offset);
            if (op == kOpChannel) add_channel(parse_channel(Fields(p, n, "channel", in)), offset);
            if (op == kOpMessage) {
              const McapMessage m = parse_message(p, n, in);
              count(static_cast<std::uint16_t>(m.offset), m.log_time, offset);
            }
          },
          pos);
    }
    pos = r.next;
  }
  have_stats_ = true;
  message_count_ = 0;
  start_ = end_ = 0;
  for (const auto& kv : stats_) {
    if (message_count_ == 0 || kv.second.first < start_) start_ = kv.second.first;
    if (kv.second.last > end_) end_ = kv.second.last;
    message_count_ += kv.second.count;
  }
}

void McapReader::load_chunk(const ChunkInfo& c) const {
  Place at{&path_, c.pos};
  const RecordHead r = record_head(*in_, c.pos, data_end_, at);
  PLUMB_CHECK(r.op == kOpChunk, at << ": expected a chunk record (opcode 0x06), found 0x" << std::hex << int(r.op));
  compressed_.resize(static_cast<std::size_t>(r.length));
  if (!compressed_.empty()) read_at(*in_, r.content, compressed_.data(), compressed_.size(), at);
  Fields f(compressed_.data(), compressed_.size(), "chunk", at);
  chunk_start_ = f.num<std::uint64_t>("message_start_time");
  chunk_end_ = f.num<std::uint64_t>("message_end_time");
  const auto size = f.num<std::uint64_t>("uncompressed_size");
  const auto crc = f.num<std::uint32_t>("uncompressed_crc");
  chunk_compression_ = f.str("compression");
  const auto records = f.num<std::uint64_t>("records_length");
  PLUMB_CHECK(records == f.left(), at << ": chunk records of " << records << " bytes, the record holds " << f.left());
  const std::uint8_t* data = f.here();
  const std::string& compression = chunk_compression_;
  if (compression.empty()) {
    PLUMB_CHECK(records == size, at << ": uncompressed chunk of " << records << " bytes, its header says " << size);
    chunk_.assign(data, data + records);
  } else if (compression == "lz4") {
    detail::decompress_lz4_frame(data, static_cast<std::size_t>(records), size, chunk_, where(at));
  } else if (compression == "zstd") {
    detail::decompress_zstd(data, static_cast<std::size_t>(records), size, chunk_, where(at));
  } else {
    PLUMB_THROW(at << ": unsupported chunk compression '" << compression << "' (none, lz4 and zstd are read)");
  }
  if (crc != 0) {
    const std::uint32_t got =
        static_cast<std::uint32_t>(crc32_z(crc32_z(0L, Z_NULL, 0), chunk_.data(), chunk_.size()));
    PLUMB_CHECK(got == crc, at << ": chunk CRC32 " << got << " differs from its header's " << crc
                               << ": the chunk is corrupt");
  }
}

void McapReader::for_each_record(
    const std::function<void(std::uint8_t, const std::uint8_t*, std::uint64_t, std::uint64_t)>& f,
    std::uint64_t chunk_pos) const {
  const std::uint64_t n = chunk_.size();
  for (std::uint64_t pos = 0; pos < n;) {
    const Place at{&path_, pos, chunk_pos, true};
    PLUMB_CHECK(n - pos >= kRecordHead, at << ": record cut off at the end of the chunk");
    const std::uint8_t op = chunk_[pos];
    const auto len = cloud_detail::load<std::uint64_t>(reinterpret_cast<const char*>(chunk_.data() + pos + 1));
    PLUMB_CHECK(len <= n - pos - kRecordHead, at << ": record of " << len << " bytes overruns the chunk");
    f(op, chunk_.data() + pos + kRecordHead, len, pos);
    pos += kRecordHead + len;
  }
}

const McapSchema* McapReader::schema(const McapChannel& c) const {
  for (const McapSchema& s : schemas_) {
    if (s.id == c.schema_id) return &s;
  }
  return nullptr;
}

std::uint64_t McapReader::num_messages() const {
  if (have_stats_ || have_statistics_) return message_count_;
  std::uint64_t n = 0;
  for (const BagTopic& t : topics()) n += t.messages;
  return n;
}

RosTime McapReader::start_time() const {
  const Place at{&path_, 0};
  if (have_stats_ || have_statistics_) return ros_time(start_, at);
  std::uint64_t t = 0;
  for (std::size_t i = 0; i < chunks_.size(); ++i) {
    if (i == 0 || chunks_[i].start < t) t = chunks_[i].start;
  }
  return ros_time(t, at);
}

RosTime McapReader::end_time() const {
  const Place at{&path_, 0};
  if (have_stats_ || have_statistics_) return ros_time(end_, at);
  std::uint64_t t = 0;
  for (const ChunkInfo& c : chunks_) t = std::max(t, c.end);
  return ros_time(t, at);
}

std::vector<std::pair<std::string, std::size_t>> McapReader::compression() const {
  std::map<std::string, std::size_t> n;
  for (const ChunkInfo& c : chunks_) ++n[c.compression.empty() ? "none" : c.compression];
  return {n.begin(), n.end()};
}

std::vector<BagTopic> McapReader::topics() const {
  std::map<std::uint16_t, ChannelStats> stats = stats_;
  if (!have_stats_) {
    // From the message indexes after the chunks (the chunks without them are read).
    for (const ChunkInfo& ci : chunks_) {
      if (ci.index_offsets.empty()) {
        load_chunk(ci);
        for_each_record(
            [&](std::uint8_t op, const std::uint8_t* p, std::uint64_t n, std::uint64_t offset) {
              if (op != kOpMessage) return;
              const McapMessage m = parse_message(p, n, Place{&path_, offset, ci.pos, true});
              ChannelStats& s = stats[static_cast<std::uint16_t>(m.offset)];
              if (s.count == 0 || m.log_time < s.first) s.first = m.log_time;
              if (s.count == 0 || m.log_time > s.last) s.last = m.log_time;
              ++s.count;
            },
            ci.pos);
        continue;
      }
      for (const auto& [channel, pos] : ci.index_offsets) {
        Place at{&path_, pos};
        const RecordHead r = record_head(*in_, pos, data_end_, at);
        PLUMB_CHECK(r.op == kOpMessageIndex, at << ": expected a message index record (opcode 0x07) of the chunk at "
                                                << ci.pos << ", found 0x" << std::hex << int(r.op));
        const std::vector<std::uint8_t> c = content(*in_, r, at);
        Fields f(c.data(), c.size(), "message index", at);
        PLUMB_CHECK(f.num<std::uint16_t>("channel_id") == channel,
                    at << ": message index of another channel than the chunk index says (" << channel << ')');
        Fields entries = f.group("records");
        PLUMB_CHECK(entries.left() % 16 == 0, at << ": message index entries of " << entries.left() << " bytes");
        ChannelStats& s = stats[channel];
        while (entries.left() > 0) {
          const auto t = entries.num<std::uint64_t>("log_time");
          entries.num<std::uint64_t>("offset");
          if (s.count == 0 || t < s.first) s.first = t;
          if (s.count == 0 || t > s.last) s.last = t;
          ++s.count;
        }
      }
    }
  }
  std::map<std::string, BagTopic> topics;
  for (const McapChannel& c : channels_) {
    const McapSchema* sc = schema(c);
    const std::string type = sc != nullptr ? sc->name : "";
    BagTopic& t = topics[c.topic];
    PLUMB_CHECK(t.topic.empty() || t.type == type,
                path_ << ": topic " << c.topic << " has two types, " << t.type << " and " << type);
    t.topic = c.topic;
    t.type = type;
    const auto it = stats.find(c.id);
    if (it == stats.end() || it->second.count == 0) continue;
    const Place at{&path_, 0};
    const std::uint64_t first = t.messages == 0 ? it->second.first
                                                : std::min<std::uint64_t>(it->second.first, t.first.nanoseconds());
    const std::uint64_t last = t.messages == 0 ? it->second.last
                                               : std::max<std::uint64_t>(it->second.last, t.last.nanoseconds());
    t.first = ros_time(first, at);
    t.last = ros_time(last, at);
    t.messages += it->second.count;
  }
  std::vector<BagTopic> out;
  for (auto& kv : topics) {
    BagTopic& t = kv.second;
    const double span = static_cast<double>(t.last.nanoseconds() - t.first.nanoseconds()) * 1e-9;
    if (t.messages > 1 && span > 0) t.rate_hz = static_cast<double>(t.messages - 1) / span;
    out.push_back(std::move(t));
  }
  return out;
}

void McapReader::check_type(const std::string& topic, const std::string& ros1_type) const {
  const std::string expected = ros2_type_name(ros1_type);
  for (const McapChannel& c : channels_) {
    if (c.topic != topic) continue;
    const McapSchema* s = schema(c);
    PLUMB_CHECK(s != nullptr, path_ << ": topic " << topic << " (channel " << c.id << ") has no schema, expected "
                                    << expected);
    PLUMB_CHECK(s->name == expected, path_ << ": topic " << topic << " has type " << s->name << ", expected " << expected);
    PLUMB_CHECK(s->encoding == "ros2msg", path_ << ": topic " << topic << ": schema " << s->name << " has encoding '"
                                                << s->encoding << "', expected ros2msg (a ROS 2 message definition)");
    PLUMB_CHECK(c.message_encoding == "cdr", path_ << ": topic " << topic << ": message encoding '"
                                                   << c.message_encoding << "', expected cdr (ROS 2's serialization)");
  }
}

void McapReader::read(const std::vector<std::uint16_t>& ids, const std::function<bool(const McapMessage&)>& f,
                      const std::function<void(std::uint64_t, std::uint64_t)>& progress) const {
  if (ids.empty()) return;
  auto channel_of = [&](std::uint16_t id, const Place& at) -> const McapChannel* {
    for (const McapChannel& c : channels_) {
      if (c.id == id) return &c;
    }
    PLUMB_THROW(at << ": message on channel " << id << ", which no channel record defines");
  };
  auto wanted = [&](std::uint16_t id) { return std::find(ids.begin(), ids.end(), id) != ids.end(); };
  std::vector<McapMessage> messages;
  // The wanted messages of chunk_, in log-time order; false when `f` says stop.
  auto deliver_chunk = [&](std::uint64_t chunk_pos) {
    messages.clear();
    for_each_record(
        [&](std::uint8_t op, const std::uint8_t* p, std::uint64_t n, std::uint64_t offset) {
          if (op != kOpMessage) return;
          const Place at{&path_, offset, chunk_pos, true};
          McapMessage m = parse_message(p, n, at);
          const auto id = static_cast<std::uint16_t>(m.offset);
          if (!wanted(id)) return;
          m.channel = channel_of(id, at);
          m.chunk_offset = chunk_pos;
          m.offset = offset;
          messages.push_back(m);
        },
        chunk_pos);
    std::stable_sort(messages.begin(), messages.end(),
                     [](const McapMessage& a, const McapMessage& b) { return a.log_time < b.log_time; });
    for (const McapMessage& m : messages) {
      if (!f(m)) return false;
    }
    return true;
  };
  if (!loose_) {
    for (const ChunkInfo& ci : chunks_) {
      if (ci.indexed && !ci.index_offsets.empty() &&
          std::none_of(ci.index_offsets.begin(), ci.index_offsets.end(), [&](const auto& o) { return wanted(o.first); })) {
        continue;
      }
      load_chunk(ci);
      if (!deliver_chunk(ci.pos)) return;
      if (progress) progress(ci.pos + ci.length, file_size_);
    }
    return;
  }
  // Messages outside chunks: the data section in file order.
  std::vector<std::uint8_t> record;
  for (std::uint64_t pos = data_begin_, done = 0; pos < data_end_;) {
    const Place at{&path_, pos};
    const RecordHead r = record_head(*in_, pos, data_end_, at);
    if (r.op == kOpDataEnd) break;
    if (r.op == kOpChunk) {
      ChunkInfo ci;
      ci.pos = pos;
      load_chunk(ci);
      if (!deliver_chunk(pos)) return;
    } else if (r.op == kOpMessage) {
      PLUMB_CHECK(r.length >= kMessageHead, at << ": message record of " << r.length << " bytes");
      std::uint8_t head[kMessageHead];
      read_at(*in_, r.content, head, sizeof(head), at);
      const auto id = cloud_detail::load<std::uint16_t>(reinterpret_cast<const char*>(head));
      if (wanted(id)) {
        record = content(*in_, r, at);
        McapMessage m = parse_message(record.data(), record.size(), at);
        m.channel = channel_of(id, at);
        m.chunk_offset = pos;
        m.offset = 0;
        if (!f(m)) return;
      }
    }
    pos = r.next;
    if (progress && pos - done >= (1u << 20)) {
      progress(pos, file_size_);
      done = pos;
    }
  }
}

void McapReader::read_topics(const std::vector<std::string>& topics, const std::function<bool(const RecordedMessage&)>& f,
                             const std::function<void(std::uint64_t, std::uint64_t)>& progress) const {
  std::vector<std::uint16_t> ids;
  for (const McapChannel& c : channels_) {
    if (std::find(topics.begin(), topics.end(), c.topic) != topics.end()) ids.push_back(c.id);
  }
  read(
      ids,
      [&](const McapMessage& m) {
        RecordedMessage r;
        r.topic = &m.channel->topic;
        r.time = ros_time(m.log_time, Place{&path_, m.offset, m.chunk_offset, m.chunk_offset != 0});
        r.data = m.data;
        r.size = m.size;
        r.serialization = RosSerialization::kCdr;
        r.chunk_offset = m.chunk_offset;
        r.offset = m.offset;
        return f(r);
      },
      progress);
}

}  // namespace plumb::io
