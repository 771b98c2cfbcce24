// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/io/bcf.hpp"

#include <unistd.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <set>
#include <utility>

#include <zlib.h>

#include "plumb/core/error.hpp"
#include "xml_text.hpp"

namespace plumb::io {
namespace {

using detail::xml_escape;

// ---- checks --------------------------------------------------------------------------------------

bool is_hex(char c, bool upper_only) {
  return (c >= '0' && c <= '9') || (c >= 'A' && c <= 'F') || (!upper_only && c >= 'a' && c <= 'f');
}

bool is_digit(char c) { return c >= '0' && c <= '9'; }

bool is_uuid(std::string_view s) {
  if (s.size() != 36) return false;
  for (std::size_t i = 0; i < s.size(); ++i) {
    const bool dash = i == 8 || i == 13 || i == 18 || i == 23;
    if (dash ? s[i] != '-' : !is_hex(s[i], false)) return false;
  }
  return true;
}

}  // namespace

bool is_ifc_guid(std::string_view s) {
  if (s.size() != 22) return false;
  for (char c : s) {
    const bool ok = is_digit(c) || (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || c == '_' || c == '$';
    if (!ok) return false;
  }
  return true;
}

namespace {

bool is_color(std::string_view s) {
  if (s.size() != 6 && s.size() != 8) return false;
  for (char c : s) {
    if (!is_hex(c, true)) return false;
  }
  return true;
}

/// `n` digits at `pos`, at most `max`.
bool digits(std::string_view s, std::size_t pos, std::size_t n, int max) {
  if (pos + n > s.size()) return false;
  int v = 0;
  for (std::size_t i = pos; i < pos + n; ++i) {
    if (!is_digit(s[i])) return false;
    v = 10 * v + (s[i] - '0');
  }
  return v <= max;
}

/// xs:dateTime as BCF uses it: YYYY-MM-DDThh:mm:ss, optional fraction, optional Z or +hh:mm / -hh:mm.
bool is_date_time(std::string_view s) {
  if (s.size() < 19 || !digits(s, 0, 4, 9999) || s[4] != '-' || !digits(s, 5, 2, 12) || s[7] != '-' ||
      !digits(s, 8, 2, 31) || s[10] != 'T' || !digits(s, 11, 2, 23) || s[13] != ':' || !digits(s, 14, 2, 59) ||
      s[16] != ':' || !digits(s, 17, 2, 59) || s.compare(5, 2, "00") == 0 || s.compare(8, 2, "00") == 0) {
    return false;
  }
  std::size_t pos = 19;
  if (pos < s.size() && s[pos] == '.') {
    const std::size_t start = ++pos;
    while (pos < s.size() && is_digit(s[pos])) ++pos;
    if (pos == start) return false;
  }
  if (pos == s.size()) return true;
  if (s[pos] == 'Z') return pos + 1 == s.size();
  return (s[pos] == '+' || s[pos] == '-') && s.size() == pos + 6 && digits(s, pos + 1, 2, 14) &&
         s[pos + 3] == ':' && digits(s, pos + 4, 2, 59);
}

/// XML 1.0 holds no control characters but tab, line feed and carriage return.
void check_text(std::string_view text, const std::string& where) {
  for (char c : text) {
    const auto u = static_cast<unsigned char>(c);
    PLUMB_CHECK(u >= 0x20 || c == '\t' || c == '\n' || c == '\r',
                where << ": control character " << static_cast<int>(u) << " cannot be written to XML");
  }
}

void check_vector(const Vector3d& v, const std::string& where) {
  PLUMB_CHECK(v.allFinite() && v.norm() > 0.0, where << " must be finite and not zero, got " << v.transpose());
}

void check_topic(const BcfTopic& t, const std::string& where) {
  PLUMB_CHECK(!t.title.empty(), where << ": empty title");
  PLUMB_CHECK(!t.author.empty(), where << ": empty author");
  PLUMB_CHECK(is_date_time(t.date), where << ": date '" << t.date << "' is not an xs:dateTime (e.g. 2026-03-01T12:00:00Z)");
  for (const auto& [name, text] : {std::pair<const char*, const std::string&>{"title", t.title},
                                   {"description", t.description}, {"author", t.author}, {"type", t.type},
                                   {"status", t.status}}) {
    check_text(text, where + " " + name);
  }
  PLUMB_CHECK(t.camera.viewpoint.allFinite(), where << ": camera viewpoint must be finite, got " << t.camera.viewpoint.transpose());
  check_vector(t.camera.direction, where + ": camera direction");
  check_vector(t.camera.up, where + ": camera up vector");
  PLUMB_CHECK(t.camera.direction.normalized().cross(t.camera.up.normalized()).norm() > 1e-9,
              where << ": camera up vector is along the direction");
  PLUMB_CHECK(t.camera.field_of_view_deg >= 45.0 && t.camera.field_of_view_deg <= 60.0,
              where << ": field of view " << t.camera.field_of_view_deg << " deg is outside [45, 60] (BCF 2.1)");
  for (const BcfComponent& c : t.components) {
    PLUMB_CHECK(is_ifc_guid(c.ifc_guid), where << ": component '" << c.ifc_guid
                                               << "' is not an IfcGuid (22 characters of 0-9 A-Z a-z _ $)");
    PLUMB_CHECK(c.color.empty() || is_color(c.color),
                where << ": component " << c.ifc_guid << ": colour '" << c.color << "' is not RRGGBB or RRGGBBAA (hex, upper case)");
  }
}

// ---- XML -----------------------------------------------------------------------------------------

constexpr const char* kXmlDeclaration = "<?xml version=\"1.0\" encoding=\"UTF-8\" standalone=\"yes\"?>\n";

void append_double(std::string& out, double value) {
  char buffer[64];
  const auto result = std::to_chars(buffer, buffer + sizeof(buffer), value);
  out.append(buffer, result.ptr);
}

void append_element(std::string& out, const char* indent, const char* name, std::string_view text) {
  out += indent;
  out += '<';
  out += name;
  out += '>';
  out += xml_escape(text);
  out += "</";
  out += name;
  out += ">\n";
}

void append_xyz(std::string& out, const char* name, const Vector3d& v) {
  out += "    <";
  out += name;
  out += ">\n";
  const char* axes[] = {"X", "Y", "Z"};
  for (int k = 0; k < 3; ++k) {
    out += "      <";
    out += axes[k];
    out += '>';
    append_double(out, v[k]);
    out += "</";
    out += axes[k];
    out += ">\n";
  }
  out += "    </";
  out += name;
  out += ">\n";
}

void append_component(std::string& out, const char* indent, const BcfComponent& c) {
  out += indent;
  out += "<Component IfcGuid=\"" + xml_escape(c.ifc_guid) + "\"/>\n";
}

std::string version_xml() {
  return std::string(kXmlDeclaration) +
         "<Version VersionId=\"2.1\">\n  <DetailedVersion>2.1</DetailedVersion>\n</Version>\n";
}

std::string project_xml(const std::string& project_id, const std::string& name) {
  std::string s = kXmlDeclaration;
  s += "<ProjectExtension>\n  <Project ProjectId=\"" + xml_escape(project_id) + "\">\n";
  append_element(s, "    ", "Name", name);
  s += "  </Project>\n  <ExtensionSchema></ExtensionSchema>\n</ProjectExtension>\n";
  return s;
}

std::string markup_xml(const BcfTopic& t, const std::string& guid, const std::string& viewpoint_guid) {
  std::string s = kXmlDeclaration;
  s += "<Markup>\n  <Topic Guid=\"" + guid + "\"";
  if (!t.type.empty()) s += " TopicType=\"" + xml_escape(t.type) + "\"";
  if (!t.status.empty()) s += " TopicStatus=\"" + xml_escape(t.status) + "\"";
  s += ">\n";
  append_element(s, "    ", "Title", t.title);
  append_element(s, "    ", "CreationDate", t.date);
  append_element(s, "    ", "CreationAuthor", t.author);
  append_element(s, "    ", "Description", t.description);
  s += "  </Topic>\n  <Viewpoints Guid=\"" + viewpoint_guid + "\">\n";
  s += "    <Viewpoint>viewpoint.bcfv</Viewpoint>\n  </Viewpoints>\n</Markup>\n";
  return s;
}

std::string viewpoint_xml(const BcfTopic& t, const std::string& viewpoint_guid) {
  std::string s = kXmlDeclaration;
  s += "<VisualizationInfo Guid=\"" + viewpoint_guid + "\">\n  <Components>\n";
  if (!t.components.empty()) {
    s += "    <Selection>\n";
    for (const BcfComponent& c : t.components) append_component(s, "      ", c);
    s += "    </Selection>\n";
  }
  s += "    <Visibility DefaultVisibility=\"true\"/>\n";
  std::vector<std::string> colors;  // in order of first use
  for (const BcfComponent& c : t.components) {
    if (!c.color.empty() && std::find(colors.begin(), colors.end(), c.color) == colors.end()) colors.push_back(c.color);
  }
  if (!colors.empty()) {
    s += "    <Coloring>\n";
    for (const std::string& color : colors) {
      s += "      <Color Color=\"" + color + "\">\n";
      for (const BcfComponent& c : t.components) {
        if (c.color == color) append_component(s, "        ", c);
      }
      s += "      </Color>\n";
    }
    s += "    </Coloring>\n";
  }
  s += "  </Components>\n  <PerspectiveCamera>\n";
  append_xyz(s, "CameraViewPoint", t.camera.viewpoint);
  append_xyz(s, "CameraDirection", t.camera.direction.normalized());
  append_xyz(s, "CameraUpVector", t.camera.up.normalized());
  s += "    <FieldOfView>";
  append_double(s, t.camera.field_of_view_deg);
  s += "</FieldOfView>\n  </PerspectiveCamera>\n</VisualizationInfo>\n";
  return s;
}

// ---- ZIP (APPNOTE.TXT 6.3: local headers, central directory, end record; method 0 = stored) -------

void put16(std::string& out, std::uint32_t v) {
  out += static_cast<char>(v & 0xFF);
  out += static_cast<char>((v >> 8) & 0xFF);
}

void put32(std::string& out, std::uint32_t v) {
  put16(out, v & 0xFFFF);
  put16(out, v >> 16);
}

/// A ZIP archive of stored entries, built in memory.
class ZipStore {
 public:
  void add(const std::string& name, const std::string& data) {
    PLUMB_CHECK(data.size() < 0xFFFFFFFFu && archive_.size() < 0xFFFFFFFFu && entries_.size() < 0xFFFF,
                name << ": too large for a ZIP archive without ZIP64");
    Entry e{name, static_cast<std::uint32_t>(archive_.size()), static_cast<std::uint32_t>(data.size()),
            static_cast<std::uint32_t>(crc32(0L, reinterpret_cast<const Bytef*>(data.data()),
                                             static_cast<uInt>(data.size())))};
    put32(archive_, 0x04034b50u);  // local file header
    put_common(archive_, e);
    archive_ += name;
    archive_ += data;
    entries_.push_back(std::move(e));
  }

  std::string finish() && {
    const std::size_t directory_offset = archive_.size();
    for (const Entry& e : entries_) {
      put32(archive_, 0x02014b50u);  // central directory header
      put16(archive_, 20);           // made by: MS-DOS attributes, version 2.0
      put_common(archive_, e);
      put16(archive_, 0);            // file comment length
      put16(archive_, 0);            // disk number start
      put16(archive_, 0);            // internal attributes
      put32(archive_, 0);            // external attributes
      put32(archive_, e.offset);
      archive_ += e.name;
    }
    const std::size_t directory_size = archive_.size() - directory_offset;
    PLUMB_CHECK(archive_.size() < 0xFFFFFFFFu, "archive too large for ZIP without ZIP64");
    put32(archive_, 0x06054b50u);  // end of central directory
    put16(archive_, 0);
    put16(archive_, 0);
    put16(archive_, static_cast<std::uint32_t>(entries_.size()));
    put16(archive_, static_cast<std::uint32_t>(entries_.size()));
    put32(archive_, static_cast<std::uint32_t>(directory_size));
    put32(archive_, static_cast<std::uint32_t>(directory_offset));
    put16(archive_, 0);  // comment length
    return std::move(archive_);
  }

 private:
  struct Entry {
    std::string name;
    std::uint32_t offset, size, crc;
  };

  /// The fields the local and the central header share, from "version needed" to "extra length".
  static void put_common(std::string& out, const Entry& e) {
    put16(out, 10);         // version needed: 1.0 (stored)
    put16(out, 1u << 11);   // flags: names are UTF-8
    put16(out, 0);          // method: stored
    put16(out, 0);          // DOS time 00:00:00 (fixed: the archive depends on its content only)
    put16(out, (0u << 9) | (1u << 5) | 1u);  // DOS date 1980-01-01
    put32(out, e.crc);
    put32(out, e.size);     // compressed size
    put32(out, e.size);     // uncompressed size
    put16(out, static_cast<std::uint32_t>(e.name.size()));
    put16(out, 0);          // extra field length
  }

  std::string archive_;
  std::vector<Entry> entries_;
};

void write_file_atomically(const std::string& path, const std::string& bytes) {
  namespace fs = std::filesystem;
  const fs::path target(path);
  const fs::path temp = target.parent_path() / ("." + target.filename().string() + ".tmp-" + std::to_string(::getpid()));
  std::FILE* f = std::fopen(temp.c_str(), "wb");
  PLUMB_CHECK(f != nullptr, path << ": cannot write (temporary " << temp.string() << "): " << std::strerror(errno));
  const bool written = std::fwrite(bytes.data(), 1, bytes.size(), f) == bytes.size();
  const bool closed = std::fclose(f) == 0;
  std::error_code ec;
  if (!written || !closed) {
    fs::remove(temp, ec);
    PLUMB_CHECK(false, path << ": write failed");
  }
  fs::rename(temp, target, ec);
  if (ec) {
    std::error_code ignored;
    fs::remove(temp, ignored);
    PLUMB_CHECK(false, path << ": cannot move the finished archive into place: " << ec.message());
  }
}

}  // namespace

std::string bcf_guid(std::uint64_t seed, std::string_view content) {
  // Two FNV-1a passes with different offsets over seed and content, each finished by SplitMix64's
  // mixer: 128 well-spread bits, of which RFC 9562 version 8 keeps 122.
  auto hash = [&](std::uint64_t h) {
    auto add = [&h](unsigned char byte) { h = (h ^ byte) * 0x100000001b3ull; };
    for (int k = 0; k < 8; ++k) add(static_cast<unsigned char>(seed >> (8 * k)));
    for (char c : content) add(static_cast<unsigned char>(c));
    h ^= h >> 30;
    h *= 0xbf58476d1ce4e5b9ull;
    h ^= h >> 27;
    h *= 0x94d049bb133111ebull;
    return h ^ (h >> 31);
  };
  std::uint64_t hi = hash(0xcbf29ce484222325ull), lo = hash(0x84222325cbf29ce4ull);
  hi = (hi & ~0xF000ull) | 0x8000ull;                      // version 8
  lo = (lo & 0x3FFFFFFFFFFFFFFFull) | 0x8000000000000000ull;  // variant 10
  char text[37];
  std::snprintf(text, sizeof(text), "%08x-%04x-%04x-%04x-%012llx", static_cast<unsigned>(hi >> 32),
                static_cast<unsigned>((hi >> 16) & 0xFFFF), static_cast<unsigned>(hi & 0xFFFF),
                static_cast<unsigned>(lo >> 48), static_cast<unsigned long long>(lo & 0xFFFFFFFFFFFFull));
  return text;
}

void write_bcf(const std::string& path, const BcfProject& project) {
  PLUMB_CHECK(!path.empty(), "write_bcf: empty path");
  check_text(project.name, path + ": project name");
  const std::string project_id = project.project_id.empty() ? bcf_guid(project.seed, "project\n" + project.name)
                                                            : project.project_id;
  check_text(project_id, path + ": project id");
  ZipStore zip;
  zip.add("bcf.version", version_xml());
  zip.add("project.bcfp", project_xml(project_id, project.name));
  std::set<std::string> guids;
  for (std::size_t i = 0; i < project.topics.size(); ++i) {
    const BcfTopic& t = project.topics[i];
    const std::string where = path + ": topic " + std::to_string(i) + " '" + t.title + "'";
    check_topic(t, where);
    const std::string guid =
        t.guid.empty() ? bcf_guid(project.seed, "topic\n" + std::to_string(i) + "\n" + t.title) : t.guid;
    PLUMB_CHECK(is_uuid(guid), where << ": GUID '" << guid << "' is not a UUID (xxxxxxxx-xxxx-xxxx-xxxx-xxxxxxxxxxxx)");
    PLUMB_CHECK(guids.insert(guid).second, where << ": GUID " << guid << " used by an earlier topic");
    const std::string viewpoint_guid = bcf_guid(project.seed, "viewpoint\n" + guid);
    zip.add(guid + "/markup.bcf", markup_xml(t, guid, viewpoint_guid));
    zip.add(guid + "/viewpoint.bcfv", viewpoint_xml(t, viewpoint_guid));
  }
  write_file_atomically(path, std::move(zip).finish());
}

}  // namespace plumb::io
