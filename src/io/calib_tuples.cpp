// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/io/calib_tuples.hpp"

#include <array>
#include <cctype>
#include <charconv>
#include <cmath>
#include <fstream>
#include <optional>
#include <sstream>
#include <string_view>
#include <system_error>

#include "plumb/io/input_file.hpp"
#include "plumb/core/error.hpp"
#include "text_tokens.hpp"

namespace plumb::io {
namespace {

/// A parser for one line holding flat JSON objects of numbers, strings, literals and arrays. Several
/// objects may share a line (Censi's l90.tuple concatenates runs without a newline between them).
class LineParser {
 public:
  LineParser(std::string_view line, const std::string& name, int line_number)
      : s_(line), name_(name), line_number_(line_number) {}

  /// True when only white space is left.
  bool at_end() {
    skip_space();
    return pos_ >= s_.size();
  }

  /// Parse the next object of the line.
  CalibrationTuple parse() {
    std::optional<double> T, phi_l, phi_r;
    std::optional<std::array<double, 3>> sm;
    expect('{');
    skip_space();
    if (peek() == '}') fail("empty object");
    while (true) {
      const std::string key = parse_string();
      expect(':');
      skip_space();
      if (key == "T" || key == "phi_l" || key == "phi_r") {
        std::optional<double>& slot = key == "T" ? T : (key == "phi_l" ? phi_l : phi_r);
        if (slot) fail("key \"" + key + "\" appears twice");
        slot = parse_number();
      } else if (key == "sm") {
        if (sm) fail("key \"sm\" appears twice");
        const std::vector<double> values = parse_number_array();
        if (values.size() != 3) fail("\"sm\" must hold 3 numbers [x, y, theta], got " + std::to_string(values.size()));
        sm = std::array<double, 3>{values[0], values[1], values[2]};
      } else {
        skip_value();
      }
      skip_space();
      const char c = next();
      if (c == '}') break;
      if (c != ',') fail(std::string("expected ',' or '}' but found ") + describe(c));
    }
    if (!T) fail("missing key \"T\"");
    if (!phi_l) fail("missing key \"phi_l\"");
    if (!phi_r) fail("missing key \"phi_r\"");
    if (!sm) fail("missing key \"sm\"");
    if (!(*T > 0.0)) fail("interval \"T\" must be > 0, got " + std::to_string(*T));
    CalibrationTuple t;
    t.T = *T;
    t.phi_left = *phi_l;
    t.phi_right = *phi_r;
    t.laser_motion = Pose2{(*sm)[0], (*sm)[1], (*sm)[2]};
    return t;
  }

 private:
  [[noreturn]] void fail(const std::string& what) const {
    PLUMB_THROW(name_ << ':' << line_number_ << ": " << what << " (column " << pos_ + 1 << ")");
  }
  static std::string describe(char c) {
    if (c == '\0') return "end of line";
    return std::string("'") + c + "'";
  }
  void skip_space() {
    while (pos_ < s_.size() && detail::is_space(s_[pos_])) ++pos_;
  }
  char peek() const { return pos_ < s_.size() ? s_[pos_] : '\0'; }
  char next() { return pos_ < s_.size() ? s_[pos_++] : '\0'; }
  void expect(char c) {
    skip_space();
    const char got = peek();
    if (got != c) fail(std::string("expected '") + c + "' but found " + describe(got));
    ++pos_;
  }

  std::string parse_string() {
    expect('"');
    std::string out;
    while (true) {
      if (pos_ >= s_.size()) fail("unterminated string");
      const char c = s_[pos_++];
      if (c == '"') return out;
      if (c == '\\') {
        if (pos_ >= s_.size()) fail("unterminated string");
        out.push_back(s_[pos_++]);  // keys we use have no escapes; keep the escaped char
      } else {
        out.push_back(c);
      }
    }
  }

  double parse_number() {
    skip_space();
    std::size_t end = pos_;
    while (end < s_.size() && (std::isdigit(static_cast<unsigned char>(s_[end])) || s_[end] == '-' ||
                               s_[end] == '+' || s_[end] == '.' || s_[end] == 'e' || s_[end] == 'E'))
      ++end;
    std::string_view token = s_.substr(pos_, end - pos_);
    if (token.empty()) fail(std::string("expected a number but found ") + describe(peek()));
    std::string_view digits = token;
    if (digits.size() > 1 && digits.front() == '+') digits.remove_prefix(1);
    double value = 0.0;
    const auto [ptr, ec] = std::from_chars(digits.data(), digits.data() + digits.size(), value);
    if (ec != std::errc() || ptr != digits.data() + digits.size() || !std::isfinite(value))
      fail("not a finite number: '" + std::string(token) + "'");
    pos_ = end;
    return value;
  }

  std::vector<double> parse_number_array() {
    expect('[');
    std::vector<double> values;
    skip_space();
    if (peek() == ']') {
      ++pos_;
      return values;
    }
    while (true) {
      values.push_back(parse_number());
      skip_space();
      const char c = next();
      if (c == ']') return values;
      if (c != ',') fail(std::string("expected ',' or ']' but found ") + describe(c));
    }
  }

  void skip_scalar() {
    skip_space();
    const char c = peek();
    if (c == '"') {
      parse_string();
    } else if (s_.substr(pos_, 4) == "true" || s_.substr(pos_, 4) == "null") {
      pos_ += 4;
    } else if (s_.substr(pos_, 5) == "false") {
      pos_ += 5;
    } else if (c == '{') {
      fail("nested objects are not supported in a tuple file");
    } else {
      parse_number();
    }
  }

  void skip_value() {
    skip_space();
    if (peek() != '[') {
      skip_scalar();
      return;
    }
    ++pos_;
    skip_space();
    if (peek() == ']') {
      ++pos_;
      return;
    }
    while (true) {
      skip_space();
      if (peek() == '[') fail("nested arrays are not supported in a tuple file");
      skip_scalar();
      skip_space();
      const char c = next();
      if (c == ']') return;
      if (c != ',') fail(std::string("expected ',' or ']' but found ") + describe(c));
    }
  }

  std::string_view s_;
  const std::string& name_;
  int line_number_;
  std::size_t pos_ = 0;
};

}  // namespace

std::vector<CalibrationTuple> parse_calib_tuples(const std::string& text, const std::string& name) {
  std::vector<CalibrationTuple> tuples;
  std::size_t start = 0;
  int line_number = 0;
  while (start <= text.size()) {
    std::size_t end = text.find('\n', start);
    if (end == std::string::npos) end = text.size();
    ++line_number;
    const std::string_view line = detail::trim(std::string_view(text.data() + start, end - start));
    if (!line.empty() && line.front() != '#') {
      LineParser parser(line, name, line_number);
      do {
        tuples.push_back(parser.parse());
      } while (!parser.at_end());
    }
    start = end + 1;
  }
  PLUMB_CHECK(!tuples.empty(), name << ": no calibration tuples in the file");
  return tuples;
}

std::vector<CalibrationTuple> read_calib_tuples(const std::string& path) {
  std::ifstream in = open_input_file(path);
  std::ostringstream buffer;
  buffer << in.rdbuf();
  PLUMB_CHECK(!in.bad(), path << ": read error");
  return parse_calib_tuples(buffer.str(), path);
}

void write_calib_tuples(const std::vector<CalibrationTuple>& tuples, const std::string& path) {
  std::ofstream out(path, std::ios::binary);
  PLUMB_CHECK(out.is_open(), path << ": cannot open file for writing");
  auto put = [&out](double v) {
    std::array<char, 32> buf{};
    const auto [ptr, ec] = std::to_chars(buf.data(), buf.data() + buf.size(), v);
    PLUMB_CHECK(ec == std::errc(), "write_calib_tuples: cannot format " << v);
    out.write(buf.data(), ptr - buf.data());
  };
  for (const CalibrationTuple& t : tuples) {
    out << "{ \"T\": ";
    put(t.T);
    out << ", \"phi_l\": ";
    put(t.phi_left);
    out << ", \"phi_r\": ";
    put(t.phi_right);
    out << ", \"sm\": [ ";
    put(t.laser_motion.x);
    out << ", ";
    put(t.laser_motion.y);
    out << ", ";
    put(t.laser_motion.theta);
    out << " ] }\n";
  }
  out.flush();
  PLUMB_CHECK(out.good(), path << ": write error");
}

}  // namespace plumb::io
