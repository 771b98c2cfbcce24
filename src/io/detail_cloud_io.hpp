// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief Private helpers shared by the point-cloud readers and writers (PCD, PLY, KITTI .bin):
///        whole-file slurp and write, a bounded text cursor, number parsing and checked
///        conversions. Not installed; not part of the API.

#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <limits>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>
#include <vector>

#include "plumb/io/input_file.hpp"
#include "plumb/core/error.hpp"
#include "plumb/core/point_cloud.hpp"

namespace plumb::io::cloud_detail {

/// Read a whole file into memory with one read. Throws plumb::Error naming the path.
inline std::vector<char> slurp_file(const std::string& path) {
  check_input_file(path);  // a directory opens with fopen on Linux and reads as an error or nothing
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (f == nullptr) PLUMB_THROW(path << ": cannot open for reading: " << std::strerror(errno));
  std::vector<char> data;
  if (std::fseek(f, 0, SEEK_END) == 0) {
    const long size = std::ftell(f);
    std::fseek(f, 0, SEEK_SET);
    if (size > 0) {  // straight into place (a large fread bypasses stdio's buffer)
      data.resize(static_cast<std::size_t>(size));
      data.resize(std::fread(data.data(), 1, data.size(), f));
    }
  }
  // Whatever the size did not cover (a file that grew, or one whose size is unknown).
  char chunk[1 << 16];
  std::size_t got = 0;
  while ((got = std::fread(chunk, 1, sizeof(chunk), f)) > 0) data.insert(data.end(), chunk, chunk + got);
  const bool failed = std::ferror(f) != 0;
  std::fclose(f);
  if (failed) PLUMB_THROW(path << ": read error");
  return data;
}

/// Write a whole buffer to a file (created or truncated). Throws plumb::Error naming the path.
inline void write_file(const std::string& path, const char* data, std::size_t size) {
  std::FILE* f = std::fopen(path.c_str(), "wb");
  if (f == nullptr) PLUMB_THROW(path << ": cannot open for writing: " << std::strerror(errno));
  const std::size_t written = size == 0 ? 0 : std::fwrite(data, 1, size, f);
  const bool close_failed = std::fclose(f) != 0;
  if (written != size || close_failed) PLUMB_THROW(path << ": write failed");
}

/// Encode with `make_bytes()` (which may throw plumb::Error about the cloud) and write the result;
/// an encoding error is re-thrown with the path in front, so every writer names its file alike.
template <class MakeBytes>
void encode_and_write(const std::string& path, MakeBytes&& make_bytes) {
  std::string bytes;
  try {
    bytes = make_bytes();
  } catch (const Error& e) {
    PLUMB_THROW(path << ": " << e.what());
  }
  write_file(path, bytes.data(), bytes.size());
}

/// Line-oriented cursor over a text (or header) region; tolerates CRLF.
struct LineCursor {
  const char* begin = nullptr;  ///< start of the whole buffer (for byte offsets)
  const char* pos = nullptr;
  const char* end = nullptr;
  std::size_t line = 0;  ///< 1-based number of the line last returned by next()

  /// Next line without its terminator ("\n" or "\r\n"); false at end of buffer.
  bool next(std::string_view& out) {
    if (pos >= end) return false;
    const char* nl = static_cast<const char*>(std::memchr(pos, '\n', static_cast<std::size_t>(end - pos)));
    const char* stop = nl != nullptr ? nl : end;
    const char* trimmed = stop;
    if (trimmed > pos && trimmed[-1] == '\r') --trimmed;
    out = std::string_view(pos, static_cast<std::size_t>(trimmed - pos));
    pos = nl != nullptr ? nl + 1 : end;
    ++line;
    return true;
  }
  std::size_t offset() const { return static_cast<std::size_t>(pos - begin); }
};

/// Parse a whole token as T (integer or floating point); false when it is not exactly a number.
/// Accepts a leading '+' and, for floating point, nan / inf in any case.
template <class T>
bool parse_number(std::string_view tok, T& out) {
  if (!tok.empty() && tok.front() == '+') tok.remove_prefix(1);
  if (tok.empty()) return false;
  const char* first = tok.data();
  const char* last = tok.data() + tok.size();
  if constexpr (std::is_floating_point_v<T>) {
    auto [ptr, ec] = std::from_chars(first, last, out, std::chars_format::general);
    if (ec == std::errc::result_out_of_range && ptr == last) {
      // from_chars leaves out untouched on over/underflow; keep what a C reader would give.
      out = static_cast<T>(std::strtod(std::string(tok).c_str(), nullptr));
      return true;
    }
    return ec == std::errc() && ptr == last;
  } else {
    auto [ptr, ec] = std::from_chars(first, last, out);
    return ec == std::errc() && ptr == last;
  }
}

/// Little-endian scalar load from unaligned memory (hosts here are little endian).
template <class T>
inline T load(const char* p) {
  T v;
  std::memcpy(&v, p, sizeof(T));
  return v;
}

/// Byte-swapped scalar load (big-endian files).
template <class T>
inline T load_swapped(const char* p) {
  char tmp[sizeof(T)];
  for (std::size_t k = 0; k < sizeof(T); ++k) tmp[k] = p[sizeof(T) - 1 - k];
  return load<T>(tmp);
}

/// Convert a source value into a destination field type. Floating destinations take any value
/// (IEEE casts); integer destinations must be finite and in range, else false.
template <class Dst, class Src>
inline bool convert_value(Src v, Dst& out) {
  if constexpr (std::is_floating_point_v<Dst>) {
    out = static_cast<Dst>(v);
    return true;
  } else if constexpr (std::is_floating_point_v<Src>) {
    // [min, 2^digits) with both ends exactly representable, so the cast below is defined.
    const Src lo = static_cast<Src>(std::numeric_limits<Dst>::min());
    const Src hi = std::ldexp(Src(1), std::numeric_limits<Dst>::digits);
    if (!(v >= lo && v < hi) || v != std::trunc(v)) return false;
    out = static_cast<Dst>(v);
    return true;
  } else if constexpr (std::is_signed_v<Src>) {
    const long long x = static_cast<long long>(v);
    if constexpr (std::is_signed_v<Dst>) {
      if (x < static_cast<long long>(std::numeric_limits<Dst>::min()) ||
          x > static_cast<long long>(std::numeric_limits<Dst>::max())) {
        return false;
      }
    } else {
      if (x < 0 || static_cast<unsigned long long>(x) > std::numeric_limits<Dst>::max()) return false;
    }
    out = static_cast<Dst>(v);
    return true;
  } else {
    const unsigned long long x = static_cast<unsigned long long>(v);
    if (x > static_cast<unsigned long long>(std::numeric_limits<Dst>::max())) return false;
    out = static_cast<Dst>(v);
    return true;
  }
}

/// Append the shortest decimal form that reads back to exactly `v` (floats) or the integer.
template <class T>
void append_number(std::string& out, T v) {
  char buf[64];
  const auto res = std::to_chars(buf, buf + sizeof(buf), v);
  out.append(buf, res.ptr);
}

/// One stored column of a cloud for the writers: value i is at base + i * stride.
struct OutColumn {
  const char* name;  ///< field / property name in the file
  char type;         ///< 'F' float32, 'U' uint16, 'I' int32
  int size;          ///< bytes per value
  const char* base;
  std::size_t stride;
};

/// x y z and every present optional field of the cloud, in the order the writers store them.
/// `ply_names` selects PLY's nx/ny/nz over PCD's normal_x/normal_y/normal_z.
inline std::vector<OutColumn> out_columns(const PointCloud& c, bool ply_names) {
  static_assert(sizeof(Vector3f) == 3 * sizeof(float), "Vector3f must be three packed floats");
  const auto vec = [](const std::vector<Vector3f>& v, int k) -> const char* {
    if (v.empty()) return nullptr;  // no offset on a null data()
    return reinterpret_cast<const char*>(v.data()) + k * static_cast<int>(sizeof(float));
  };
  std::vector<OutColumn> cols = {{"x", 'F', 4, vec(c.points, 0), sizeof(Vector3f)},
                                 {"y", 'F', 4, vec(c.points, 1), sizeof(Vector3f)},
                                 {"z", 'F', 4, vec(c.points, 2), sizeof(Vector3f)}};
  if (c.has_normals()) {
    cols.push_back({ply_names ? "nx" : "normal_x", 'F', 4, vec(c.normals, 0), sizeof(Vector3f)});
    cols.push_back({ply_names ? "ny" : "normal_y", 'F', 4, vec(c.normals, 1), sizeof(Vector3f)});
    cols.push_back({ply_names ? "nz" : "normal_z", 'F', 4, vec(c.normals, 2), sizeof(Vector3f)});
  }
  const auto col = [](const auto& v) { return reinterpret_cast<const char*>(v.data()); };
  if (c.has_intensities()) cols.push_back({"intensity", 'F', 4, col(c.intensities), sizeof(float)});
  if (c.has_rings()) cols.push_back({"ring", 'U', 2, col(c.rings), sizeof(std::uint16_t)});
  if (c.has_times()) cols.push_back({"time", 'F', 4, col(c.times), sizeof(float)});
  if (c.has_labels()) cols.push_back({"label", 'I', 4, col(c.labels), sizeof(std::int32_t)});
  return cols;
}

/// Append value i of a column in decimal (shortest round-trip form for floats).
inline void append_column_value(std::string& out, const OutColumn& c, std::size_t i) {
  const char* p = c.base + i * c.stride;
  if (c.type == 'F') {
    append_number(out, load<float>(p));
  } else if (c.type == 'U') {
    append_number(out, load<std::uint16_t>(p));
  } else {
    append_number(out, load<std::int32_t>(p));
  }
}

/// Append rows 0 .. n-1 of `cols` as text: the values of a row separated by one space, one row a line.
inline void append_ascii_rows(std::string& out, const std::vector<OutColumn>& cols, std::size_t n) {
  out.reserve(out.size() + n * cols.size() * 12);
  for (std::size_t i = 0; i < n; ++i) {
    for (std::size_t k = 0; k < cols.size(); ++k) {
      if (k > 0) out += ' ';
      append_column_value(out, cols[k], i);
    }
    out += '\n';
  }
}

/// The value `table` pairs with the header keyword `word`, in `out`; false (`out` untouched) when
/// no entry names it.
template <class E, std::size_t N>
bool keyword_value(std::string_view word, const std::pair<std::string_view, E> (&table)[N], E& out) {
  for (const auto& entry : table) {
    if (word == entry.first) {
      out = entry.second;
      return true;
    }
  }
  return false;
}

}  // namespace plumb::io::cloud_detail
