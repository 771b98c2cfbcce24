// SPDX-License-Identifier: BSD-3-Clause
// ROS 1 bag format 2.0 (http://wiki.ros.org/Bags/Format/2.0). A bag is the line "#ROSBAG V2.0\n"
// followed by records: uint32 header length, the header (fields: uint32 length, "name=value"),
// uint32 data length, the data. The header's `op` field says what the record is: 0x03 bag header
// (index_pos, conn_count, chunk_count), 0x05 chunk (compression, size; data: connection and message
// records, compressed), 0x04 index data after each chunk (conn, count; data: count x (time, offset)),
// and at index_pos the connection records (0x07) and chunk info records (0x06: chunk_pos,
// start_time, end_time, count; data: count x (conn, messages)). Message records are 0x02 (conn,
// time; data: the serialized message). Integers are little-endian; a time is uint32 sec, uint32 nsec.
#include "plumb/io/rosbag.hpp"

#include <algorithm>
#include <cstring>
#include <fstream>
#include <map>
#include <memory>
#include <sstream>
#include <utility>

#include "plumb/core/error.hpp"
#include "plumb/io/input_file.hpp"
#include "plumb/io/ros_messages.hpp"
#include "detail_cloud_io.hpp"
#include "detail_decompress.hpp"

namespace plumb::io {
namespace {

constexpr char kMagic[] = "#ROSBAG V2.0\n";
constexpr std::size_t kMagicSize = sizeof(kMagic) - 1;
constexpr std::uint8_t kOpMessage = 0x02, kOpBagHeader = 0x03, kOpIndex = 0x04, kOpChunk = 0x05,
                       kOpChunkInfo = 0x06, kOpConnection = 0x07;

std::uint32_t le32(const std::uint8_t* p) { return cloud_detail::load<std::uint32_t>(reinterpret_cast<const char*>(p)); }
std::uint64_t le64(const std::uint8_t* p) { return cloud_detail::load<std::uint64_t>(reinterpret_cast<const char*>(p)); }
RosTime time_at(const std::uint8_t* p) { return {le32(p), le32(p + 4)}; }

// Where a record is, for messages: "BAG: offset N" or "BAG: offset N (chunk at M)".
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

// The fields of a record header, "name=value" each.
class Fields {
 public:
  Fields(const std::uint8_t* p, std::size_t n, const Place& at) : at_(at) {
    std::size_t i = 0;
    while (i < n) {
      PLUMB_CHECK(n - i >= 4, at << ": header field length cut off");
      const std::uint32_t len = le32(p + i);
      i += 4;
      PLUMB_CHECK(len <= n - i, at << ": header field of " << len << " bytes overruns the header (" << n - i
                                   << " bytes left)");
      const auto* begin = reinterpret_cast<const char*>(p + i);
      const auto* eq = static_cast<const char*>(std::memchr(begin, '=', len));
      PLUMB_CHECK(eq != nullptr, at << ": header field without '='");
      fields_.emplace_back(std::string(begin, eq), std::string(eq + 1, begin + len));
      i += len;
    }
  }
  const std::string& bytes(const char* name, std::size_t size = 0) const {
    for (const auto& f : fields_) {
      if (f.first == name) {
        PLUMB_CHECK(size == 0 || f.second.size() == size,
                    at_ << ": header field '" << name << "' has " << f.second.size() << " bytes, expected " << size);
        return f.second;
      }
    }
    PLUMB_THROW(at_ << ": record header has no field '" << name << "'");
  }
  bool has(const char* name) const {
    return std::any_of(fields_.begin(), fields_.end(), [&](const auto& f) { return f.first == name; });
  }
  const std::uint8_t* raw(const char* name, std::size_t size) const {
    return reinterpret_cast<const std::uint8_t*>(bytes(name, size).data());
  }
  std::uint8_t op() const { return raw("op", 1)[0]; }
  std::uint32_t u32(const char* name) const { return le32(raw(name, 4)); }
  std::uint64_t u64(const char* name) const { return le64(raw(name, 8)); }
  RosTime time(const char* name) const { return time_at(raw(name, 8)); }

 private:
  Place at_;
  std::vector<std::pair<std::string, std::string>> fields_;
};

// A record in a memory buffer (a chunk or a connection record's data): header fields and data.
struct BufferRecord {
  std::size_t header_begin = 0, header_size = 0, data_begin = 0, data_size = 0, next = 0;
};
BufferRecord buffer_record(const std::vector<std::uint8_t>& buf, std::size_t pos, const Place& at) {
  BufferRecord r;
  const std::size_t n = buf.size();
  PLUMB_CHECK(n - pos >= 4, at << ": record header length cut off");
  r.header_size = le32(buf.data() + pos);
  r.header_begin = pos + 4;
  PLUMB_CHECK(r.header_size <= n - r.header_begin && n - r.header_begin - r.header_size >= 4,
              at << ": record header of " << r.header_size << " bytes overruns the chunk");
  r.data_size = le32(buf.data() + r.header_begin + r.header_size);
  r.data_begin = r.header_begin + r.header_size + 4;
  PLUMB_CHECK(r.data_size <= n - r.data_begin, at << ": record data of " << r.data_size << " bytes overruns the chunk");
  r.next = r.data_begin + r.data_size;
  return r;
}

// Decompress a chunk's data into `out`, which must come to `size` bytes exactly.
void decompress(const std::string& compression, const std::vector<std::uint8_t>& in, std::uint32_t size,
                std::vector<std::uint8_t>& out, const Place& at) {
  std::ostringstream where;
  where << at;
  if (compression == "none") {
    PLUMB_CHECK(in.size() == size, at << ": uncompressed chunk of " << in.size() << " bytes, its header says " << size);
    out = in;
  } else if (compression == "bz2") {
    detail::decompress_bz2(in.data(), in.size(), size, out, where.str());
  } else if (compression == "lz4") {
    detail::decompress_lz4_frame(in.data(), in.size(), size, out, where.str());
  } else {
    PLUMB_THROW(at << ": unsupported chunk compression '" << compression << "' (none, bz2 and lz4 are read)");
  }
}

}  // namespace

namespace {
// A record read from the file: its header fields and where its data is.
struct FileRecord {
  std::vector<std::uint8_t> header;
  std::uint64_t data_pos = 0;
  std::uint32_t data_size = 0;
  std::uint64_t next = 0;
};

void read_at(std::istream& in, std::uint64_t pos, std::uint8_t* out, std::size_t n) {
  in.clear();
  in.seekg(static_cast<std::streamoff>(pos));
  in.read(reinterpret_cast<char*>(out), static_cast<std::streamsize>(n));
}

FileRecord file_record(std::istream& in, std::uint64_t pos, std::uint64_t file_size, const Place& at) {
  FileRecord r;
  std::uint8_t len[4];
  PLUMB_CHECK(file_size >= pos && file_size - pos >= 4, at << ": record cut off at the end of the file (file size "
                                                           << file_size << ')');
  read_at(in, pos, len, 4);
  const std::uint64_t header_size = le32(len);
  PLUMB_CHECK(file_size - pos - 4 >= header_size + 4,
              at << ": record header of " << header_size << " bytes overruns the file (size " << file_size << ')');
  r.header.resize(header_size);
  read_at(in, pos + 4, r.header.data(), r.header.size());
  read_at(in, pos + 4 + header_size, len, 4);
  r.data_size = le32(len);
  r.data_pos = pos + 8 + header_size;
  PLUMB_CHECK(file_size - r.data_pos >= r.data_size,
              at << ": record data of " << r.data_size << " bytes overruns the file (size " << file_size << ')');
  PLUMB_CHECK(in.good(), at << ": read error");
  r.next = r.data_pos + r.data_size;
  return r;
}

std::vector<std::uint8_t> file_data(std::istream& in, const FileRecord& r, const Place& at) {
  std::vector<std::uint8_t> data(r.data_size);
  read_at(in, r.data_pos, data.data(), data.size());
  PLUMB_CHECK(in.good(), at << ": read error");
  return data;
}
}  // namespace

BagReader::BagReader(const std::string& path)
    : path_(path), in_(std::make_unique<std::ifstream>(open_input_file(path))) {
  open();
}

BagReader::BagReader(std::unique_ptr<std::istream> in, const std::string& name) : path_(name), in_(std::move(in)) {
  open();
}

void BagReader::open() {
  const std::string& path = path_;
  std::istream& in = *in_;
  in.seekg(0, std::ios::end);
  file_size_ = static_cast<std::uint64_t>(in.tellg());
  char magic[kMagicSize] = {};
  in.seekg(0);
  in.read(magic, kMagicSize);
  PLUMB_CHECK(in.good() && std::memcmp(magic, kMagic, kMagicSize) == 0,
              path << ": offset 0: not a ROS bag of format 2.0 (no '#ROSBAG V2.0' line"
                   << (std::memcmp(magic, "#ROSBAG V", 9) == 0 ? "; other versions are not read)" : ")"));
  Place at{&path_, kMagicSize};
  const FileRecord head = file_record(*in_, kMagicSize, file_size_, at);
  const Fields hf(head.header.data(), head.header.size(), at);
  PLUMB_CHECK(hf.op() == kOpBagHeader, at << ": expected the bag header record (op 0x03), found op " << int(hf.op()));
  const std::uint64_t index_pos = hf.u64("index_pos");
  const std::uint32_t conn_count = hf.u32("conn_count");
  const std::uint32_t chunk_count = hf.u32("chunk_count");
  PLUMB_CHECK(index_pos != 0, at << ": the bag has no index (its recording was interrupted?); "
                                    "`rosbag reindex` writes one");
  PLUMB_CHECK(index_pos >= head.next && index_pos <= file_size_,
              at << ": index position " << index_pos << " outside the file (size " << file_size_
                 << "): the bag is truncated or corrupt");
  for (std::uint64_t pos = index_pos; pos < file_size_;) {
    at.offset = pos;
    const FileRecord r = file_record(*in_, pos, file_size_, at);
    const Fields f(r.header.data(), r.header.size(), at);
    const std::vector<std::uint8_t> data = file_data(*in_, r, at);
    if (f.op() == kOpConnection) {
      BagConnection c;
      c.id = f.u32("conn");
      c.topic = f.bytes("topic");
      const Fields d(data.data(), data.size(), at);
      c.type = d.bytes("type");
      c.md5sum = d.bytes("md5sum");
      if (d.has("message_definition")) c.message_definition = d.bytes("message_definition");
      connections_.push_back(std::move(c));
    } else if (f.op() == kOpChunkInfo) {
      PLUMB_CHECK(f.u32("ver") == 1, at << ": chunk info version " << f.u32("ver") << " (1 is read)");
      ChunkInfo ci;
      ci.pos = f.u64("chunk_pos");
      ci.start = f.time("start_time");
      ci.end = f.time("end_time");
      const std::uint32_t count = f.u32("count");
      PLUMB_CHECK(data.size() == std::uint64_t{count} * 8,
                  at << ": chunk info of " << count << " connections has " << data.size() << " data bytes");
      for (std::uint32_t i = 0; i < count; ++i) ci.counts.emplace_back(le32(&data[8 * i]), le32(&data[8 * i + 4]));
      PLUMB_CHECK(ci.pos >= head.next && ci.pos < index_pos, at << ": chunk position " << ci.pos << " outside the data");
      chunks_.push_back(std::move(ci));
    } else {
      PLUMB_THROW(at << ": unexpected record op " << int(f.op()) << " in the index section");
    }
    pos = r.next;
  }
  at.offset = index_pos;
  PLUMB_CHECK(connections_.size() == conn_count && chunks_.size() == chunk_count,
              at << ": index holds " << connections_.size() << " connections and " << chunks_.size()
                 << " chunk infos, the bag header says " << conn_count << " and " << chunk_count);
  for (const ChunkInfo& ci : chunks_) {
    for (const auto& c : ci.counts) {
      PLUMB_CHECK(std::any_of(connections_.begin(), connections_.end(), [&](const BagConnection& b) { return b.id == c.first; }),
                  at << ": chunk info names connection " << c.first << ", which the bag does not have");
    }
  }
  std::sort(chunks_.begin(), chunks_.end(), [](const ChunkInfo& a, const ChunkInfo& b) { return a.pos < b.pos; });
}

std::uint64_t BagReader::num_messages() const {
  std::uint64_t n = 0;
  for (const ChunkInfo& ci : chunks_) {
    for (const auto& c : ci.counts) n += c.second;
  }
  return n;
}

RosTime BagReader::start_time() const {
  RosTime t;
  for (std::size_t i = 0; i < chunks_.size(); ++i) {
    if (i == 0 || chunks_[i].start.nanoseconds() < t.nanoseconds()) t = chunks_[i].start;
  }
  return t;
}

RosTime BagReader::end_time() const {
  RosTime t;
  for (const ChunkInfo& ci : chunks_) {
    if (ci.end.nanoseconds() > t.nanoseconds()) t = ci.end;
  }
  return t;
}

std::vector<std::pair<std::string, std::size_t>> BagReader::compression() const {
  std::map<std::string, std::size_t> n;
  for (const ChunkInfo& ci : chunks_) {
    const Place at{&path_, ci.pos};
    const FileRecord r = file_record(*in_, ci.pos, file_size_, at);
    ++n[Fields(r.header.data(), r.header.size(), at).bytes("compression")];
  }
  return {n.begin(), n.end()};
}

std::vector<BagTopic> BagReader::topics() const {
  std::map<std::string, BagTopic> topics;
  std::map<std::uint32_t, std::vector<std::int64_t>> times;  // per connection, from the index records
  for (const ChunkInfo& ci : chunks_) {
    Place at{&path_, ci.pos};
    std::uint64_t pos = file_record(*in_, ci.pos, file_size_, at).next;
    for (std::size_t seen = 0; seen < ci.counts.size(); ++seen) {
      at.offset = pos;
      const FileRecord r = file_record(*in_, pos, file_size_, at);
      const Fields f(r.header.data(), r.header.size(), at);
      PLUMB_CHECK(f.op() == kOpIndex, at << ": expected an index data record (op 0x04) after the chunk at " << ci.pos);
      const std::uint32_t count = f.u32("count");
      PLUMB_CHECK(r.data_size == std::uint64_t{count} * 12,
                  at << ": index data of " << count << " messages has " << r.data_size << " bytes");
      const std::vector<std::uint8_t> data = file_data(*in_, r, at);
      std::vector<std::int64_t>& t = times[f.u32("conn")];
      for (std::uint32_t i = 0; i < count; ++i) t.push_back(time_at(&data[12 * i]).nanoseconds());
      pos = r.next;
    }
  }
  for (const BagConnection& c : connections_) {
    BagTopic& t = topics[c.topic];
    PLUMB_CHECK(t.type.empty() || t.type == c.type, path_ << ": topic " << c.topic << " has two types, " << t.type
                                                          << " and " << c.type);
    t.topic = c.topic;
    t.type = c.type;
    t.md5sum = c.md5sum;
    for (std::int64_t ns : times[c.id]) {
      const RosTime rt{static_cast<std::uint32_t>(ns / 1000000000), static_cast<std::uint32_t>(ns % 1000000000)};
      if (t.messages == 0 || ns < t.first.nanoseconds()) t.first = rt;
      if (t.messages == 0 || ns > t.last.nanoseconds()) t.last = rt;
      ++t.messages;
    }
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

void BagReader::read(const std::vector<std::uint32_t>& ids, const std::function<bool(const BagMessage&)>& f,
                     const std::function<void(std::uint64_t, std::uint64_t)>& progress) const {
  auto wanted = [&ids](std::uint32_t id) { return std::find(ids.begin(), ids.end(), id) != ids.end(); };
  std::map<std::uint32_t, const BagConnection*> by_id;
  for (const BagConnection& c : connections_) by_id[c.id] = &c;
  for (const ChunkInfo& ci : chunks_) {
    if (std::none_of(ci.counts.begin(), ci.counts.end(), [&](const auto& c) { return c.second > 0 && wanted(c.first); })) {
      continue;
    }
    Place at{&path_, ci.pos};
    const FileRecord r = file_record(*in_, ci.pos, file_size_, at);
    const Fields cf(r.header.data(), r.header.size(), at);
    PLUMB_CHECK(cf.op() == kOpChunk, at << ": expected a chunk record (op 0x05), found op " << int(cf.op()));
    compressed_.resize(r.data_size);
    read_at(*in_, r.data_pos, compressed_.data(), compressed_.size());
    PLUMB_CHECK(in_->good(), at << ": read error");
    decompress(cf.bytes("compression"), compressed_, cf.u32("size"), chunk_, at);
    at.in_chunk = true;
    at.chunk = ci.pos;
    for (std::size_t pos = 0; pos < chunk_.size();) {
      at.offset = pos;
      const BufferRecord br = buffer_record(chunk_, pos, at);
      const Fields mf(chunk_.data() + br.header_begin, br.header_size, at);
      const std::uint8_t op = mf.op();
      PLUMB_CHECK(op == kOpMessage || op == kOpConnection, at << ": unexpected record op " << int(op) << " in a chunk");
      if (op == kOpMessage && wanted(mf.u32("conn"))) {
        const auto c = by_id.find(mf.u32("conn"));
        BagMessage m;
        m.connection = c->second;
        m.time = mf.time("time");
        m.data = chunk_.data() + br.data_begin;
        m.size = br.data_size;
        m.chunk_offset = ci.pos;
        m.offset = pos;
        if (!f(m)) return;
      }
      pos = br.next;
    }
    if (progress) progress(r.next, file_size_);
  }
}

void BagReader::check_type(const std::string& topic, const std::string& ros1_type) const {
  for (const BagConnection& c : connections_) {
    if (c.topic != topic) continue;
    PLUMB_CHECK(c.type == ros1_type, path_ << ": topic " << topic << " has type " << c.type << ", expected " << ros1_type);
    const char* md5 = ros_known_md5sum(c.type);
    PLUMB_CHECK(md5 != nullptr && c.md5sum == md5,
                path_ << ": topic " << topic << ": md5sum " << c.md5sum << " of " << c.type << " (connection " << c.id
                      << ", from its first message) differs from the known " << (md5 ? md5 : "?")
                      << ": another version of the message, which plumb does not decode");
  }
}

void BagReader::read_topics(const std::vector<std::string>& topics, const std::function<bool(const RecordedMessage&)>& f,
                            const std::function<void(std::uint64_t, std::uint64_t)>& progress) const {
  std::vector<std::uint32_t> ids;
  for (const BagConnection& c : connections_) {
    if (std::find(topics.begin(), topics.end(), c.topic) != topics.end()) ids.push_back(c.id);
  }
  if (ids.empty()) return;
  read(
      ids,
      [&](const BagMessage& m) {
        RecordedMessage r;
        r.topic = &m.connection->topic;
        r.time = m.time;
        r.data = m.data;
        r.size = m.size;
        r.serialization = RosSerialization::kRos1;
        r.chunk_offset = m.chunk_offset;
        r.offset = m.offset;
        return f(r);
      },
      progress);
}

}  // namespace plumb::io
