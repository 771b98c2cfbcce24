// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief Private helpers of the text readers in io: white space, trimming and splitting of a line
///        into tokens (runs of separators are one break) or into CSV fields (every delimiter is a
///        break, so empty fields are kept). Views into the caller's text, no copies. Not installed;
///        not part of the API.

#include <cstddef>
#include <string_view>
#include <vector>

namespace plumb::io::detail {

/// White space as the C locale's isspace has it: ' ', '\t', '\n', '\v', '\f', '\r'.
inline bool is_space(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '\f' || c == '\v'; }

/// The blanks around a CSV field: ' ', '\t' and the '\r' of a CRLF line end. Narrower than
/// is_space on purpose: the frame dump's CSV files have always refused '\f' and '\v' in a number.
inline bool is_blank(char c) { return c == ' ' || c == '\t' || c == '\r'; }

/// `s` without the leading and trailing characters for which `space(c)` holds.
template <class Space>
std::string_view trim(std::string_view s, Space&& space) {
  while (!s.empty() && space(s.front())) s.remove_prefix(1);
  while (!s.empty() && space(s.back())) s.remove_suffix(1);
  return s;
}

/// `s` without leading and trailing white space (is_space).
inline std::string_view trim(std::string_view s) { return trim(s, is_space); }

/// The next token of `line` at or after `i`: skips separators (`sep(c)`), then takes the run of
/// other characters; `i` ends just after it. Empty when only separators are left.
template <class Sep>
std::string_view next_token(std::string_view line, std::size_t& i, Sep&& sep) {
  while (i < line.size() && sep(line[i])) ++i;
  const std::size_t start = i;
  while (i < line.size() && !sep(line[i])) ++i;
  return line.substr(start, i - start);
}

/// The next white-space separated token of `line` at or after `i` (see above).
inline std::string_view next_token(std::string_view line, std::size_t& i) { return next_token(line, i, is_space); }

/// All tokens of `line` between runs of separators (`sep(c)`); never an empty token.
template <class Sep>
std::vector<std::string_view> split_tokens(std::string_view line, Sep&& sep) {
  std::vector<std::string_view> out;
  std::size_t i = 0;
  for (std::string_view token = next_token(line, i, sep); !token.empty(); token = next_token(line, i, sep)) {
    out.push_back(token);
  }
  return out;
}

/// All white-space separated tokens of `line`.
inline std::vector<std::string_view> split_tokens(std::string_view line) { return split_tokens(line, is_space); }

/// CSV fields: `line` cut at every `delimiter` (so "a,,b" has three fields and "" has one), each
/// field trimmed of blanks (is_blank). No quoting: the formats read with it have none.
inline std::vector<std::string_view> split_fields(std::string_view line, char delimiter = ',') {
  std::vector<std::string_view> fields;
  std::size_t start = 0;
  for (;;) {
    const std::size_t end = line.find(delimiter, start);
    fields.push_back(trim(line.substr(start, end == std::string_view::npos ? std::string_view::npos : end - start),
                          is_blank));
    if (end == std::string_view::npos) return fields;
    start = end + 1;
  }
}

}  // namespace plumb::io::detail
