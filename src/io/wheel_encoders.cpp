// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/io/wheel_encoders.hpp"

#include <array>
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

/// Fields are separated by any run of these (a comma between spaces is one separator).
bool is_separator(char c) { return c == ',' || c == ';' || c == ' ' || c == '\t' || c == '\r'; }

std::optional<double> to_number(std::string_view s) {
  if (!s.empty() && s.front() == '+') s.remove_prefix(1);
  double v = 0.0;
  const auto [ptr, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (ec != std::errc() || ptr != s.data() + s.size()) return std::nullopt;
  return v;
}

}  // namespace

std::vector<WheelEncoderReading> parse_wheel_encoders(const std::string& text, const std::string& name,
                                                      const WheelEncoderReadSettings& settings) {
  PLUMB_CHECK(std::isfinite(settings.ticks_per_revolution) && settings.ticks_per_revolution >= 0.0,
              name << ": ticks_per_revolution = " << settings.ticks_per_revolution
                   << " must be 0 (angles in rad) or positive");
  std::vector<WheelEncoderReading> out;
  bool header_allowed = true;
  std::size_t line_number = 0;
  std::size_t pos = 0;
  while (pos < text.size()) {
    std::size_t end = text.find('\n', pos);
    if (end == std::string::npos) end = text.size();
    const std::string_view line(text.data() + pos, end - pos);
    pos = end + 1;
    ++line_number;
    const std::vector<std::string_view> fields = detail::split_tokens(line, is_separator);
    if (fields.empty() || fields.front().front() == '#') continue;
    std::array<double, 3> v{};
    bool numeric = fields.size() >= 3;
    for (std::size_t f = 0; f < 3 && f < fields.size(); ++f) {
      const std::optional<double> x = to_number(fields[f]);
      if (!x) {
        numeric = false;
        break;
      }
      v[f] = *x;
    }
    if (!numeric && header_allowed && !to_number(fields.front())) {  // a header line such as stamp,left,right
      header_allowed = false;
      continue;
    }
    header_allowed = false;
    PLUMB_CHECK(fields.size() >= 3, name << ":" << line_number << ": expected 3 fields (stamp, left, right), found "
                                         << fields.size());
    PLUMB_CHECK(numeric, name << ":" << line_number << ": fields must be numbers (stamp, left, right)");
    PLUMB_CHECK(std::isfinite(v[0]) && std::isfinite(v[1]) && std::isfinite(v[2]),
                name << ":" << line_number << ": non-finite value");
    PLUMB_CHECK(out.empty() || v[0] > out.back().stamp,
                name << ":" << line_number << ": stamp " << v[0] << " does not increase (previous "
                     << out.back().stamp << ")");
    const WheelEncoderReading reading =
        settings.ticks_per_revolution > 0.0
            ? WheelEncoderReading::from_ticks(v[0], v[1], v[2], settings.ticks_per_revolution)
            : WheelEncoderReading{v[0], v[1], v[2]};
    // 2 pi ticks / ticks_per_revolution overflows for counts near the largest double.
    PLUMB_CHECK(std::isfinite(reading.left) && std::isfinite(reading.right),
                name << ":" << line_number << ": tick counts (" << v[1] << ", " << v[2]
                     << ") are too large to convert to angles at " << settings.ticks_per_revolution
                     << " ticks per revolution");
    out.push_back(reading);
  }
  PLUMB_CHECK(!out.empty(), name << ": no wheel encoder reading");
  return out;
}

std::vector<WheelEncoderReading> read_wheel_encoders(const std::string& path,
                                                     const WheelEncoderReadSettings& settings) {
  std::ifstream in = open_input_file(path);
  std::ostringstream buffer;
  buffer << in.rdbuf();
  PLUMB_CHECK(!in.bad(), path << ": read error");
  return parse_wheel_encoders(buffer.str(), path, settings);
}

void write_wheel_encoders(const std::vector<WheelEncoderReading>& readings, const std::string& path) {
  std::ofstream out(path, std::ios::binary);
  PLUMB_CHECK(out.is_open(), path << ": cannot open file for writing");
  auto put = [&out](double v) {
    std::array<char, 32> buf{};
    const auto [ptr, ec] = std::to_chars(buf.data(), buf.data() + buf.size(), v);
    PLUMB_CHECK(ec == std::errc(), "write_wheel_encoders: cannot format " << v);
    out.write(buf.data(), ptr - buf.data());
  };
  out << "stamp,left,right\n";
  for (const WheelEncoderReading& r : readings) {
    put(r.stamp);
    out << ',';
    put(r.left);
    out << ',';
    put(r.right);
    out << '\n';
  }
  out.flush();
  PLUMB_CHECK(out.good(), path << ": write error");
}

}  // namespace plumb::io
