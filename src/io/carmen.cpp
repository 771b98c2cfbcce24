// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/io/carmen.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <string_view>
#include <system_error>

#include <zlib.h>

#include "plumb/core/error.hpp"

namespace plumb::io {
namespace {

constexpr double kPi = 3.14159265358979323846;

bool is_space(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '\f' || c == '\v'; }

/// Splits one line into white-space separated tokens and converts them, with the file and line
/// in every error.
class Fields {
 public:
  Fields(std::string_view line, const std::string& name, std::size_t line_number)
      : name_(name), line_(line_number) {
    std::size_t i = 0;
    while (i < line.size()) {
      while (i < line.size() && is_space(line[i])) ++i;
      const std::size_t start = i;
      while (i < line.size() && !is_space(line[i])) ++i;
      if (i > start) tokens_.push_back(line.substr(start, i - start));
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
    PLUMB_CHECK(v >= 0.0 && v == std::floor(v) && v <= 1e6,
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
  while (!line.empty() && is_space(line.front())) line.remove_prefix(1);
  if (line.empty() || line.front() == '#') return;
  const Fields f(line, name, line_number);
  const std::string_view type = f.type();
  if (type == "FLASER" || type.substr(0, 8) == "RAWLASER" || type == "ROBOTLASER1") {
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
  } else if (type == "PARAM") {
    f.need(1, 2, "a name and a value");
    log.params[std::string(f.token(1))] = std::string(f.token(2));
  } else {
    ++log.num_skipped;  // NEFF, RLASER, SYNC, TRUEPOS, ...
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

CarmenLog read_carmen(const std::string& path, const CarmenReadSettings& settings) {
  // gzopen reads plain files transparently.
  gzFile file = gzopen(path.c_str(), "rb");
  PLUMB_CHECK(file != nullptr, path << ": cannot open file");
  std::string text;
  std::vector<char> buffer(1 << 16);
  int n = 0;
  while ((n = gzread(file, buffer.data(), static_cast<unsigned>(buffer.size()))) > 0) {
    text.append(buffer.data(), static_cast<std::size_t>(n));
  }
  int err = Z_OK;
  const char* message = n < 0 ? gzerror(file, &err) : nullptr;
  const std::string error_text = message != nullptr ? message : "";
  gzclose(file);
  PLUMB_CHECK(n == 0, path << ": read error after " << text.size() << " bytes: " << error_text);
  return parse_carmen(text, path, settings);
}

Pose2 interpolate_pose2(const Pose2& a, const Pose2& b, double alpha) {
  const Pose2 r = a.ominus().oplus(b);
  return a.oplus(Pose2{alpha * r.x, alpha * r.y, alpha * wrap_angle(r.theta)});
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
