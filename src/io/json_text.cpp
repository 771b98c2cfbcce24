// SPDX-License-Identifier: BSD-3-Clause
#include "json_text.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <iterator>
#include <unordered_set>

#include <nlohmann/json.hpp>

#include "plumb/core/error.hpp"

namespace plumb::io::detail {
namespace {

using Json = nlohmann::json;

/// Where a byte is: its offset in the text and its line and column.
struct Place {
  std::size_t offset = 0;
  TextPosition position;
};

/// Follows the bytes nlohmann's lexer takes, with just enough of JSON's lexical structure to know
/// where the last value token (a string, a number, a literal, '{' or '[') began.
///
/// The parser raises each SAX event right after the lexer has read the token of that event. Only a
/// number is read with one byte of look-ahead, and in valid JSON that byte is white space, ',', ']',
/// '}' or the end, none of which begins a value; so at every event the last value start is where
/// the event's value starts. (Input the parser then rejects may mislead it, but a syntax error is
/// reported at nlohmann's own byte offset, not from here.)
class ValueStarts {
 public:
  void take(char c) {
    const Place here = next_;
    ++next_.offset;
    if (c == '\n') {
      ++next_.position.line;
      next_.position.column = 1;
    } else {
      ++next_.position.column;
    }
    if (in_string_) {
      if (escaped_) {
        escaped_ = false;
      } else if (c == '\\') {
        escaped_ = true;
      } else if (c == '"') {
        in_string_ = false;
      }
      return;
    }
    switch (c) {
      case ' ': case '\t': case '\r': case '\n': case ',': case ':': case '}': case ']':
        in_word_ = false;
        break;
      case '"':
        in_string_ = true;
        in_word_ = false;
        last_ = here;
        break;
      case '{': case '[':
        in_word_ = false;
        last_ = here;
        break;
      default:  // a number or a literal: its first byte starts the value
        if (!in_word_) last_ = here;
        in_word_ = true;
    }
  }

  const Place& last_value() const { return last_; }

 private:
  Place next_, last_;
  bool in_string_ = false, escaped_ = false, in_word_ = false;
};

/// The lexer's input: the bytes of the text, each shown to a ValueStarts as the lexer takes it.
/// nlohmann reads an input iterator one `*it`, `++it` at a time and compares it with the end.
class TrackedBytes {
 public:
  using iterator_category = std::input_iterator_tag;
  using value_type = char;
  using difference_type = std::ptrdiff_t;
  using pointer = const char*;
  using reference = const char&;

  TrackedBytes(const char* p, ValueStarts* starts) : p_(p), starts_(starts) {}

  reference operator*() const { return *p_; }
  TrackedBytes& operator++() {
    starts_->take(*p_);
    ++p_;
    return *this;
  }
  TrackedBytes operator++(int) {
    TrackedBytes before = *this;
    ++*this;
    return before;
  }
  bool operator==(const TrackedBytes& other) const { return p_ == other.p_; }
  bool operator!=(const TrackedBytes& other) const { return p_ != other.p_; }

 private:
  const char* p_;
  ValueStarts* starts_;
};

TextPosition position_of(std::string_view text, std::size_t offset) {
  offset = std::min(offset, text.size());
  const std::string_view before = text.substr(0, offset);
  TextPosition p;
  p.line = 1 + static_cast<std::size_t>(std::count(before.begin(), before.end(), '\n'));
  const std::size_t newline = before.rfind('\n');
  p.column = newline == std::string_view::npos ? offset + 1 : offset - newline;
  return p;
}

/// SAX handler of nlohmann's parser that builds the JsonValue tree, refusing a key that an object
/// already has (nlohmann would keep one of the two silently) and nesting beyond kMaxJsonDepth.
class TreeBuilder {
 public:
  TreeBuilder(std::string_view text, const ValueStarts& starts) : text_(text), starts_(starts) {}

  bool null() { return add(JsonValue::Kind::kNull) != nullptr; }
  bool boolean(bool b) {
    add(JsonValue::Kind::kBool)->boolean = b;
    return true;
  }
  bool number_integer(Json::number_integer_t x) {
    // nlohmann reads "-0" as the integer 0; a double keeps the sign, as from_chars and strtod do.
    const bool negative_zero = x == 0 && text_[starts_.last_value().offset] == '-';
    add(JsonValue::Kind::kNumber)->number = negative_zero ? -0.0 : static_cast<double>(x);
    return true;
  }
  bool number_unsigned(Json::number_unsigned_t x) {
    add(JsonValue::Kind::kNumber)->number = static_cast<double>(x);  // rounds to nearest, as strtod
    return true;
  }
  bool number_float(Json::number_float_t x, const Json::string_t& /*text*/) {
    add(JsonValue::Kind::kNumber)->number = x;
    return true;
  }
  bool string(Json::string_t& s) {
    add(JsonValue::Kind::kString)->string = std::move(s);
    return true;
  }
  bool binary(Json::binary_t& /*b*/) { return true; }  // only the binary formats make these
  bool start_object(std::size_t /*size*/) { return open(JsonValue::Kind::kObject); }
  bool key(Json::string_t& k) {
    Open& object = open_.back();
    // A hash set: a scan of the keys before made an object of n keys cost n^2 / 2 comparisons.
    if (!object.keys.insert(k).second) return fail(starts_.last_value().position, "duplicate key \"" + k + "\"");
    object.name = std::move(k);
    return true;
  }
  bool end_object() { return close(); }
  bool start_array(std::size_t /*size*/) { return open(JsonValue::Kind::kArray); }
  bool end_array() { return close(); }

  bool parse_error(std::size_t byte, const std::string& /*token*/, const Json::exception& e) {
    if (e.id == 406) {
      // A number beyond a double (1e999): nlohmann ends the parse here, before the number's event.
      // It is named by its member, as json_number() names a value that is not finite.
      const std::string& name = open_.empty() ? std::string() : open_.back().name;
      return fail(starts_.last_value().position,
                  name.empty() ? "number beyond the range of a double" : "\"" + name + "\" must be a finite number");
    }
    // nlohmann's message reads "[json.exception.parse_error.101] parse error at line L, column C:
    // WHAT"; the place is given here the same way as for every other error. `byte` counts the bytes
    // read up to and including the one the lexer stopped at.
    std::string what = e.what();
    const std::size_t colon = what.find(": ");
    if (colon != std::string::npos) what.erase(0, colon + 2);
    return fail(position_of(text_, byte == 0 ? 0 : byte - 1), what);
  }

  JsonValue& root() { return root_; }
  const TextPosition& error_position() const { return error_position_; }
  const std::string& error() const { return error_; }

 private:
  /// An array or object being read, with the member name its values are known by: the last key
  /// of an object, and for an array the name of the member holding it.
  struct Open {
    JsonValue* value;
    std::string name;
    std::unordered_set<std::string> keys;
  };

  JsonValue* add(JsonValue::Kind kind) {
    JsonValue* v = &root_;
    if (!open_.empty()) {
      JsonValue& parent = *open_.back().value;
      if (parent.kind == JsonValue::Kind::kObject) {
        parent.object.emplace_back(open_.back().name, JsonValue());
        v = &parent.object.back().second;
      } else {
        v = &parent.array.emplace_back();
      }
    }
    v->kind = kind;
    v->position = starts_.last_value().position;
    return v;
  }

  // A pointer into its parent's vector stays valid while open: only the innermost open value grows.
  bool open(JsonValue::Kind kind) {
    if (open_.size() == kMaxJsonDepth) {
      return fail(starts_.last_value().position,
                  "nesting too deep (more than " + std::to_string(kMaxJsonDepth) + " arrays and objects)");
    }
    std::string name = open_.empty() ? std::string() : open_.back().name;
    open_.push_back({add(kind), std::move(name), {}});
    return true;
  }

  bool close() {
    open_.pop_back();
    return true;
  }

  bool fail(const TextPosition& where, std::string message) {
    error_position_ = where;
    error_ = std::move(message);
    return false;
  }

  std::string_view text_;
  const ValueStarts& starts_;
  JsonValue root_;
  std::vector<Open> open_;
  TextPosition error_position_;
  std::string error_ = "not valid JSON";  // every refusal sets its own; this only if nlohmann stops unasked
};

}  // namespace

const JsonValue* JsonValue::find(std::string_view key) const {
  for (const auto& [k, v] : object) {
    if (k == key) return &v;
  }
  return nullptr;
}

JsonValue parse_json(std::string_view text, const std::string& name) {
  ValueStarts starts;
  TreeBuilder builder(text, starts);
  const bool ok = Json::sax_parse(TrackedBytes(text.data(), &starts), TrackedBytes(text.data() + text.size(), &starts),
                                  &builder, Json::input_format_t::json, /*strict=*/true, /*ignore_comments=*/false);
  if (!ok) {
    const TextPosition& p = builder.error_position();
    PLUMB_THROW(name << ':' << p.line << ':' << p.column << ": " << builder.error());
  }
  return std::move(builder.root());
}

void fail_at(const std::string& name, const JsonValue& value, const std::string& message) {
  PLUMB_THROW(name << ':' << value.position.line << ':' << value.position.column << ": " << message);
}

double json_number(const std::string& name, const JsonValue& value, std::string_view key) {
  if (value.kind != JsonValue::Kind::kNumber) fail_at(name, value, "\"" + std::string(key) + "\" must be a number");
  // parse_json refuses an infinity already; a tree built some other way might hold one.
  if (!std::isfinite(value.number)) fail_at(name, value, "\"" + std::string(key) + "\" must be a finite number");
  return value.number;
}

std::string json_string(const std::string& name, const JsonValue& value, std::string_view key) {
  if (value.kind != JsonValue::Kind::kString) fail_at(name, value, "\"" + std::string(key) + "\" must be a string");
  return value.string;
}

std::vector<double> json_numbers(const std::string& name, const JsonValue& value, std::string_view key) {
  if (value.kind != JsonValue::Kind::kArray) {
    fail_at(name, value, "\"" + std::string(key) + "\" must be an array of numbers");
  }
  std::vector<double> out;
  out.reserve(value.array.size());
  for (const JsonValue& e : value.array) out.push_back(json_number(name, e, key));
  return out;
}

void append_json_string(std::string& out, std::string_view s) {
  out += Json(std::string(s)).dump(-1, ' ', /*ensure_ascii=*/false, Json::error_handler_t::replace);
}

}  // namespace plumb::io::detail
