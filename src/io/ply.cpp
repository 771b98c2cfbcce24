// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/io/ply.hpp"

#include <array>
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
using cloud_detail::load_swapped;
using cloud_detail::parse_number;
using detail::split_tokens;

enum class Format { kAscii, kBinaryLittleEndian, kBinaryBigEndian };
enum class Scalar { kInt8, kUint8, kInt16, kUint16, kInt32, kUint32, kFloat32, kFloat64 };
enum class Role { kNone, kX, kY, kZ, kNormalX, kNormalY, kNormalZ, kIntensity, kRing, kTime, kLabel };
constexpr int kNumRoles = 11;

struct Property {
  std::string name;
  Scalar type = Scalar::kFloat32;
  bool is_list = false;
  Scalar count_type = Scalar::kUint8;  // lists only
  Role role = Role::kNone;
};

struct Element {
  std::string name;
  std::uint64_t count = 0;
  std::vector<Property> properties;
  std::size_t line = 0;
};

struct Header {
  Format format = Format::kAscii;
  std::vector<Element> elements;
  std::size_t data_offset = 0;
  std::size_t end_line = 0;  // line number of end_header
};

bool scalar_of(std::string_view s, Scalar& out) {
  struct Entry {
    const char* a;
    const char* b;
    Scalar t;
  };
  static const Entry kTable[] = {{"char", "int8", Scalar::kInt8},      {"uchar", "uint8", Scalar::kUint8},
                                 {"short", "int16", Scalar::kInt16},   {"ushort", "uint16", Scalar::kUint16},
                                 {"int", "int32", Scalar::kInt32},     {"uint", "uint32", Scalar::kUint32},
                                 {"float", "float32", Scalar::kFloat32}, {"double", "float64", Scalar::kFloat64}};
  for (const Entry& e : kTable) {
    if (s == e.a || s == e.b) {
      out = e.t;
      return true;
    }
  }
  return false;
}

std::size_t size_of(Scalar t) {
  switch (t) {
    case Scalar::kInt8:
    case Scalar::kUint8: return 1;
    case Scalar::kInt16:
    case Scalar::kUint16: return 2;
    case Scalar::kInt32:
    case Scalar::kUint32:
    case Scalar::kFloat32: return 4;
    case Scalar::kFloat64: return 8;
  }
  return 1;
}

Role role_of(std::string_view name) {
  if (name == "x") return Role::kX;
  if (name == "y") return Role::kY;
  if (name == "z") return Role::kZ;
  if (name == "nx" || name == "normal_x") return Role::kNormalX;
  if (name == "ny" || name == "normal_y") return Role::kNormalY;
  if (name == "nz" || name == "normal_z") return Role::kNormalZ;
  if (name == "intensity") return Role::kIntensity;
  if (name == "ring") return Role::kRing;
  if (name == "time") return Role::kTime;
  if (name == "label") return Role::kLabel;
  return Role::kNone;
}

Header parse_header(const char* data, std::size_t size, const std::string& name) {
  Header h;
  LineCursor cur{data, data, data + size, 0};
  std::string_view line;
  if (!cur.next(line) || line != "ply") PLUMB_THROW(name << ":1: not a PLY file (first line is not 'ply')");
  bool have_format = false;
  while (true) {
    if (!cur.next(line)) PLUMB_THROW(name << ":" << cur.line << ": truncated PLY header (no end_header)");
    const auto t = split_tokens(line);
    if (t.empty()) continue;
    const std::string_view key = t[0];
    if (key == "comment" || key == "obj_info") continue;
    if (key == "end_header") {
      if (t.size() != 1) PLUMB_THROW(name << ":" << cur.line << ": unexpected text after end_header");
      break;
    }
    if (key == "format") {
      if (t.size() != 3 || t[2] != "1.0") {
        PLUMB_THROW(name << ":" << cur.line << ": expected 'format <kind> 1.0'");
      }
      static constexpr std::pair<std::string_view, Format> kFormats[] = {
          {"ascii", Format::kAscii},
          {"binary_little_endian", Format::kBinaryLittleEndian},
          {"binary_big_endian", Format::kBinaryBigEndian}};
      if (!cloud_detail::keyword_value(t[1], kFormats, h.format)) {
        PLUMB_THROW(name << ":" << cur.line << ": unknown PLY format '" << t[1] << "'");
      }
      have_format = true;
    } else if (key == "element") {
      if (t.size() != 3) PLUMB_THROW(name << ":" << cur.line << ": expected 'element <name> <count>'");
      Element e;
      e.name = std::string(t[1]);
      e.line = cur.line;
      if (!parse_number(t[2], e.count)) {
        PLUMB_THROW(name << ":" << cur.line << ": element count '" << t[2] << "' is not a non-negative integer");
      }
      h.elements.push_back(std::move(e));
    } else if (key == "property") {
      if (h.elements.empty()) PLUMB_THROW(name << ":" << cur.line << ": property before any element");
      Property p;
      if (t.size() == 5 && t[1] == "list") {
        p.is_list = true;
        if (!scalar_of(t[2], p.count_type) || !scalar_of(t[3], p.type)) {
          PLUMB_THROW(name << ":" << cur.line << ": unknown type in list property");
        }
        if (p.count_type == Scalar::kFloat32 || p.count_type == Scalar::kFloat64) {
          PLUMB_THROW(name << ":" << cur.line << ": list count type must be an integer type");
        }
        p.name = std::string(t[4]);
      } else if (t.size() == 3) {
        if (!scalar_of(t[1], p.type)) PLUMB_THROW(name << ":" << cur.line << ": unknown property type '" << t[1] << "'");
        p.name = std::string(t[2]);
      } else {
        PLUMB_THROW(name << ":" << cur.line << ": malformed property line");
      }
      h.elements.back().properties.push_back(std::move(p));
    } else {
      PLUMB_THROW(name << ":" << cur.line << ": unknown PLY header keyword '" << key << "'");
    }
  }
  if (!have_format) PLUMB_THROW(name << ":" << cur.line << ": PLY header has no format line");
  h.data_offset = cur.offset();
  h.end_line = cur.line;

  // Roles on the vertex element; every mapped property must be a scalar, named once.
  bool have_vertex = false;
  for (Element& e : h.elements) {
    if (e.name != "vertex") continue;
    if (have_vertex) PLUMB_THROW(name << ":" << e.line << ": second 'element vertex'");
    have_vertex = true;
    std::array<int, kNumRoles> seen{};
    for (Property& p : e.properties) {
      p.role = p.is_list ? Role::kNone : role_of(p.name);
      if (p.role == Role::kNone) continue;
      if (++seen[static_cast<int>(p.role)] > 1) {
        PLUMB_THROW(name << ":" << e.line << ": vertex property '" << p.name << "' appears twice");
      }
    }
    if (!seen[static_cast<int>(Role::kX)] || !seen[static_cast<int>(Role::kY)] || !seen[static_cast<int>(Role::kZ)]) {
      PLUMB_THROW(name << ":" << e.line << ": element vertex lacks property x, y or z");
    }
    const bool normals = seen[static_cast<int>(Role::kNormalX)] && seen[static_cast<int>(Role::kNormalY)] &&
                         seen[static_cast<int>(Role::kNormalZ)];
    if (!normals) {
      for (Property& p : e.properties) {
        if (p.role == Role::kNormalX || p.role == Role::kNormalY || p.role == Role::kNormalZ) p.role = Role::kNone;
      }
    }
  }
  if (!have_vertex) PLUMB_THROW(name << ":" << h.end_line << ": PLY file has no 'element vertex'");
  return h;
}

// Destination of one vertex: the cloud's arrays at index i.
struct VertexSink {
  PointCloud* cloud = nullptr;
  std::size_t i = 0;

  template <class Src>
  bool put(Role r, Src v) {
    PointCloud& c = *cloud;
    switch (r) {
      case Role::kX: return convert_value(v, c.points[i].x());
      case Role::kY: return convert_value(v, c.points[i].y());
      case Role::kZ: return convert_value(v, c.points[i].z());
      case Role::kNormalX: return convert_value(v, c.normals[i].x());
      case Role::kNormalY: return convert_value(v, c.normals[i].y());
      case Role::kNormalZ: return convert_value(v, c.normals[i].z());
      case Role::kIntensity: return convert_value(v, c.intensities[i]);
      case Role::kRing: return convert_value(v, c.rings[i]);
      case Role::kTime: return convert_value(v, c.times[i]);
      case Role::kLabel: return convert_value(v, c.labels[i]);
      case Role::kNone: return true;
    }
    return true;
  }
};

void size_cloud(const Element& e, std::size_t n, PointCloud& cloud) {
  bool has[kNumRoles] = {};
  for (const Property& p : e.properties) has[static_cast<int>(p.role)] = true;
  cloud.points.assign(n, Vector3f::Zero());
  if (has[static_cast<int>(Role::kNormalX)]) cloud.normals.assign(n, Vector3f::Zero());
  if (has[static_cast<int>(Role::kIntensity)]) cloud.intensities.assign(n, 0.0f);
  if (has[static_cast<int>(Role::kRing)]) cloud.rings.assign(n, 0);
  if (has[static_cast<int>(Role::kTime)]) cloud.times.assign(n, 0.0f);
  if (has[static_cast<int>(Role::kLabel)]) cloud.labels.assign(n, 0);
}

// ---- binary ------------------------------------------------------------------------------------

template <class T>
T load_as(const char* p, bool swap) {
  return swap ? load_swapped<T>(p) : load<T>(p);
}

// Read one scalar of type t at p into the sink's role; false when an integer role gets a bad value.
bool put_binary(Scalar t, const char* p, bool swap, Role r, VertexSink& sink) {
  switch (t) {
    case Scalar::kInt8: return sink.put(r, load_as<std::int8_t>(p, swap));
    case Scalar::kUint8: return sink.put(r, load_as<std::uint8_t>(p, swap));
    case Scalar::kInt16: return sink.put(r, load_as<std::int16_t>(p, swap));
    case Scalar::kUint16: return sink.put(r, load_as<std::uint16_t>(p, swap));
    case Scalar::kInt32: return sink.put(r, load_as<std::int32_t>(p, swap));
    case Scalar::kUint32: return sink.put(r, load_as<std::uint32_t>(p, swap));
    case Scalar::kFloat32: return sink.put(r, load_as<float>(p, swap));
    case Scalar::kFloat64: return sink.put(r, load_as<double>(p, swap));
  }
  return false;
}

// A list length as an unsigned count; false for a negative value.
bool list_length(Scalar t, const char* p, bool swap, std::uint64_t& n) {
  switch (t) {
    case Scalar::kInt8: return convert_value(load_as<std::int8_t>(p, swap), n);
    case Scalar::kUint8: return convert_value(load_as<std::uint8_t>(p, swap), n);
    case Scalar::kInt16: return convert_value(load_as<std::int16_t>(p, swap), n);
    case Scalar::kUint16: return convert_value(load_as<std::uint16_t>(p, swap), n);
    case Scalar::kInt32: return convert_value(load_as<std::int32_t>(p, swap), n);
    case Scalar::kUint32: return convert_value(load_as<std::uint32_t>(p, swap), n);
    default: return false;
  }
}

void read_binary(const Header& h, const char* data, std::size_t size, const std::string& name, PointCloud& cloud) {
  const bool swap = h.format == Format::kBinaryBigEndian;
  std::size_t pos = h.data_offset;
  for (const Element& e : h.elements) {
    if (e.properties.empty()) continue;  // nothing stored, whatever the count
    std::size_t min_item = 0;
    for (const Property& p : e.properties) min_item += p.is_list ? size_of(p.count_type) : size_of(p.type);
    const std::size_t remaining = size - pos;
    if (e.count > remaining / min_item) {
      PLUMB_THROW(name << ": byte " << pos << ": element " << e.name << " truncated: " << e.count
                       << " items of at least " << min_item << " bytes need more than the " << remaining
                       << " bytes left");
    }
    const std::size_t n = static_cast<std::size_t>(e.count);
    const bool is_vertex = e.name == "vertex";
    VertexSink sink{&cloud, 0};
    if (is_vertex) size_cloud(e, n, cloud);
    for (std::size_t i = 0; i < n; ++i) {
      sink.i = i;
      for (const Property& p : e.properties) {
        if (p.is_list) {
          const std::size_t cs = size_of(p.count_type);
          if (size - pos < cs) PLUMB_THROW(name << ": byte " << pos << ": truncated in list '" << p.name << "'");
          std::uint64_t len = 0;
          if (!list_length(p.count_type, data + pos, swap, len)) {
            PLUMB_THROW(name << ": byte " << pos << ": negative length of list '" << p.name << "'");
          }
          pos += cs;
          const std::size_t is = size_of(p.type);
          if (len > (size - pos) / is) {
            PLUMB_THROW(name << ": byte " << pos << ": list '" << p.name << "' of " << len
                             << " items runs past the end of the file");
          }
          pos += static_cast<std::size_t>(len) * is;
          continue;
        }
        const std::size_t s = size_of(p.type);
        if (size - pos < s) PLUMB_THROW(name << ": byte " << pos << ": truncated in property '" << p.name << "'");
        if (is_vertex && p.role != Role::kNone && !put_binary(p.type, data + pos, swap, p.role, sink)) {
          PLUMB_THROW(name << ": byte " << pos << ": value of vertex property '" << p.name
                           << "' is not an integer in the range of its destination");
        }
        pos += s;
      }
    }
  }
}

// ---- ascii -------------------------------------------------------------------------------------

// Whitespace-separated tokens across lines, tracking the line number.
struct TokenCursor {
  const char* pos;
  const char* end;
  std::size_t line;

  std::string_view next() {
    while (pos < end && detail::is_space(*pos)) {
      if (*pos == '\n') ++line;
      ++pos;
    }
    const char* start = pos;
    while (pos < end && !detail::is_space(*pos)) ++pos;
    return std::string_view(start, static_cast<std::size_t>(pos - start));
  }
};

template <class Sink>
bool put_ascii(Scalar t, std::string_view tok, Role r, Sink& sink) {
  switch (t) {
    case Scalar::kFloat32: {
      float v;
      return parse_number(tok, v) && sink.put(r, v);
    }
    case Scalar::kFloat64: {
      double v;
      return parse_number(tok, v) && sink.put(r, v);
    }
    case Scalar::kUint8:
    case Scalar::kUint16:
    case Scalar::kUint32: {
      std::uint64_t v;
      if (parse_number(tok, v)) return sink.put(r, v);
      break;
    }
    default: {
      std::int64_t v;
      if (parse_number(tok, v)) return sink.put(r, v);
      break;
    }
  }
  double v;  // lenient: "3.0" for an integer property
  return parse_number(tok, v) && sink.put(r, v);
}

void read_ascii(const Header& h, const char* data, std::size_t size, const std::string& name, PointCloud& cloud) {
  TokenCursor cur{data + h.data_offset, data + size, h.end_line + 1};
  for (const Element& e : h.elements) {
    if (e.properties.empty()) continue;
    const bool is_vertex = e.name == "vertex";
    // Every item needs at least two bytes per property ("0 "): bound the allocation by the data.
    const std::uint64_t can_hold = static_cast<std::uint64_t>(cur.end - cur.pos) / (2 * e.properties.size()) + 1;
    if (e.count > can_hold) {
      PLUMB_THROW(name << ":" << cur.line << ": truncated: element " << e.name << " declares " << e.count
                       << " items, more than the remaining data can hold");
    }
    const std::size_t n = static_cast<std::size_t>(e.count);
    VertexSink sink{&cloud, 0};
    if (is_vertex) size_cloud(e, n, cloud);
    for (std::size_t i = 0; i < n; ++i) {
      sink.i = i;
      for (const Property& p : e.properties) {
        std::string_view tok = cur.next();
        if (tok.empty()) {
          PLUMB_THROW(name << ":" << cur.line << ": truncated: element " << e.name << " item " << i << " of "
                           << e.count << " ends before property '" << p.name << "'");
        }
        if (p.is_list) {
          std::uint64_t len = 0;
          if (!parse_number(tok, len)) {
            PLUMB_THROW(name << ":" << cur.line << ": bad length '" << tok << "' of list '" << p.name << "'");
          }
          for (std::uint64_t k = 0; k < len; ++k) {
            if (cur.next().empty()) {
              PLUMB_THROW(name << ":" << cur.line << ": truncated inside list '" << p.name << "'");
            }
          }
          continue;
        }
        if (is_vertex && p.role != Role::kNone && !put_ascii(p.type, tok, p.role, sink)) {
          PLUMB_THROW(name << ":" << cur.line << ": cannot read '" << tok << "' as a value of vertex property '"
                           << p.name << "'");
        }
      }
    }
  }
}

const char* type_name(char t) { return t == 'F' ? "float" : t == 'U' ? "ushort" : "int"; }

}  // namespace

PointCloud read_ply_buffer(const char* data, std::size_t size, const std::string& name) {
  if (data == nullptr || size == 0) PLUMB_THROW(name << ": empty PLY file");
  const Header h = parse_header(data, size, name);
  PointCloud cloud;
  if (h.format == Format::kAscii) {
    read_ascii(h, data, size, name, cloud);
  } else {
    read_binary(h, data, size, name, cloud);
  }
  return cloud;
}

PointCloud read_ply(const std::string& path) {
  const std::vector<char> data = cloud_detail::slurp_file(path);
  return read_ply_buffer(data.data(), data.size(), path);
}

std::string write_ply_buffer(const PointCloud& cloud, const PlyWriteSettings& settings) {
  cloud.check_consistent("write_ply");
  const std::vector<cloud_detail::OutColumn> cols = cloud_detail::out_columns(cloud, true);
  const std::size_t n = cloud.size();
  const bool ascii = settings.encoding == PlyEncoding::kAscii;

  std::string out = "ply\nformat ";
  out += ascii ? "ascii" : "binary_little_endian";
  out += " 1.0\ncomment written by plumb\nelement vertex " + std::to_string(n) + "\n";
  for (const auto& c : cols) out += std::string("property ") + type_name(c.type) + " " + c.name + "\n";
  out += "end_header\n";

  if (ascii) {
    cloud_detail::append_ascii_rows(out, cols, n);
    return out;
  }
  std::size_t record = 0;
  for (const auto& c : cols) record += static_cast<std::size_t>(c.size);
  const std::size_t start = out.size();
  out.resize(start + n * record);
  std::size_t offset = 0;
  for (const auto& c : cols) {
    const std::size_t s = static_cast<std::size_t>(c.size);
    char* dst = &out[start + offset];
    for (std::size_t i = 0; i < n; ++i) std::memcpy(dst + i * record, c.base + i * c.stride, s);
    offset += s;
  }
  return out;
}

void write_ply(const std::string& path, const PointCloud& cloud, const PlyWriteSettings& settings) {
  cloud_detail::encode_and_write(path, [&] { return write_ply_buffer(cloud, settings); });
}

}  // namespace plumb::io
