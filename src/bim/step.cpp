// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/bim/step.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <fstream>
#include <limits>
#include <sstream>

#include "plumb/core/error.hpp"

namespace plumb::bim {

namespace {

constexpr int kMaxNesting = 64;

bool is_space(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '\f' || c == '\v'; }
bool is_upper_ident(char c) {
  return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_' || c == '-';
}
int hex_value(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  return -1;
}

void append_utf8(std::string& out, std::uint32_t cp) {
  if (cp < 0x80) {
    out.push_back(static_cast<char>(cp));
  } else if (cp < 0x800) {
    out.push_back(static_cast<char>(0xC0 | (cp >> 6)));
    out.push_back(static_cast<char>(0x80 | (cp & 0x3F)));
  } else if (cp < 0x10000) {
    out.push_back(static_cast<char>(0xE0 | (cp >> 12)));
    out.push_back(static_cast<char>(0x80 | ((cp >> 6) & 0x3F)));
    out.push_back(static_cast<char>(0x80 | (cp & 0x3F)));
  } else if (cp <= 0x10FFFF) {
    out.push_back(static_cast<char>(0xF0 | (cp >> 18)));
    out.push_back(static_cast<char>(0x80 | ((cp >> 12) & 0x3F)));
    out.push_back(static_cast<char>(0x80 | ((cp >> 6) & 0x3F)));
    out.push_back(static_cast<char>(0x80 | (cp & 0x3F)));
  } else {
    append_utf8(out, 0xFFFD);
  }
}

/// Scanner over the whole buffer for the indexing pass; tracks the line number.
struct Scanner {
  const std::string& buf;
  const std::string& name;
  std::size_t pos = 0;
  std::uint32_t line = 1;

  [[noreturn]] void fail(const std::string& msg) const { PLUMB_THROW(name << ":" << line << ": " << msg); }

  bool at_end() const { return pos >= buf.size(); }

  void skip_ws() {
    const std::size_t n = buf.size();
    while (pos < n) {
      const char c = buf[pos];
      if (c == '\n') {
        ++line;
        ++pos;
      } else if (is_space(c)) {
        ++pos;
      } else if (c == '/' && pos + 1 < n && buf[pos + 1] == '*') {
        const std::uint32_t start_line = line;
        pos += 2;
        bool closed = false;
        while (pos + 1 < n) {
          if (buf[pos] == '*' && buf[pos + 1] == '/') {
            pos += 2;
            closed = true;
            break;
          }
          if (buf[pos] == '\n') ++line;
          ++pos;
        }
        if (!closed) PLUMB_THROW(name << ":" << start_line << ": unterminated comment");
      } else {
        break;
      }
    }
  }

  bool accept(std::string_view word) {
    skip_ws();
    if (buf.compare(pos, word.size(), word) == 0) {
      pos += word.size();
      return true;
    }
    return false;
  }

  std::string ident() {
    skip_ws();
    const std::size_t start = pos;
    while (pos < buf.size() && is_upper_ident(buf[pos])) ++pos;
    std::string s = buf.substr(start, pos - start);
    for (char& c : s) {
      if (c >= 'a' && c <= 'z') c = static_cast<char>(c - 'a' + 'A');
    }
    return s;
  }

  /// pos is just after '('; advances to the matching ')' (pos left on it).
  void skip_to_matching_paren() {
    const std::size_t n = buf.size();
    const std::uint32_t start_line = line;
    int depth = 1;
    while (pos < n) {
      const char c = buf[pos];
      switch (c) {
        case '\n':
          ++line;
          break;
        case '\'': {
          const std::uint32_t string_line = line;
          ++pos;
          for (;;) {
            if (pos >= n) PLUMB_THROW(name << ":" << string_line << ": unterminated string");
            const char d = buf[pos];
            if (d == '\'') {
              if (pos + 1 < n && buf[pos + 1] == '\'') {
                pos += 2;
                continue;
              }
              break;
            }
            if (d == '\n') ++line;
            ++pos;
          }
          break;
        }
        case '"': {
          ++pos;
          while (pos < n && buf[pos] != '"') ++pos;
          if (pos >= n) fail("unterminated binary value");
          break;
        }
        case '/':
          if (pos + 1 < n && buf[pos + 1] == '*') {
            skip_ws();
            continue;
          }
          break;
        case '(':
          if (++depth > kMaxNesting) fail("lists nested deeper than 64");
          break;
        case ')':
          if (--depth == 0) return;
          break;
        case ';':
          // A ';' outside a string inside an argument list means a truncated/garbled instance.
          fail("';' inside an argument list (unbalanced parentheses)");
        default:
          break;
      }
      ++pos;
    }
    PLUMB_THROW(name << ":" << start_line << ": truncated entity (no closing ')')");
  }
};

/// Decoder for one argument range.
struct ArgParser {
  const std::string& buf;
  std::size_t pos;
  std::size_t end;
  const StepFile& file;
  const StepEntity& entity;

  [[noreturn]] void fail(const std::string& msg) const {
    std::uint32_t line = entity.line;
    const std::size_t stop = std::min(pos, buf.size());
    for (std::size_t i = entity.args_begin; i < stop; ++i) line += buf[i] == '\n' ? 1 : 0;
    PLUMB_THROW(file.name() << ":" << line << ": " << file.type_names()[entity.type] << " #" << entity.id
                            << ": " << msg);
  }

  void skip_ws() {
    while (pos < end) {
      const char c = buf[pos];
      if (is_space(c)) {
        ++pos;
      } else if (c == '/' && pos + 1 < end && buf[pos + 1] == '*') {
        const std::size_t close = buf.find("*/", pos + 2);
        if (close == std::string::npos || close + 2 > end) fail("unterminated comment");
        pos = close + 2;
      } else {
        break;
      }
    }
  }

  /// Parse comma-separated values until `close` (')' at `end` for the top level).
  void parse_items(std::vector<StepValue>& out, int depth) {
    skip_ws();
    if (pos < end && buf[pos] == ')') return;
    if (out.capacity() == 0) out.reserve(depth == 0 ? 10 : 4);
    for (;;) {
      out.emplace_back();
      parse_value(out.back(), depth);
      skip_ws();
      if (pos >= end) return;
      if (buf[pos] == ',') {
        ++pos;
        continue;
      }
      if (buf[pos] == ')') return;
      fail(std::string("unexpected character '") + buf[pos] + "' in argument list");
    }
  }

  void parse_value(StepValue& v, int depth) {
    if (depth > kMaxNesting) fail("lists nested deeper than 64");
    skip_ws();
    if (pos >= end) fail("missing argument");
    const char c = buf[pos];
    if (c == '$') {
      v.kind = StepValue::Kind::kNull;
      ++pos;
    } else if (c == '*') {
      v.kind = StepValue::Kind::kDerived;
      ++pos;
    } else if (c == '#') {
      ++pos;
      std::uint64_t id = 0;
      const std::size_t start = pos;
      while (pos < end && buf[pos] >= '0' && buf[pos] <= '9') {
        id = id * 10 + static_cast<std::uint64_t>(buf[pos] - '0');
        if (id > std::numeric_limits<std::uint32_t>::max()) fail("entity reference out of range");
        ++pos;
      }
      if (pos == start) fail("'#' without a number");
      v.kind = StepValue::Kind::kRef;
      v.ref = static_cast<std::uint32_t>(id);
    } else if (c == '\'') {
      ++pos;
      const std::size_t start = pos;
      for (;;) {
        if (pos >= end) fail("unterminated string");
        if (buf[pos] == '\'') {
          if (pos + 1 < end && buf[pos + 1] == '\'') {
            pos += 2;
            continue;
          }
          break;
        }
        ++pos;
      }
      v.kind = StepValue::Kind::kString;
      if (!decode_step_string(std::string_view(buf).substr(start, pos - start), v.text)) {
        fail("malformed escape in string");
      }
      ++pos;
    } else if (c == '"') {
      ++pos;
      const std::size_t start = pos;
      while (pos < end && buf[pos] != '"') ++pos;
      if (pos >= end) fail("unterminated binary value");
      v.kind = StepValue::Kind::kBinary;
      v.text.assign(buf, start, pos - start);
      ++pos;
    } else if (c == '.') {
      ++pos;
      const std::size_t start = pos;
      while (pos < end && buf[pos] != '.') ++pos;
      if (pos >= end) fail("unterminated enumeration");
      v.kind = StepValue::Kind::kEnum;
      v.text.assign(buf, start, pos - start);
      ++pos;
    } else if (c == '(') {
      ++pos;
      v.kind = StepValue::Kind::kList;
      parse_items(v.items, depth + 1);
      if (pos >= end || buf[pos] != ')') fail("unterminated list");
      ++pos;
    } else if ((c >= '0' && c <= '9') || c == '-' || c == '+') {
      parse_number(v);
    } else if ((c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || c == '_') {
      const std::size_t start = pos;
      while (pos < end && is_upper_ident(buf[pos])) ++pos;
      v.kind = StepValue::Kind::kTyped;
      v.text.assign(buf, start, pos - start);
      for (char& ch : v.text) {
        if (ch >= 'a' && ch <= 'z') ch = static_cast<char>(ch - 'a' + 'A');
      }
      skip_ws();
      if (pos >= end || buf[pos] != '(') fail("typed value '" + v.text + "' without '('");
      ++pos;
      parse_items(v.items, depth + 1);
      if (pos >= end || buf[pos] != ')') fail("unterminated typed value");
      ++pos;
    } else {
      fail(std::string("unexpected character '") + c + "'");
    }
  }

  void parse_number(StepValue& v) {
    std::size_t start = pos;
    bool negative = false;
    if (buf[pos] == '+' || buf[pos] == '-') {
      negative = buf[pos] == '-';
      ++pos;
      start = pos;
    }
    bool is_real = false;
    while (pos < end) {
      const char d = buf[pos];
      if (d >= '0' && d <= '9') {
        ++pos;
      } else if (d == '.' || d == 'E' || d == 'e' || ((d == '-' || d == '+') && (buf[pos - 1] == 'E' || buf[pos - 1] == 'e'))) {
        is_real = true;
        ++pos;
      } else {
        break;
      }
    }
    if (pos == start) fail("malformed number");
    const char* first = buf.data() + start;
    const char* last = buf.data() + pos;
    if (!is_real) {
      std::int64_t value = 0;
      auto [ptr, ec] = std::from_chars(first, last, value);
      if (ec == std::errc::result_out_of_range) {
        is_real = true;  // absurdly long integers degrade to reals
      } else {
        if (ec != std::errc() || ptr != last) fail("malformed integer");
        v.kind = StepValue::Kind::kInteger;
        v.integer = negative ? -value : value;
        v.real = static_cast<double>(v.integer);
        return;
      }
    }
    double value = 0.0;
    auto [ptr, ec] = std::from_chars(first, last, value);
    if (ec == std::errc::result_out_of_range) {
      // Subnormal/overflowing literal: strtod-like saturation.
      value = std::strtod(std::string(first, last).c_str(), nullptr);
    } else if (ec != std::errc() || ptr != last) {
      fail("malformed real '" + std::string(first, last) + "'");
    }
    v.kind = StepValue::Kind::kReal;
    v.real = negative ? -value : value;
  }
};

}  // namespace

double StepValue::number() const {
  if (kind == Kind::kReal || kind == Kind::kInteger) return real;
  if (kind == Kind::kTyped && items.size() == 1) return items[0].number();
  return std::numeric_limits<double>::quiet_NaN();
}

bool decode_step_string(std::string_view raw, std::string& out) {
  out.clear();
  out.reserve(raw.size());
  const std::size_t n = raw.size();
  std::size_t i = 0;
  while (i < n) {
    const char c = raw[i];
    if (c == '\'') {
      out.push_back('\'');
      i += (i + 1 < n && raw[i + 1] == '\'') ? 2 : 1;
      continue;
    }
    if (c != '\\') {
      out.push_back(c);
      ++i;
      continue;
    }
    // Escapes.
    if (i + 1 < n && raw[i + 1] == '\\') {
      out.push_back('\\');
      i += 2;
    } else if (raw.compare(i, 3, "\\X\\") == 0) {
      if (i + 4 >= n) return false;
      const int h = hex_value(raw[i + 3]);
      const int l = hex_value(raw[i + 4]);
      if (h < 0 || l < 0) return false;
      append_utf8(out, static_cast<std::uint32_t>(h * 16 + l));
      i += 5;
    } else if (raw.compare(i, 4, "\\X2\\") == 0 || raw.compare(i, 4, "\\X4\\") == 0) {
      const int width = raw[i + 2] == '2' ? 4 : 8;
      i += 4;
      std::uint32_t pending_high = 0;
      for (;;) {
        if (raw.compare(i, 4, "\\X0\\") == 0) {
          i += 4;
          break;
        }
        if (i + static_cast<std::size_t>(width) > n) return false;
        std::uint32_t cp = 0;
        for (int k = 0; k < width; ++k) {
          const int h = hex_value(raw[i + static_cast<std::size_t>(k)]);
          if (h < 0) return false;
          cp = cp * 16 + static_cast<std::uint32_t>(h);
        }
        i += static_cast<std::size_t>(width);
        if (cp >= 0xD800 && cp < 0xDC00) {  // UTF-16 high surrogate
          pending_high = cp;
          continue;
        }
        if (cp >= 0xDC00 && cp < 0xE000 && pending_high != 0) {
          cp = 0x10000 + ((pending_high - 0xD800) << 10) + (cp - 0xDC00);
        }
        pending_high = 0;
        append_utf8(out, cp);
      }
    } else if (raw.compare(i, 3, "\\S\\") == 0) {
      if (i + 3 >= n) return false;
      append_utf8(out, static_cast<std::uint32_t>(static_cast<unsigned char>(raw[i + 3])) + 128U);
      i += 4;
    } else if (i + 3 < n && raw[i + 1] == 'P' && raw[i + 3] == '\\') {
      i += 4;  // code page switch: ignored
    } else {
      out.push_back('\\');  // lone backslash: keep it
      ++i;
    }
  }
  return true;
}

StepFile StepFile::read(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  PLUMB_CHECK(in.good(), path << ": cannot open file");
  std::ostringstream ss;
  ss << in.rdbuf();
  return parse(ss.str(), path);
}

namespace {

/// The schema a FILE_SCHEMA name belongs to (case-insensitive prefix).
StepSchema schema_of(const std::string& schema_name) {
  std::string upper = schema_name;
  for (char& c : upper) {
    if (c >= 'a' && c <= 'z') c = static_cast<char>(c - 'a' + 'A');
  }
  if (upper.rfind("IFC2X3", 0) == 0) return StepSchema::kIfc2x3;
  if (upper.rfind("IFC4X3", 0) == 0) return StepSchema::kIfc4x3;
  if (upper.rfind("IFC4", 0) == 0) return StepSchema::kIfc4;
  return StepSchema::kUnknown;
}

}  // namespace

/// The indexing pass of StepFile::parse over the whole buffer: the header, the instances of the
/// DATA sections, then the id index.
class StepFile::Parser {
 public:
  explicit Parser(StepFile& f) : f_(f), s_{f.buffer_, f.name_} {}

  /// The magic line and the HEADER section, which gives the schema name.
  void header() {
    const std::string& buf = f_.buffer_;
    // Skip a UTF-8 byte order mark.
    if (buf.compare(0, 3, "\xEF\xBB\xBF") == 0) s_.pos = 3;
    if (!s_.accept("ISO-10303-21;")) s_.fail("not a STEP file (expected 'ISO-10303-21;')");
    if (!s_.accept("HEADER;")) s_.fail("expected 'HEADER;'");
    // Header entities: NAME(args);
    for (;;) {
      s_.skip_ws();
      if (s_.at_end()) s_.fail("truncated header (no ENDSEC)");
      if (s_.accept("ENDSEC;")) break;
      const std::uint32_t line = s_.line;
      const std::string kw = s_.ident();
      if (kw.empty()) s_.fail("malformed header entry");
      s_.skip_ws();
      if (s_.at_end() || buf[s_.pos] != '(') s_.fail("expected '(' after " + kw);
      ++s_.pos;
      const std::size_t begin = s_.pos;
      s_.skip_to_matching_paren();
      const std::size_t end = s_.pos;
      ++s_.pos;
      if (!s_.accept(";")) s_.fail("expected ';' after " + kw);
      if (kw == "FILE_SCHEMA") {
        StepEntity e;
        e.line = line;
        e.args_begin = static_cast<std::uint32_t>(begin);
        e.args_end = static_cast<std::uint32_t>(end);
        f_.type_names_.push_back(kw);
        const auto args = f_.args(e);
        f_.type_names_.clear();
        if (!args.empty() && args[0].is_list() && !args[0].items.empty() &&
            args[0].items[0].kind == StepValue::Kind::kString) {
          f_.schema_name_ = args[0].items[0].text;
        }
      }
    }
  }

  /// The DATA sections up to END-ISO-10303-21.
  void data() {
    const std::string& buf = f_.buffer_;
    bool saw_data = false;
    for (;;) {
      s_.skip_ws();
      if (s_.at_end()) {
        if (!saw_data) s_.fail("no DATA section");
        s_.fail("truncated file (missing ENDSEC / END-ISO-10303-21)");
      }
      if (s_.accept("END-ISO-10303-21;")) break;
      if (!s_.accept("DATA")) s_.fail("expected 'DATA;'");
      s_.skip_ws();
      if (!s_.at_end() && buf[s_.pos] == '(') {  // DATA('name', ...) of edition 3
        ++s_.pos;
        s_.skip_to_matching_paren();
        ++s_.pos;
      }
      if (!s_.accept(";")) s_.fail("expected ';' after DATA");
      saw_data = true;
      for (;;) {
        s_.skip_ws();
        if (s_.at_end()) s_.fail("truncated DATA section (no ENDSEC)");
        if (s_.accept("ENDSEC;")) break;
        instance();
      }
    }
  }

  /// Id index: dense when ids are compact, else a hash map.
  void index() {
    const std::size_t n = f_.entities_.size();
    if (static_cast<std::size_t>(max_id_) <= 4 * n + 4096) {
      f_.dense_index_.assign(static_cast<std::size_t>(max_id_) + 1, -1);
      for (std::size_t i = 0; i < n; ++i) {
        std::int32_t& slot = f_.dense_index_[f_.entities_[i].id];
        if (slot >= 0) duplicate(i);
        slot = static_cast<std::int32_t>(i);
      }
    } else {
      f_.sparse_index_.reserve(n);
      for (std::size_t i = 0; i < n; ++i) {
        if (!f_.sparse_index_.emplace(f_.entities_[i].id, static_cast<std::uint32_t>(i)).second) duplicate(i);
      }
    }
  }

 private:
  /// One instance `#id = TYPE(args);` (or a complex one, `#id = (...);`), indexed, not decoded.
  void instance() {
    const std::string& buf = f_.buffer_;
    if (buf[s_.pos] != '#') s_.fail(std::string("expected '#' at the start of an instance, got '") + buf[s_.pos] + "'");
    StepEntity e;
    e.line = s_.line;
    ++s_.pos;
    std::uint64_t id = 0;
    const std::size_t start = s_.pos;
    while (!s_.at_end() && buf[s_.pos] >= '0' && buf[s_.pos] <= '9') {
      id = id * 10 + static_cast<std::uint64_t>(buf[s_.pos] - '0');
      if (id > 0x7FFFFFFFULL) s_.fail("instance id out of range");
      ++s_.pos;
    }
    if (s_.pos == start) s_.fail("'#' without a number");
    e.id = static_cast<std::uint32_t>(id);
    if (!s_.accept("=")) s_.fail("expected '=' after #" + std::to_string(id));
    s_.skip_ws();
    std::string type;
    if (!s_.at_end() && buf[s_.pos] == '(') {
      type = "";  // complex (multi-leaf) instance: indexed, not decoded
    } else {
      type = s_.ident();
      if (type.empty()) s_.fail("expected an entity type name after #" + std::to_string(id) + "=");
      s_.skip_ws();
    }
    if (s_.at_end() || buf[s_.pos] != '(') s_.fail("expected '(' after " + type);
    ++s_.pos;
    e.args_begin = static_cast<std::uint32_t>(s_.pos);
    s_.skip_to_matching_paren();
    e.args_end = static_cast<std::uint32_t>(s_.pos);
    ++s_.pos;
    if (!s_.accept(";")) s_.fail("expected ';' after instance #" + std::to_string(id));
    auto it = f_.type_lookup_.find(type);
    if (it == f_.type_lookup_.end()) {
      it = f_.type_lookup_.emplace(type, static_cast<std::uint32_t>(f_.type_names_.size())).first;
      f_.type_names_.push_back(type);
    }
    e.type = it->second;
    max_id_ = std::max(max_id_, e.id);
    f_.entities_.push_back(e);
  }

  [[noreturn]] void duplicate(std::size_t i) const {
    PLUMB_THROW(f_.name_ << ":" << f_.entities_[i].line << ": duplicate instance #" << f_.entities_[i].id);
  }

  StepFile& f_;
  Scanner s_;
  std::uint32_t max_id_ = 0;
};

StepFile StepFile::parse(std::string buffer, std::string name) {
  StepFile f;
  f.name_ = std::move(name);
  f.buffer_ = std::move(buffer);
  PLUMB_CHECK(f.buffer_.size() < std::numeric_limits<std::uint32_t>::max(),
              f.name_ << ": file larger than 4 GB is not supported");
  Parser parser(f);
  parser.header();
  f.schema_ = schema_of(f.schema_name_);
  parser.data();
  parser.index();
  return f;
}

std::int64_t StepFile::find(std::uint32_t id) const {
  if (!dense_index_.empty() || sparse_index_.empty()) {
    if (id < dense_index_.size()) return dense_index_[id];
    return -1;
  }
  auto it = sparse_index_.find(id);
  return it == sparse_index_.end() ? -1 : static_cast<std::int64_t>(it->second);
}

const StepEntity& StepFile::entity(std::uint32_t id) const {
  const std::int64_t i = find(id);
  PLUMB_CHECK(i >= 0, name_ << ": reference to missing instance #" << id);
  return entities_[static_cast<std::size_t>(i)];
}

const std::string& StepFile::type_of(std::uint32_t id) const {
  static const std::string kEmpty;
  const std::int64_t i = find(id);
  return i < 0 ? kEmpty : type_names_[entities_[static_cast<std::size_t>(i)].type];
}

std::int64_t StepFile::type_index(std::string_view upper_name) const {
  auto it = type_lookup_.find(std::string(upper_name));
  return it == type_lookup_.end() ? -1 : static_cast<std::int64_t>(it->second);
}

std::vector<std::uint32_t> StepFile::ids_of_type(std::string_view upper_name) const {
  std::vector<std::uint32_t> ids;
  const std::int64_t t = type_index(upper_name);
  if (t < 0) return ids;
  for (const auto& e : entities_) {
    if (e.type == static_cast<std::uint32_t>(t)) ids.push_back(e.id);
  }
  return ids;
}

std::vector<StepValue> StepFile::args(const StepEntity& e) const {
  std::vector<StepValue> out;
  ArgParser p{buffer_, e.args_begin, e.args_end, *this, e};
  p.parse_items(out, 0);
  p.skip_ws();
  if (p.pos != e.args_end) p.fail("trailing characters in argument list");
  return out;
}

std::string StepFile::where(std::uint32_t id) const {
  const std::int64_t i = find(id);
  if (i < 0) return name_ + ": #" + std::to_string(id);
  const auto& e = entities_[static_cast<std::size_t>(i)];
  return name_ + ":" + std::to_string(e.line);
}

}  // namespace plumb::bim
