// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief Private helper of the io readers: strict JSON text (RFC 8259, lexed by nlohmann_json) read
///        into a small tree whose every value knows the line and column where it starts, so that a
///        reader names `file:line:column` for a wrong type or value as it does for a syntax error.
///        Not installed; not part of the API.

#include <cstddef>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace plumb::io::detail {

/// 1-based line and column of a place in a text; columns count bytes.
struct TextPosition {
  std::size_t line = 1;
  std::size_t column = 1;
};

/// One JSON value and where it starts in the text.
struct JsonValue {
  enum class Kind { kNull, kBool, kNumber, kString, kArray, kObject };
  Kind kind = Kind::kNull;
  bool boolean = false;
  double number = 0.0;  ///< every JSON number, integers too, as the nearest double (finite)
  std::string string;   ///< UTF-8
  std::vector<JsonValue> array;
  std::vector<std::pair<std::string, JsonValue>> object;  ///< members in text order; no key twice
  TextPosition position;

  /// The member `key` of an object; nullptr when there is none or this is not an object.
  const JsonValue* find(std::string_view key) const;
};

/// Most arrays and objects parse_json accepts inside each other: a bound on the reader's work per
/// byte and on the recursion of whatever walks the tree.
constexpr std::size_t kMaxJsonDepth = 64;

/// Parses `text` as one JSON value in time linear in its length. Throws plumb::Error
/// "NAME:LINE:COLUMN: what" for
///  - a syntax error (nlohmann's message, at the byte where its lexer stopped),
///  - a key that occurs twice in one object (at the second one),
///  - a number beyond the range of a double, such as 1e999 ("\"KEY\" must be a finite number", KEY
///    the member it is, or is in an array of, as json_number() would say),
///  - arrays and objects nested deeper than kMaxJsonDepth.
JsonValue parse_json(std::string_view text, const std::string& name);

/// Throws plumb::Error "NAME:LINE:COLUMN: message" at the start of `value`.
[[noreturn]] void fail_at(const std::string& name, const JsonValue& value, const std::string& message);

/// `value` as a number, which the member `key` must be; otherwise throws at the value naming `key`.
double json_number(const std::string& name, const JsonValue& value, std::string_view key);

/// `value` as a string, which the member `key` must be; otherwise throws at the value naming `key`.
std::string json_string(const std::string& name, const JsonValue& value, std::string_view key);

/// `value` as an array of numbers, which the member `key` must be; otherwise throws at the value
/// (or the entry) naming `key`.
std::vector<double> json_numbers(const std::string& name, const JsonValue& value, std::string_view key);

/// Appends `s` to `out` as a JSON string (quoted, escaped; other UTF-8 left as it is). Bytes that are
/// not UTF-8 become U+FFFD: written raw they would make a file no JSON reader takes, parse_json
/// included, while a C++ string may hold any bytes (a file name, say).
void append_json_string(std::string& out, std::string_view s);

}  // namespace plumb::io::detail
