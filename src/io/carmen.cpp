// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/io/carmen.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <string_view>
#include <system_error>

#include <zlib.h>

#include "plumb/core/error.hpp"
#include "detail_cloud_io.hpp"
#include "text_tokens.hpp"

namespace plumb::io {
namespace {

/// Largest beam or remission count a message may declare.
constexpr double kMaxCount = 1e6;
/// Most fields a message can have: ROBOTLASER1 with kMaxCount beams and as many remissions plus its
/// 24 other fields. Lines are split only up to this, so a line of millions of tokens costs no more
/// memory than the largest valid message (each field is a 16-byte view of the text).
constexpr std::size_t kMaxFields = 2 * static_cast<std::size_t>(kMaxCount) + 24;

/// Splits one line into white-space separated tokens and converts them, with the file and line
/// in every error.
class Fields {
 public:
  Fields(std::string_view line, const std::string& name, std::size_t line_number)
      : name_(name), line_(line_number) {
    std::size_t i = 0;
    for (std::string_view token = detail::next_token(line, i); !token.empty(); token = detail::next_token(line, i)) {
      PLUMB_CHECK(tokens_.size() < kMaxFields, name_ << ":" << line_ << ": " << tokens_.front() << ": more than "
                                                     << kMaxFields << " fields, more than any CARMEN message has");
      tokens_.push_back(token);
    }
  }

  std::size_t size() const { return tokens_.size(); }
  std::string_view token(std::size_t i) const { return tokens_[i]; }
  std::string_view type() const { return tokens_.front(); }

  /// Throw unless at least `n` fields remain after position `pos`.
  void need(std::size_t pos, std::size_t n, const char* what) const {
    PLUMB_CHECK(pos + n <= tokens_.size(), name_ << ":" << line_ << ": " << type() << ": expected "
                                                 << what << " at field " << pos + 1 << ", line has only "
                                                 << tokens_.size() << " fields");
  }

  /// Throw unless the line has exactly `n` fields.
  void expect_size(std::size_t n) const {
    PLUMB_CHECK(tokens_.size() == n, name_ << ":" << line_ << ": " << type() << ": expected " << n
                                           << " fields, found " << tokens_.size());
  }

  double number(std::size_t i) const {
    need(i, 1, "a number");
    std::string_view t = tokens_[i];
    if (!t.empty() && t.front() == '+') t.remove_prefix(1);
    double v = 0.0;
    const auto [ptr, ec] = std::from_chars(t.data(), t.data() + t.size(), v);
    // "inf"/"nan" readings are accepted by from_chars; they become invalid beams downstream.
    PLUMB_CHECK(ec == std::errc() && ptr == t.data() + t.size(),
                name_ << ":" << line_ << ": " << type() << ": field " << i + 1 << " ('"
                      << tokens_[i] << "') is not a number");
    return v;
  }

  /// A finite number (poses, timestamps, angles).
  double finite(std::size_t i) const {
    const double v = number(i);
    PLUMB_CHECK(std::isfinite(v), name_ << ":" << line_ << ": " << type() << ": field " << i + 1
                                        << " must be finite");
    return v;
  }

  std::size_t count(std::size_t i, const char* what) const {
    const double v = finite(i);
    PLUMB_CHECK(v >= 0.0 && v == std::floor(v) && v <= kMaxCount,
                name_ << ":" << line_ << ": " << type() << ": bad " << what << " '" << tokens_[i]
                      << "' at field " << i + 1);
    return static_cast<std::size_t>(v);
  }

  Pose2 pose(std::size_t i) const { return {finite(i), finite(i + 1), finite(i + 2)}; }

 private:
  const std::string& name_;
  std::size_t line_;
  std::vector<std::string_view> tokens_;
};

void read_ranges(const Fields& f, std::size_t first, std::size_t n, LaserScan& scan) {
  f.need(first, n, "range readings");
  scan.ranges.resize(n);
  for (std::size_t i = 0; i < n; ++i) scan.ranges[i] = static_cast<float>(f.number(first + i));
}

void parse_flaser(const Fields& f, const CarmenReadSettings& settings, CarmenLaser& laser) {
  laser.kind = CarmenLaserKind::kFlaser;
  const std::size_t n = f.count(1, "beam count");
  f.expect_size(2 + n + 9);
  read_ranges(f, 2, n, laser.scan);
  const std::size_t p = 2 + n;
  laser.pose = f.pose(p);
  laser.odom_pose = f.pose(p + 3);
  laser.ipc_timestamp = f.finite(p + 6);
  laser.logger_timestamp = f.finite(p + 8);
  laser.scan.angle_min = -0.5 * kPi;
  laser.scan.angle_increment = n < 2 ? 0.0 : (n % 2 == 0 ? kPi / n : kPi / (n - 1));
  laser.scan.range_max = settings.flaser_range_max;
}

/// RAWLASER* and ROBOTLASER1 share the head; returns the index of the first field after the
/// remissions.
std::size_t parse_laser_head(const Fields& f, const CarmenReadSettings& settings, CarmenLaser& laser) {
  f.need(1, 8, "the laser header");
  const double start_angle = f.finite(2);
  const double resolution = f.finite(4);
  const double max_range = f.finite(5);
  const std::size_t n = f.count(8, "beam count");
  read_ranges(f, 9, n, laser.scan);
  const std::size_t m = f.count(9 + n, "remission count");
  f.need(10 + n, m, "remission values");
  laser.scan.angle_min = start_angle;
  laser.scan.angle_increment = resolution;
  laser.scan.range_max = std::min(max_range > 0.0 ? max_range : settings.flaser_range_max,
                                  settings.flaser_range_max);
  return 10 + n + m;
}

void parse_rawlaser(const Fields& f, const CarmenReadSettings& settings, CarmenLaser& laser) {
  laser.kind = CarmenLaserKind::kRawLaser;
  const std::size_t p = parse_laser_head(f, settings, laser);
  f.expect_size(p + 3);
  laser.ipc_timestamp = f.finite(p);
  laser.logger_timestamp = f.finite(p + 2);
}

void parse_robotlaser(const Fields& f, const CarmenReadSettings& settings, CarmenLaser& laser) {
  laser.kind = CarmenLaserKind::kRobotLaser;
  const std::size_t p = parse_laser_head(f, settings, laser);
  f.expect_size(p + 14);
  laser.pose = f.pose(p);
  laser.odom_pose = f.pose(p + 3);
  laser.ipc_timestamp = f.finite(p + 11);
  laser.logger_timestamp = f.finite(p + 13);
}

void parse_line(std::string_view line, std::size_t line_number, const std::string& name,
                const CarmenReadSettings& settings, CarmenLog& log) {
  line = detail::trim(line);
  if (line.empty() || line.front() == '#') return;
  std::size_t type_end = 0;
  const std::string_view type = detail::next_token(line, type_end);
  const bool laser_message = type == "FLASER" || type.substr(0, 8) == "RAWLASER" || type == "ROBOTLASER1";
  if (!laser_message && type != "ODOM" && type != "PARAM") {
    ++log.num_skipped;  // NEFF, RLASER, SYNC, TRUEPOS, ...: not split, whatever their length
    return;
  }
  const Fields f(line, name, line_number);
  if (laser_message) {
    CarmenLaser laser;
    laser.line = line_number;
    laser.num_odometry_before = log.odometry.size();
    if (type == "FLASER") {
      parse_flaser(f, settings, laser);
    } else if (type == "ROBOTLASER1") {
      parse_robotlaser(f, settings, laser);
    } else {
      parse_rawlaser(f, settings, laser);
    }
    laser.scan.stamp = laser.ipc_timestamp;
    log.lasers.push_back(std::move(laser));
  } else if (type == "ODOM") {
    f.expect_size(10);
    CarmenOdometry odom;
    odom.pose = f.pose(1);
    odom.tv = f.finite(4);
    odom.rv = f.finite(5);
    odom.accel = f.finite(6);
    odom.ipc_timestamp = f.finite(7);
    odom.logger_timestamp = f.finite(9);
    odom.line = line_number;
    if (odom.ipc_timestamp == 0.0) {
      ++log.num_repeated_odometry;  // a repeat of the corrected pose (SOURCES.md)
    } else {
      log.odometry.push_back(odom);
    }
  } else {
    f.need(1, 2, "a name and a value");
    log.params[std::string(f.token(1))] = std::string(f.token(2));
  }
}

}  // namespace

CarmenLog parse_carmen(const std::string& text, const std::string& name,
                       const CarmenReadSettings& settings) {
  CarmenLog log;
  std::size_t line_number = 0, start = 0;
  while (start < text.size()) {
    std::size_t end = text.find('\n', start);
    if (end == std::string::npos) end = text.size();
    ++line_number;
    parse_line(std::string_view(text).substr(start, end - start), line_number, name, settings, log);
    start = end + 1;
  }
  return log;
}

namespace {

bool is_gzip(const char* data, std::size_t size) {
  return size >= 2 && static_cast<unsigned char>(data[0]) == 0x1f && static_cast<unsigned char>(data[1]) == 0x8b;
}

/// Inflate every gzip member of `data` in turn, as gzread() does; at most `max_bytes` of text.
std::string gunzip(const char* data, std::size_t size, const std::string& name, std::size_t max_bytes) {
  z_stream z{};
  PLUMB_CHECK(inflateInit2(&z, 16 + MAX_WBITS) == Z_OK, name << ": cannot initialise zlib");
  std::string text;
  std::vector<char> out(1 << 16);
  std::size_t consumed = 0;  // input bytes handed to zlib so far
  std::string error;
  for (;;) {
    if (z.avail_in == 0 && consumed < size) {
      // avail_in is 32 bits wide: feed inputs of 4 GiB and more in pieces.
      const std::size_t piece = std::min<std::size_t>(size - consumed, 1u << 30);
      z.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(data + consumed));
      z.avail_in = static_cast<uInt>(piece);
      consumed += piece;
    }
    z.next_out = reinterpret_cast<Bytef*>(out.data());
    z.avail_out = static_cast<uInt>(out.size());
    const int ret = inflate(&z, Z_NO_FLUSH);
    text.append(out.data(), out.size() - z.avail_out);
    if (text.size() > max_bytes) {
      error = "inflates to more than " + std::to_string(max_bytes) +
              " bytes of text (CarmenReadSettings::max_inflated_bytes)";
      break;
    }
    if (ret == Z_STREAM_END) {
      const std::size_t rest = z.avail_in + (size - consumed);
      const std::size_t at = size - rest;
      if (!is_gzip(data + at, rest)) break;  // the end, or trailing bytes gzread() ignores too
      inflateReset(&z);
      continue;
    }
    if (ret == Z_OK) continue;
    if (ret == Z_BUF_ERROR && z.avail_in == 0 && consumed == size) {
      error = "unexpected end of the gzip data (truncated file?)";
    } else {
      error = z.msg != nullptr ? z.msg : "zlib error " + std::to_string(ret);
    }
    break;
  }
  const std::size_t at = size - (z.avail_in + (size - consumed));
  inflateEnd(&z);
  PLUMB_CHECK(error.empty(), name << ": gzip byte " << at << ": " << error << " (after " << text.size()
                                  << " bytes of text)");
  return text;
}

}  // namespace

CarmenLog read_carmen_buffer(const char* data, std::size_t size, const std::string& name,
                             const CarmenReadSettings& settings) {
  if (is_gzip(data, size)) {
    return parse_carmen(gunzip(data, size, name, settings.max_inflated_bytes), name, settings);
  }
  return parse_carmen(std::string(data, size), name, settings);
}

CarmenLog read_carmen(const std::string& path, const CarmenReadSettings& settings) {
  const std::vector<char> data = cloud_detail::slurp_file(path);
  return read_carmen_buffer(data.data(), data.size(), path, settings);
}

std::vector<Pose2> raw_odometry_at_lasers(const CarmenLog& log) {
  std::vector<Pose2> out;
  if (log.lasers.empty()) return out;
  PLUMB_CHECK(!log.odometry.empty(), "raw_odometry_at_lasers: the log has " << log.lasers.size()
                                         << " laser messages but no raw ODOM message");
  out.reserve(log.lasers.size());
  const auto& odom = log.odometry;
  for (const CarmenLaser& laser : log.lasers) {
    const std::size_t next = laser.num_odometry_before;  // first ODOM after the laser
    const double t = laser.ipc_timestamp;
    if (next == 0) {
      out.push_back(odom.front().pose);
    } else if (next >= odom.size()) {
      out.push_back(odom.back().pose);
    } else {
      const CarmenOdometry& a = odom[next - 1];
      const CarmenOdometry& b = odom[next];
      if (a.ipc_timestamp <= t && t <= b.ipc_timestamp && b.ipc_timestamp > a.ipc_timestamp) {
        const double alpha = (t - a.ipc_timestamp) / (b.ipc_timestamp - a.ipc_timestamp);
        out.push_back(interpolate_pose2(a.pose, b.pose, alpha));
      } else {
        out.push_back(a.pose);  // stamps do not bracket the scan: the last message before it
      }
    }
  }
  return out;
}

}  // namespace plumb::io
