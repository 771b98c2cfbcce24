// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/io/trajectory.hpp"

#include <charconv>
#include <cmath>
#include <fstream>
#include <sstream>
#include <string_view>
#include <system_error>

#include <Eigen/SVD>

#include "plumb/core/error.hpp"
#include "plumb/io/input_file.hpp"
#include "text_tokens.hpp"

namespace plumb::io {
namespace {

/// One line of a text with its 1-based number, trimmed; comment and blank lines are skipped.
class LineReader {
 public:
  LineReader(const std::string& text, const std::string& name) : name_(name), text_(text) {}

  /// Next data line (trimmed, not blank, not a comment); false at the end of the text.
  bool next(std::string_view& line) {
    while (pos_ < text_.size()) {
      std::size_t end = text_.find('\n', pos_);
      if (end == std::string_view::npos) end = text_.size();
      const std::string_view view = detail::trim(text_.substr(pos_, end - pos_));
      pos_ = end + 1;
      ++line_number_;
      if (view.empty() || view.front() == '#') continue;
      line = view;
      return true;
    }
    return false;
  }

  std::size_t line_number() const { return line_number_; }
  const std::string& path() const { return name_; }

 private:
  const std::string& name_;
  std::string_view text_;
  std::size_t pos_ = 0;
  std::size_t line_number_ = 0;
};

std::string read_text(const std::string& path) {
  std::ifstream in = open_input_file(path);  // names a directory or a missing file as such
  std::ostringstream buffer;
  buffer << in.rdbuf();
  PLUMB_CHECK(!in.bad(), path << ": read error");
  return buffer.str();
}

/// Split on spaces, tabs and commas and parse every field as a finite double.
std::vector<double> parse_fields(std::string_view line, const LineReader& reader) {
  std::vector<double> values;
  std::size_t pos = 0;
  const auto separator = [](char c) { return detail::is_space(c) || c == ','; };
  for (std::string_view token = detail::next_token(line, pos, separator); !token.empty();
       token = detail::next_token(line, pos, separator)) {
    // from_chars does not take a leading '+'; accept it as strtod would.
    std::string_view digits = token;
    if (digits.size() > 1 && digits.front() == '+') digits.remove_prefix(1);
    double value = 0.0;
    const auto [ptr, ec] = std::from_chars(digits.data(), digits.data() + digits.size(), value);
    PLUMB_CHECK(ec == std::errc() && ptr == digits.data() + digits.size() && std::isfinite(value),
                reader.path() << ':' << reader.line_number() << ": field " << values.size() + 1
                              << " is not a finite number: '" << token << "'");
    values.push_back(value);
  }
  return values;
}

void check_field_count(const std::vector<double>& values, std::size_t expected, const char* format,
                       const LineReader& reader) {
  PLUMB_CHECK(values.size() == expected, reader.path() << ':' << reader.line_number() << ": expected "
                                                       << expected << " fields (" << format << "), got "
                                                       << values.size());
}

/// Stamps must increase line by line (when the settings ask for it); remembers the last one.
class StampOrder {
 public:
  explicit StampOrder(const TrajectoryReadSettings& settings) : enabled_(settings.require_increasing_stamps) {}

  void check(double stamp, const LineReader& reader) {
    PLUMB_CHECK(!enabled_ || previous_line_ == 0 || stamp > previous_,
                reader.path() << ':' << reader.line_number() << ": stamp " << stamp
                              << (stamp == previous_ ? " repeats" : " is earlier than")
                              << " the stamp of line " << previous_line_ << " (" << previous_
                              << "); stamps must strictly increase");
    previous_ = stamp;
    previous_line_ = reader.line_number();
  }

 private:
  bool enabled_;
  double previous_ = 0.0;
  std::size_t previous_line_ = 0;
};

void check_position(const Eigen::Vector3d& p, const TrajectoryReadSettings& settings, const LineReader& reader) {
  PLUMB_CHECK(p.cwiseAbs().maxCoeff() <= settings.max_abs_coordinate,
              reader.path() << ':' << reader.line_number() << ": position (" << p.x() << ", " << p.y() << ", "
                            << p.z() << ") is beyond " << settings.max_abs_coordinate
                            << " m from the origin (not a plausible coordinate in metres)");
}

// Shortest decimal text that parses back to the same double.
void append_double(std::string& out, double value) {
  char buffer[32];
  const auto [ptr, ec] = std::to_chars(buffer, buffer + sizeof(buffer), value);
  PLUMB_CHECK(ec == std::errc(), "write_trajectory: cannot format " << value);
  out.append(buffer, ptr);
}

void write_text(const std::string& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  PLUMB_CHECK(out.is_open(), path << ": cannot open file for writing");
  out << text;
  out.flush();
  PLUMB_CHECK(out.good(), path << ": write failed");
}

}  // namespace

Trajectory read_tum(const std::string& path, const TrajectoryReadSettings& settings) {
  return parse_tum(read_text(path), path, settings);
}

Trajectory parse_tum(const std::string& text, const std::string& path, const TrajectoryReadSettings& settings) {
  LineReader reader(text, path);
  StampOrder order(settings);
  Trajectory trajectory;
  std::string_view line;
  while (reader.next(line)) {
    const std::vector<double> v = parse_fields(line, reader);
    check_field_count(v, 8, "stamp tx ty tz qx qy qz qw", reader);
    order.check(v[0], reader);
    check_position(Eigen::Vector3d(v[1], v[2], v[3]), settings, reader);
    Eigen::Quaterniond q(v[7], v[4], v[5], v[6]);  // (w, x, y, z)
    const double norm = q.norm();
    PLUMB_CHECK(std::abs(norm - 1.0) <= settings.max_quaternion_norm_error,
                path << ':' << reader.line_number() << ": quaternion (" << v[4] << ", " << v[5] << ", "
                     << v[6] << ", " << v[7] << ") has norm " << norm << ", not 1 (tolerance "
                     << settings.max_quaternion_norm_error << ")");
    q.coeffs() /= norm;
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = q.toRotationMatrix();
    T.translation() = Eigen::Vector3d(v[1], v[2], v[3]);
    trajectory.push_back(v[0], T);
  }
  PLUMB_CHECK(!trajectory.empty(), path << ": no poses in file (empty or only comments)");
  return trajectory;
}

void write_tum(const Trajectory& trajectory, const std::string& path) {
  trajectory.check_consistent("write_tum");
  PLUMB_CHECK(trajectory.has_stamps() || trajectory.empty(),
              "write_tum: " << path << ": the TUM format needs a stamp per pose");
  std::string text = "# timestamp tx ty tz qx qy qz qw\n";
  for (std::size_t i = 0; i < trajectory.size(); ++i) {
    const Eigen::Isometry3d& T = trajectory.poses[i];
    Eigen::Quaterniond q(T.linear());
    q.normalize();
    const double values[8] = {trajectory.stamps[i], T.translation().x(), T.translation().y(),
                              T.translation().z(), q.x(), q.y(), q.z(), q.w()};
    for (int k = 0; k < 8; ++k) {
      if (k > 0) text += ' ';
      append_double(text, values[k]);
    }
    text += '\n';
  }
  write_text(path, text);
}

std::vector<double> read_times(const std::string& path, const TrajectoryReadSettings& settings) {
  return parse_times(read_text(path), path, settings);
}

std::vector<double> parse_times(const std::string& text, const std::string& path,
                                const TrajectoryReadSettings& settings) {
  LineReader reader(text, path);
  StampOrder order(settings);
  std::vector<double> stamps;
  std::string_view line;
  while (reader.next(line)) {
    const std::vector<double> v = parse_fields(line, reader);
    check_field_count(v, 1, "one stamp per line", reader);
    order.check(v[0], reader);
    stamps.push_back(v[0]);
  }
  PLUMB_CHECK(!stamps.empty(), path << ": no stamps in file (empty or only comments)");
  return stamps;
}

Trajectory read_kitti(const std::string& path, const std::string& times_path,
                      const TrajectoryReadSettings& settings) {
  Trajectory trajectory = parse_kitti(read_text(path), path, settings);
  if (!times_path.empty()) {
    trajectory.stamps = read_times(times_path, settings);
    PLUMB_CHECK(trajectory.stamps.size() == trajectory.poses.size(),
                times_path << ": " << trajectory.stamps.size() << " stamps for the " << trajectory.poses.size()
                           << " poses of " << path);
  }
  return trajectory;
}

Trajectory parse_kitti(const std::string& text, const std::string& path, const TrajectoryReadSettings& settings) {
  LineReader reader(text, path);
  Trajectory trajectory;
  std::string_view line;
  while (reader.next(line)) {
    const std::vector<double> v = parse_fields(line, reader);
    check_field_count(v, 12, "row-major 3x4 [R|t]", reader);
    check_position(Eigen::Vector3d(v[3], v[7], v[11]), settings, reader);
    Eigen::Matrix3d R;
    R << v[0], v[1], v[2], v[4], v[5], v[6], v[8], v[9], v[10];
    const double error = (R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
    const double det = R.determinant();
    PLUMB_CHECK(error <= settings.max_rotation_error && det > 0.0,
                path << ':' << reader.line_number() << ": rotation block is not a rotation (max |R^T R - I| = "
                     << error << ", tolerance " << settings.max_rotation_error << ", det " << det << ")");
    if (settings.orthonormalize && error > 0.0) {
      // Nearest rotation in the Frobenius norm: U V^T (det > 0 is guaranteed by the check above
      // for such small errors).
      const Eigen::JacobiSVD<Eigen::Matrix3d> svd(R, Eigen::ComputeFullU | Eigen::ComputeFullV);
      R = svd.matrixU() * svd.matrixV().transpose();
    }
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = R;
    T.translation() = Eigen::Vector3d(v[3], v[7], v[11]);
    trajectory.poses.push_back(T);
  }
  PLUMB_CHECK(!trajectory.empty(), path << ": no poses in file (empty or only comments)");
  return trajectory;
}

void write_kitti(const Trajectory& trajectory, const std::string& path, const std::string& times_path) {
  trajectory.check_consistent("write_kitti");
  std::string text;
  for (const Eigen::Isometry3d& T : trajectory.poses) {
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 4; ++c) {
        if (r > 0 || c > 0) text += ' ';
        append_double(text, T.matrix()(r, c));
      }
    }
    text += '\n';
  }
  if (!times_path.empty()) {
    PLUMB_CHECK(trajectory.has_stamps() || trajectory.empty(),
                "write_kitti: " << times_path << ": the trajectory has no stamps to write");
    std::string times;
    for (double stamp : trajectory.stamps) {
      append_double(times, stamp);
      times += '\n';
    }
    write_text(times_path, times);
  }
  write_text(path, text);
}

}  // namespace plumb::io
