// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/io/pcd.hpp"

#include <lzf.h>

#include <array>
#include <charconv>
#include <cstdint>
#include <cstring>
#include <limits>
#include <string>
#include <string_view>
#include <vector>

#include "detail_cloud_io.hpp"
#include "text_tokens.hpp"

namespace plumb::io {
namespace {

using cloud_detail::convert_value;
using cloud_detail::LineCursor;
using cloud_detail::load;
using cloud_detail::parse_number;
using detail::split_tokens;

// Upper bound on COUNT per field; keeps record sizes far from overflow. Real files use <= 308 (FPFH
// histograms are 33, VFH 308).
constexpr std::uint64_t kMaxCount = std::uint64_t{1} << 24;
// LZF cannot expand a stream by more than ~88x (3 input bytes yield at most 264 output bytes).
constexpr std::uint64_t kMaxLzfRatio = 100;

static_assert(sizeof(Vector3f) == 3 * sizeof(float), "points are decoded as strided float arrays");

enum class Role { kNone, kX, kY, kZ, kNormalX, kNormalY, kNormalZ, kIntensity, kRing, kTime, kLabel };
constexpr int kNumRoles = 11;

enum class DataKind { kAscii, kBinary, kBinaryCompressed };

struct Field {
  std::string name;
  int size = 0;             // bytes per value
  char type = 0;            // 'F', 'U' or 'I'
  std::uint64_t count = 1;  // values per point
  Role role = Role::kNone;
  std::uint64_t offset = 0;  // byte offset of the field inside one interleaved record
};

struct Header {
  std::vector<Field> fields;
  std::uint64_t num_points = 0;
  std::uint64_t point_size = 0;  // bytes of one record
  DataKind kind = DataKind::kAscii;
  std::size_t data_offset = 0;  // byte offset of the first data byte
  std::size_t data_line = 0;    // number of the DATA line
  std::array<int, kNumRoles> field_of_role{};  // index into fields, or -1
};

Role role_of(std::string_view name) {
  if (name == "x") return Role::kX;
  if (name == "y") return Role::kY;
  if (name == "z") return Role::kZ;
  if (name == "normal_x") return Role::kNormalX;
  if (name == "normal_y") return Role::kNormalY;
  if (name == "normal_z") return Role::kNormalZ;
  if (name == "intensity") return Role::kIntensity;
  if (name == "ring") return Role::kRing;
  if (name == "time") return Role::kTime;
  if (name == "label") return Role::kLabel;
  return Role::kNone;
}

bool valid_type_size(char type, int size) {
  if (type == 'F') return size == 4 || size == 8;
  if (type == 'U' || type == 'I') return size == 1 || size == 2 || size == 4 || size == 8;
  return false;
}

std::uint64_t parse_header_uint(std::string_view tok, const std::string& name, std::size_t line,
                                std::string_view key) {
  std::uint64_t v = 0;
  if (!parse_number(tok, v)) {
    PLUMB_THROW(name << ":" << line << ": " << key << " expects a non-negative integer, got '" << tok << "'");
  }
  return v;
}

// The header's keyword lines as read, each list with the line it came from (0 = absent).
struct HeaderLines {
  std::vector<std::string_view> names, sizes, types, counts;
  std::size_t fields_line = 0, size_line = 0, type_line = 0, count_line = 0;
  bool have_width = false, have_points = false;
  std::uint64_t width = 0, height = 1, points = 0;
  std::size_t width_line = 0, points_line = 0;
};

// Reads the header's lines up to DATA, which sets h's data kind, offset and line.
HeaderLines read_header_lines(const char* data, std::size_t size, const std::string& name, Header& h) {
  HeaderLines hl;
  LineCursor cur{data, data, data + size, 0};
  bool have_data = false;
  std::string_view line;
  while (cur.next(line)) {
    const auto tokens = split_tokens(line);
    if (tokens.empty() || tokens[0].front() == '#') continue;
    const std::string_view key = tokens[0];
    auto expect_one = [&]() {
      if (tokens.size() != 2) {
        PLUMB_THROW(name << ":" << cur.line << ": " << key << " expects one value, got " << tokens.size() - 1);
      }
    };
    if (key == "VERSION") {
      // .5, 0.6, 0.7: the layout read here is the same.
    } else if (key == "FIELDS" || key == "COLUMNS") {
      hl.names.assign(tokens.begin() + 1, tokens.end());
      hl.fields_line = cur.line;
    } else if (key == "SIZE") {
      hl.sizes.assign(tokens.begin() + 1, tokens.end());
      hl.size_line = cur.line;
    } else if (key == "TYPE") {
      hl.types.assign(tokens.begin() + 1, tokens.end());
      hl.type_line = cur.line;
    } else if (key == "COUNT") {
      hl.counts.assign(tokens.begin() + 1, tokens.end());
      hl.count_line = cur.line;
    } else if (key == "WIDTH") {
      expect_one();
      hl.width = parse_header_uint(tokens[1], name, cur.line, key);
      hl.have_width = true;
      hl.width_line = cur.line;
    } else if (key == "HEIGHT") {
      expect_one();
      hl.height = parse_header_uint(tokens[1], name, cur.line, key);
    } else if (key == "POINTS") {
      expect_one();
      hl.points = parse_header_uint(tokens[1], name, cur.line, key);
      hl.have_points = true;
      hl.points_line = cur.line;
    } else if (key == "VIEWPOINT") {
      // Sensor pose; not kept (the cloud is in its own frame).
    } else if (key == "DATA") {
      expect_one();
      static constexpr std::pair<std::string_view, DataKind> kDataKinds[] = {
          {"ascii", DataKind::kAscii},
          {"binary", DataKind::kBinary},
          {"binary_compressed", DataKind::kBinaryCompressed}};
      if (!cloud_detail::keyword_value(tokens[1], kDataKinds, h.kind)) {
        PLUMB_THROW(name << ":" << cur.line << ": unknown DATA kind '" << tokens[1]
                         << "' (expected ascii, binary or binary_compressed)");
      }
      h.data_offset = cur.offset();
      h.data_line = cur.line;
      have_data = true;
      break;
    } else {
      PLUMB_THROW(name << ":" << cur.line << ": unknown PCD header keyword '" << key << "'");
    }
  }
  if (!have_data) {
    PLUMB_THROW(name << ":" << cur.line << ": not a PCD file or truncated header (no DATA line)");
  }
  return hl;
}

// FIELDS, SIZE, TYPE and COUNT into h.fields (with offsets and roles) and h.point_size.
void parse_fields(const HeaderLines& hl, const std::string& name, Header& h) {
  const std::size_t dl = h.data_line;
  if (hl.names.empty()) PLUMB_THROW(name << ":" << dl << ": header has no FIELDS");
  if (hl.sizes.size() != hl.names.size()) {
    PLUMB_THROW(name << ":" << (hl.size_line ? hl.size_line : dl) << ": SIZE has " << hl.sizes.size()
                     << " entries for " << hl.names.size() << " FIELDS");
  }
  if (hl.types.size() != hl.names.size()) {
    PLUMB_THROW(name << ":" << (hl.type_line ? hl.type_line : dl) << ": TYPE has " << hl.types.size()
                     << " entries for " << hl.names.size() << " FIELDS");
  }
  if (!hl.counts.empty() && hl.counts.size() != hl.names.size()) {
    PLUMB_THROW(name << ":" << hl.count_line << ": COUNT has " << hl.counts.size() << " entries for "
                     << hl.names.size() << " FIELDS");
  }

  h.field_of_role.fill(-1);
  std::uint64_t offset = 0;
  for (std::size_t i = 0; i < hl.names.size(); ++i) {
    Field f;
    f.name = std::string(hl.names[i]);
    const std::uint64_t s = parse_header_uint(hl.sizes[i], name, hl.size_line, "SIZE");
    if (hl.types[i].size() != 1 || !valid_type_size(hl.types[i][0], static_cast<int>(s > 8 ? 0 : s))) {
      PLUMB_THROW(name << ":" << hl.type_line << ": field '" << f.name << "' has unsupported TYPE " << hl.types[i]
                       << " with SIZE " << hl.sizes[i]);
    }
    f.size = static_cast<int>(s);
    f.type = hl.types[i][0];
    if (!hl.counts.empty()) {
      f.count = parse_header_uint(hl.counts[i], name, hl.count_line, "COUNT");
      if (f.count == 0 || f.count > kMaxCount) {
        PLUMB_THROW(name << ":" << hl.count_line << ": field '" << f.name << "' has COUNT " << f.count
                         << " (expected 1.." << kMaxCount << ")");
      }
    }
    f.offset = offset;
    offset += static_cast<std::uint64_t>(f.size) * f.count;
    f.role = role_of(f.name);
    if (f.role != Role::kNone) {
      int& slot = h.field_of_role[static_cast<int>(f.role)];
      if (slot >= 0) PLUMB_THROW(name << ":" << hl.fields_line << ": field '" << f.name << "' appears twice");
      if (f.count != 1) {
        PLUMB_THROW(name << ":" << hl.count_line << ": field '" << f.name << "' must have COUNT 1, has " << f.count);
      }
      slot = static_cast<int>(i);
    }
    h.fields.push_back(std::move(f));
  }
  h.point_size = offset;
  for (Role r : {Role::kX, Role::kY, Role::kZ}) {
    if (h.field_of_role[static_cast<int>(r)] < 0) {
      PLUMB_THROW(name << ":" << hl.fields_line << ": FIELDS lacks x, y or z");
    }
  }
  // Normals only as a complete triple; a lone normal_x is treated as an unknown field.
  const int nx = h.field_of_role[static_cast<int>(Role::kNormalX)];
  const int ny = h.field_of_role[static_cast<int>(Role::kNormalY)];
  const int nz = h.field_of_role[static_cast<int>(Role::kNormalZ)];
  if (nx < 0 || ny < 0 || nz < 0) {
    for (int idx : {nx, ny, nz}) {
      if (idx >= 0) h.fields[static_cast<std::size_t>(idx)].role = Role::kNone;
    }
    h.field_of_role[static_cast<int>(Role::kNormalX)] = -1;
    h.field_of_role[static_cast<int>(Role::kNormalY)] = -1;
    h.field_of_role[static_cast<int>(Role::kNormalZ)] = -1;
  }
}

// WIDTH x HEIGHT, or POINTS without WIDTH (HEIGHT is then 1); both must agree when given.
std::uint64_t point_count(const HeaderLines& hl, const std::string& name, std::size_t data_line) {
  if (!hl.have_width && !hl.have_points) {
    PLUMB_THROW(name << ":" << data_line << ": header has neither WIDTH nor POINTS");
  }
  std::uint64_t width = hl.width, height = hl.height;
  if (!hl.have_width) {
    width = hl.points;
    height = 1;
  }
  if (height != 0 && width > std::numeric_limits<std::uint64_t>::max() / height) {
    PLUMB_THROW(name << ":" << hl.width_line << ": WIDTH " << width << " x HEIGHT " << height << " overflows");
  }
  const std::uint64_t wh = width * height;
  if (hl.have_points && hl.points != wh) {
    PLUMB_THROW(name << ":" << hl.points_line << ": POINTS " << hl.points << " does not match WIDTH x HEIGHT = "
                     << width << " x " << height << " = " << wh);
  }
  return wh;
}

Header parse_header(const char* data, std::size_t size, const std::string& name) {
  Header h;
  const HeaderLines hl = read_header_lines(data, size, name, h);
  parse_fields(hl, name, h);
  h.num_points = point_count(hl, name, h.data_line);
  return h;
}

// Where decoded values of one role go: a strided array of Dst.
template <class Dst>
struct Sink {
  Dst* out = nullptr;
  std::size_t stride = 1;
};

[[noreturn]] void throw_bad_value(const std::string& name, const Field& f, std::size_t byte, const char* where) {
  PLUMB_THROW(name << ": byte " << byte << where << ": value of field '" << f.name
                   << "' is not an integer in the range of its destination");
}

// Decode one field for n points: value i sits at base + i * stride. `base_offset` is the byte
// offset of `base` for messages.
template <class Src, class Dst>
void decode_column_typed(const char* base, std::size_t stride, std::size_t n, Sink<Dst> sink,
                         const std::string& name, const Field& f, std::size_t base_offset, const char* where) {
  for (std::size_t i = 0; i < n; ++i) {
    if (!convert_value(load<Src>(base + i * stride), sink.out[i * sink.stride])) {
      throw_bad_value(name, f, base_offset + i * stride, where);
    }
  }
}

template <class Dst>
void decode_column(const char* base, std::size_t stride, std::size_t n, Sink<Dst> sink, const std::string& name,
                   const Field& f, std::size_t base_offset, const char* where) {
  const auto go = [&](auto tag) {
    decode_column_typed<decltype(tag), Dst>(base, stride, n, sink, name, f, base_offset, where);
  };
  switch (f.type) {
    case 'F':
      if (f.size == 4) return go(float{});
      return go(double{});
    case 'U':
      if (f.size == 1) return go(std::uint8_t{});
      if (f.size == 2) return go(std::uint16_t{});
      if (f.size == 4) return go(std::uint32_t{});
      return go(std::uint64_t{});
    default:
      if (f.size == 1) return go(std::int8_t{});
      if (f.size == 2) return go(std::int16_t{});
      if (f.size == 4) return go(std::int32_t{});
      return go(std::int64_t{});
  }
}

// Size the cloud's arrays for n points and decode every mapped field from a binary layout where
// field f's value for point i sits at data + field_base(f) + i * field_stride(f).
template <class BaseFn, class StrideFn>
void decode_binary(const Header& h, const char* data, std::size_t n, BaseFn field_base, StrideFn field_stride,
                   std::size_t message_offset, const char* where, const std::string& name, PointCloud& cloud) {
  cloud.points.resize(n);
  const auto role_field = [&](Role r) { return h.field_of_role[static_cast<int>(r)]; };
  const bool has_normals = role_field(Role::kNormalX) >= 0;
  if (has_normals) cloud.normals.resize(n);
  if (role_field(Role::kIntensity) >= 0) cloud.intensities.resize(n);
  if (role_field(Role::kRing) >= 0) cloud.rings.resize(n);
  if (role_field(Role::kTime) >= 0) cloud.times.resize(n);
  if (role_field(Role::kLabel) >= 0) cloud.labels.resize(n);
  if (n == 0) return;
  for (const Field& f : h.fields) {
    if (f.role == Role::kNone) continue;
    const std::size_t base = field_base(f);
    const char* p = data + base;
    const std::size_t stride = field_stride(f);
    const std::size_t off = message_offset + base;
    switch (f.role) {
      case Role::kX:
      case Role::kY:
      case Role::kZ:
        decode_column(p, stride, n,
                      Sink<float>{cloud.points[0].data() + (static_cast<int>(f.role) - static_cast<int>(Role::kX)), 3},
                      name, f, off, where);
        break;
      case Role::kNormalX:
      case Role::kNormalY:
      case Role::kNormalZ:
        decode_column(
            p, stride, n,
            Sink<float>{cloud.normals[0].data() + (static_cast<int>(f.role) - static_cast<int>(Role::kNormalX)), 3},
            name, f, off, where);
        break;
      case Role::kIntensity:
        decode_column(p, stride, n, Sink<float>{cloud.intensities.data(), 1}, name, f, off, where);
        break;
      case Role::kRing:
        decode_column(p, stride, n, Sink<std::uint16_t>{cloud.rings.data(), 1}, name, f, off, where);
        break;
      case Role::kTime:
        decode_column(p, stride, n, Sink<float>{cloud.times.data(), 1}, name, f, off, where);
        break;
      case Role::kLabel:
        decode_column(p, stride, n, Sink<std::int32_t>{cloud.labels.data(), 1}, name, f, off, where);
        break;
      case Role::kNone:
        break;
    }
  }
}

void read_binary(const Header& h, const char* data, std::size_t size, const std::string& name, PointCloud& cloud) {
  const std::size_t available = size - h.data_offset;
  if (h.num_points > available / h.point_size) {
    PLUMB_THROW(name << ": byte " << h.data_offset << ": DATA binary truncated: " << h.num_points
                     << " points of " << h.point_size << " bytes need more than the " << available
                     << " bytes that follow the header");
  }
  const std::size_t n = static_cast<std::size_t>(h.num_points);
  const std::size_t ps = static_cast<std::size_t>(h.point_size);
  decode_binary(
      h, data + h.data_offset, n, [](const Field& f) { return static_cast<std::size_t>(f.offset); },
      [ps](const Field&) { return ps; }, h.data_offset, "", name, cloud);
}

void read_compressed(const Header& h, const char* data, std::size_t size, const std::string& name,
                     PointCloud& cloud) {
  const std::size_t available = size - h.data_offset;
  if (available < 8) {
    PLUMB_THROW(name << ": byte " << h.data_offset << ": DATA binary_compressed truncated: missing the 8-byte "
                     << "size prefix");
  }
  const char* p = data + h.data_offset;
  const std::uint32_t compressed_size = load<std::uint32_t>(p);
  const std::uint32_t uncompressed_size = load<std::uint32_t>(p + 4);
  if (compressed_size > available - 8) {
    PLUMB_THROW(name << ": byte " << h.data_offset + 8 << ": DATA binary_compressed truncated: "
                     << compressed_size << " compressed bytes declared, " << available - 8 << " present");
  }
  if (h.num_points > std::numeric_limits<std::uint32_t>::max() / h.point_size ||
      h.num_points * h.point_size != uncompressed_size) {
    PLUMB_THROW(name << ": byte " << h.data_offset + 4 << ": uncompressed size " << uncompressed_size
                     << " does not match " << h.num_points << " points of " << h.point_size << " bytes");
  }
  if (uncompressed_size > std::uint64_t{compressed_size} * kMaxLzfRatio + 64) {
    PLUMB_THROW(name << ": byte " << h.data_offset << ": corrupt binary_compressed data: " << uncompressed_size
                     << " bytes cannot come from " << compressed_size << " compressed bytes");
  }
  std::vector<char> buffer(uncompressed_size);
  if (uncompressed_size > 0) {
    const unsigned int got = lzf_decompress(p + 8, compressed_size, buffer.data(), uncompressed_size);
    if (got != uncompressed_size) {
      PLUMB_THROW(name << ": byte " << h.data_offset + 8 << ": corrupt LZF stream (decompressed " << got
                       << " of " << uncompressed_size << " bytes)");
    }
  }
  const std::size_t n = static_cast<std::size_t>(h.num_points);
  // Structure of arrays: field f's n values start at n * (its record offset).
  decode_binary(
      h, buffer.data(), n, [n](const Field& f) { return n * static_cast<std::size_t>(f.offset); },
      [](const Field& f) { return static_cast<std::size_t>(f.size) * static_cast<std::size_t>(f.count); }, 0,
      " of the decompressed data", name, cloud);
}

// Parse one ascii token of a field into Dst.
template <class Dst>
bool parse_ascii_value(std::string_view tok, const Field& f, Dst& out) {
  if (f.type == 'F') {
    if (f.size == 4) {
      float v;
      return parse_number(tok, v) && convert_value(v, out);
    }
    double v;
    return parse_number(tok, v) && convert_value(v, out);
  }
  if (f.type == 'U') {
    std::uint64_t v;
    if (parse_number(tok, v)) return convert_value(v, out);
  } else {
    std::int64_t v;
    if (parse_number(tok, v)) return convert_value(v, out);
  }
  double v;  // lenient: "3.0" in an integer column
  return parse_number(tok, v) && convert_value(v, out);
}

void read_ascii(const Header& h, const char* data, std::size_t size, const std::string& name, PointCloud& cloud) {
  LineCursor cur{data, data + h.data_offset, data + size, h.data_line};
  std::uint64_t values_per_point = 0;
  for (const Field& f : h.fields) values_per_point += f.count;
  // A point needs at least two bytes per value ("0 "): cap the reservation by what the data can hold.
  const std::uint64_t can_hold = (size - h.data_offset) / (2 * values_per_point) + 1;
  const std::size_t n_reserve = static_cast<std::size_t>(std::min<std::uint64_t>(h.num_points, can_hold));
  const auto role_field = [&](Role r) { return h.field_of_role[static_cast<int>(r)]; };
  const bool has_normals = role_field(Role::kNormalX) >= 0;
  const bool has_intensity = role_field(Role::kIntensity) >= 0;
  const bool has_ring = role_field(Role::kRing) >= 0;
  const bool has_time = role_field(Role::kTime) >= 0;
  const bool has_label = role_field(Role::kLabel) >= 0;
  cloud.points.reserve(n_reserve);
  if (has_normals) cloud.normals.reserve(n_reserve);
  if (has_intensity) cloud.intensities.reserve(n_reserve);
  if (has_ring) cloud.rings.reserve(n_reserve);
  if (has_time) cloud.times.reserve(n_reserve);
  if (has_label) cloud.labels.reserve(n_reserve);

  std::string_view line;
  for (std::uint64_t i = 0; i < h.num_points; ++i) {
    bool got_line = false;
    while (cur.next(line)) {
      std::size_t k = 0;
      if (!detail::next_token(line, k).empty()) {
        got_line = true;
        break;
      }
    }
    if (!got_line) {
      PLUMB_THROW(name << ":" << cur.line + 1 << ": DATA ascii truncated: " << i << " of " << h.num_points
                       << " points present");
    }
    Vector3f p = Vector3f::Zero(), nrm = Vector3f::Zero();
    float intensity = 0.0f, time = 0.0f;
    std::uint16_t ring = 0;
    std::int32_t label = 0;
    std::size_t pos = 0;
    for (const Field& f : h.fields) {
      for (std::uint64_t c = 0; c < f.count; ++c) {
        const std::string_view tok = detail::next_token(line, pos);
        if (tok.empty()) {
          PLUMB_THROW(name << ":" << cur.line << ": expected " << values_per_point << " values, line ends in field '"
                           << f.name << "'");
        }
        if (f.role == Role::kNone) continue;
        bool ok = false;
        switch (f.role) {
          case Role::kX: ok = parse_ascii_value(tok, f, p.x()); break;
          case Role::kY: ok = parse_ascii_value(tok, f, p.y()); break;
          case Role::kZ: ok = parse_ascii_value(tok, f, p.z()); break;
          case Role::kNormalX: ok = parse_ascii_value(tok, f, nrm.x()); break;
          case Role::kNormalY: ok = parse_ascii_value(tok, f, nrm.y()); break;
          case Role::kNormalZ: ok = parse_ascii_value(tok, f, nrm.z()); break;
          case Role::kIntensity: ok = parse_ascii_value(tok, f, intensity); break;
          case Role::kRing: ok = parse_ascii_value(tok, f, ring); break;
          case Role::kTime: ok = parse_ascii_value(tok, f, time); break;
          case Role::kLabel: ok = parse_ascii_value(tok, f, label); break;
          case Role::kNone: break;
        }
        if (!ok) {
          PLUMB_THROW(name << ":" << cur.line << ": cannot read '" << tok << "' as a value of field '" << f.name
                           << "' (TYPE " << f.type << " SIZE " << f.size << ")");
        }
      }
    }
    if (!detail::next_token(line, pos).empty()) {
      PLUMB_THROW(name << ":" << cur.line << ": more than the " << values_per_point << " values FIELDS declares");
    }
    cloud.points.push_back(p);
    if (has_normals) cloud.normals.push_back(nrm);
    if (has_intensity) cloud.intensities.push_back(intensity);
    if (has_ring) cloud.rings.push_back(ring);
    if (has_time) cloud.times.push_back(time);
    if (has_label) cloud.labels.push_back(label);
  }
}

}  // namespace

PointCloud read_pcd_buffer(const char* data, std::size_t size, const std::string& name,
                           const PcdReadSettings& settings) {
  if (data == nullptr || size == 0) PLUMB_THROW(name << ": empty PCD file");
  const Header h = parse_header(data, size, name);
  PointCloud cloud;
  switch (h.kind) {
    case DataKind::kAscii: read_ascii(h, data, size, name, cloud); break;
    case DataKind::kBinary: read_binary(h, data, size, name, cloud); break;
    case DataKind::kBinaryCompressed: read_compressed(h, data, size, name, cloud); break;
  }
  if (settings.drop_non_finite) {
    const auto keep = cloud.finite_indices();
    if (keep.size() != cloud.size()) cloud = cloud.select(keep);
  }
  return cloud;
}

PointCloud read_pcd(const std::string& path, const PcdReadSettings& settings) {
  const std::vector<char> data = cloud_detail::slurp_file(path);
  return read_pcd_buffer(data.data(), data.size(), path, settings);
}

std::string write_pcd_buffer(const PointCloud& cloud, const PcdWriteSettings& settings) {
  cloud.check_consistent("write_pcd");
  const std::vector<cloud_detail::OutColumn> cols = cloud_detail::out_columns(cloud, false);
  const std::size_t n = cloud.size();
  std::size_t point_size = 0;
  for (const auto& c : cols) point_size += static_cast<std::size_t>(c.size);

  std::string out;
  out += "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS";
  for (const auto& c : cols) (out += ' ') += c.name;
  out += "\nSIZE";
  for (const auto& c : cols) (out += ' ') += std::to_string(c.size);
  out += "\nTYPE";
  for (const auto& c : cols) (out += ' ') += c.type;
  out += "\nCOUNT";
  for (std::size_t k = 0; k < cols.size(); ++k) out += " 1";
  out += "\nWIDTH " + std::to_string(n) + "\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS " + std::to_string(n) +
         "\nDATA ";

  switch (settings.encoding) {
    case PcdEncoding::kAscii: {
      out += "ascii\n";
      cloud_detail::append_ascii_rows(out, cols, n);
      break;
    }
    case PcdEncoding::kBinary: {
      out += "binary\n";
      const std::size_t start = out.size();
      out.resize(start + n * point_size);
      std::size_t offset = 0;  // interleaved records: column k at offset within each record
      for (const auto& c : cols) {
        const std::size_t s = static_cast<std::size_t>(c.size);
        char* dst = &out[start + offset];
        for (std::size_t i = 0; i < n; ++i) std::memcpy(dst + i * point_size, c.base + i * c.stride, s);
        offset += s;
      }
      break;
    }
    case PcdEncoding::kBinaryCompressed: {
      out += "binary_compressed\n";
      PLUMB_CHECK(n <= std::numeric_limits<std::uint32_t>::max() / point_size,
                  "write_pcd: " << n << " points are too many for binary_compressed (4 GiB limit)");
      std::vector<char> soa(n * point_size);
      std::size_t pos = 0;  // structure of arrays: each column's n values in turn
      for (const auto& c : cols) {
        const std::size_t s = static_cast<std::size_t>(c.size);
        for (std::size_t i = 0; i < n; ++i, pos += s) std::memcpy(&soa[pos], c.base + i * c.stride, s);
      }
      const auto uncompressed = static_cast<std::uint32_t>(soa.size());
      // LZF's worst case grows the input by one byte per 32 literals.
      std::vector<char> compressed(soa.size() + soa.size() / 16 + 64);
      std::uint32_t compressed_size = 0;
      if (!soa.empty()) {
        compressed_size = lzf_compress(soa.data(), uncompressed, compressed.data(),
                                       static_cast<unsigned int>(compressed.size()));
        PLUMB_CHECK(compressed_size > 0, "write_pcd: LZF compression failed");
      }
      char prefix[8];
      std::memcpy(prefix, &compressed_size, 4);
      std::memcpy(prefix + 4, &uncompressed, 4);
      out.append(prefix, 8);
      out.append(compressed.data(), compressed_size);
      break;
    }
  }
  return out;
}

void write_pcd(const std::string& path, const PointCloud& cloud, const PcdWriteSettings& settings) {
  cloud_detail::encode_and_write(path, [&] { return write_pcd_buffer(cloud, settings); });
}

}  // namespace plumb::io
