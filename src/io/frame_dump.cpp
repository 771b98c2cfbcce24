// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/io/frame_dump.hpp"

#include <charconv>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>
#include <string_view>
#include <system_error>
#include <utility>

#include "plumb/io/input_file.hpp"
#include "plumb/core/error.hpp"
#include "plumb/io/trajectory.hpp"
#include "plumb/io/wheel_encoders.hpp"
#include "json_text.hpp"
#include "text_tokens.hpp"

namespace plumb::io {
namespace {

namespace fs = std::filesystem;

// ---- numbers -------------------------------------------------------------------------------------

void append_double(std::string& out, double value) {
  char buffer[64];
  const auto result = std::to_chars(buffer, buffer + sizeof(buffer), value);
  out.append(buffer, result.ptr);
}

std::string join_path(const std::string& dir, const std::string& name) {
  return (fs::path(dir) / name).string();
}

// ---- meta.json values ----------------------------------------------------------------------------

using detail::fail_at;
using detail::json_number;
using detail::json_numbers;
using detail::json_string;
using detail::JsonValue;

Eigen::Isometry3d get_transform(const std::string& name, const JsonValue& v, const char* key) {
  const std::vector<double> m = json_numbers(name, v, key);
  if (m.size() != 16) {
    fail_at(name, v, std::string("\"") + key + "\" must hold 16 numbers (4x4 row-major), got " +
                         std::to_string(m.size()));
  }
  Eigen::Matrix4d M;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) M(r, c) = m[static_cast<std::size_t>(4 * r + c)];
  if (std::abs(M(3, 0)) > 1e-9 || std::abs(M(3, 1)) > 1e-9 || std::abs(M(3, 2)) > 1e-9 ||
      std::abs(M(3, 3) - 1.0) > 1e-9) {
    fail_at(name, v, std::string("\"") + key + "\": last row must be 0 0 0 1");
  }
  const Eigen::Matrix3d R = M.topLeftCorner<3, 3>();
  const double orthogonality = (R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
  if (!(orthogonality < 1e-6) || R.determinant() <= 0.0) {
    fail_at(name, v, std::string("\"") + key + "\": upper-left 3x3 block is not a rotation");
  }
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::Quaterniond(R).normalized().toRotationMatrix();
  T.translation() = M.topRightCorner<3, 1>();
  return T;
}

void append_transform(std::string& out, const Eigen::Isometry3d& T) {
  const Eigen::Matrix4d M = T.matrix();
  out += '[';
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) {
      if (r + c > 0) out += ", ";
      append_double(out, M(r, c));
    }
  }
  out += ']';
}

// ---- CSV -----------------------------------------------------------------------------------------

// Fields and lines are trimmed of blanks only (' ', '\t', '\r'): a '\f' or '\v' is not taken for one.
std::string_view trim(std::string_view s) { return detail::trim(s, detail::is_blank); }

std::string read_text(const std::string& path) {
  std::ifstream in = open_input_file(path);  // names a missing file or a directory as such
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  PLUMB_CHECK(!in.bad(), path << ": read error");
  return text;
}

/// A CSV file with a fixed header, taken one line at a time: a data row's fields are checked
/// against the header's count and handed out with their line number.
class CsvLines {
 public:
  CsvLines(std::string path, const char* header)
      : path_(std::move(path)), header_(header), expected_(detail::split_fields(header)) {}

  /// Takes the next raw line (without its '\n'); true when it is a data row, whose fields are then
  /// in fields() (views into `raw`).
  bool take(std::string_view raw) {
    ++line_number_;
    const std::string_view line = trim(raw);
    if (line.empty() || line.front() == '#') return false;
    fields_ = detail::split_fields(line);
    if (!have_header_) {
      PLUMB_CHECK(fields_ == expected_, path_ << ':' << line_number_ << ": expected the header line '" << header_
                                              << "', got '" << line << "'");
      have_header_ = true;
      return false;
    }
    PLUMB_CHECK(fields_.size() == expected_.size(), path_ << ':' << line_number_ << ": expected "
                                                          << expected_.size() << " comma-separated fields, got "
                                                          << fields_.size());
    return true;
  }
  /// Called at the end of the file: a file without its header line is an error.
  void finish() const {
    PLUMB_CHECK(have_header_, path_ << ": empty file (expected the header line '" << header_ << "')");
  }
  const std::vector<std::string_view>& fields() const { return fields_; }
  std::size_t line_number() const { return line_number_; }
  const std::string& path() const { return path_; }

 private:
  std::string path_;
  const char* header_;
  std::vector<std::string_view> expected_;
  std::vector<std::string_view> fields_;
  std::size_t line_number_ = 0;
  bool have_header_ = false;
};

/// Reads CSV text with a fixed header; calls `row(fields, line_number)` for every data row.
template <class Row>
void read_csv(const std::string& text, const std::string& path, const char* header, Row&& row) {
  CsvLines csv(path, header);
  std::size_t pos = 0;
  while (pos < text.size()) {
    std::size_t end = text.find('\n', pos);
    if (end == std::string::npos) end = text.size();
    if (csv.take(std::string_view(text).substr(pos, end - pos))) row(csv.fields(), csv.line_number());
    pos = end + 1;
  }
  csv.finish();
}

double parse_double(std::string_view field, const std::string& path, std::size_t line_number, const char* what) {
  double value = 0.0;
  const char* first = field.data();
  const char* last = field.data() + field.size();
  if (!field.empty() && *first == '+') ++first;
  const auto result = std::from_chars(first, last, value);
  PLUMB_CHECK(!field.empty() && result.ec == std::errc() && result.ptr == last && std::isfinite(value),
              path << ':' << line_number << ": " << what << " is not a finite number: '" << field << "'");
  return value;
}

/// Parses every field as a double into `out` and checks the stamp (field 0) increases strictly.
void parse_row(const std::vector<std::string_view>& fields, const std::string& path, std::size_t line_number,
               const char* const* names, double* out, double& last_stamp, bool first) {
  for (std::size_t k = 0; k < fields.size(); ++k) out[k] = parse_double(fields[k], path, line_number, names[k]);
  PLUMB_CHECK(first || out[0] > last_stamp, path << ':' << line_number << ": stamp " << out[0]
                                                 << " does not increase (previous " << last_stamp << ")");
  last_stamp = out[0];
}

void write_text_file(const std::string& path, const std::string& text) {
  std::FILE* f = std::fopen(path.c_str(), "wb");
  PLUMB_CHECK(f != nullptr, path << ": cannot open for writing: " << std::strerror(errno));
  const std::size_t written = text.empty() ? 0 : std::fwrite(text.data(), 1, text.size(), f);
  const bool close_failed = std::fclose(f) != 0;
  PLUMB_CHECK(written == text.size() && !close_failed, path << ": write failed");
}

template <class T, class Format>
void write_csv(const std::string& path, const char* header, const std::vector<T>& rows, Format&& format) {
  std::string text = header;
  text += '\n';
  double last = 0.0;
  for (std::size_t i = 0; i < rows.size(); ++i) {
    const double stamp = rows[i].stamp;
    PLUMB_CHECK(std::isfinite(stamp) && (i == 0 || stamp > last),
                path << ": row " << i << ": stamp " << stamp << " does not increase");
    last = stamp;
    format(text, rows[i]);
    text += '\n';
  }
  write_text_file(path, text);
}

void append_values(std::string& out, std::initializer_list<double> values) {
  bool first = true;
  for (double v : values) {
    if (!first) out += ',';
    first = false;
    PLUMB_CHECK(std::isfinite(v), "frame dump writer: non-finite value " << v);
    append_double(out, v);
  }
}

constexpr const char* kFramesHeader = "index,stamp,file";
constexpr double kMinLidarRateHz = 0.1, kMaxLidarRateHz = 1000.0;  // meta.json lidar.rate_hz, when not 0
constexpr const char* kOdomHeader = "stamp,x,y,theta";
constexpr const char* kImuHeader = "stamp,wx,wy,wz,ax,ay,az";
const char* const kImuNames[] = {"stamp", "wx", "wy", "wz", "ax", "ay", "az"};

}  // namespace

// ---- meta.json -----------------------------------------------------------------------------------

std::string frame_dump_meta_json(const FrameDumpMeta& meta) {
  std::string s = "{\n  \"format\": \"plumb-frame-dump\",\n  \"version\": 1,\n";
  s += "  \"units\": {\"length\": \"m\", \"angle\": \"rad\", \"time\": \"s\", \"point_time\": \"s since the frame stamp\"},\n";
  s += "  \"source\": ";
  detail::append_json_string(s, meta.source);
  s += ",\n  \"model\": ";
  detail::append_json_string(s, meta.model);
  s += ",\n  \"scenario\": ";
  detail::append_json_string(s, meta.scenario);
  s += ",\n  \"lidar\": {\"name\": ";
  detail::append_json_string(s, meta.lidar.name);
  s += ", \"rate_hz\": ";
  append_double(s, meta.lidar.rate_hz);
  s += ", \"columns\": " + std::to_string(meta.lidar.columns) + ", \"min_range\": ";
  append_double(s, meta.lidar.min_range);
  s += ", \"max_range\": ";
  append_double(s, meta.lidar.max_range);
  s += ", \"elevations_rad\": [";
  for (std::size_t i = 0; i < meta.lidar.elevations_rad.size(); ++i) {
    if (i > 0) s += ", ";
    append_double(s, meta.lidar.elevations_rad[i]);
  }
  s += "]},\n  \"T_base_lidar\": ";
  append_transform(s, meta.T_base_lidar);
  s += ",\n  \"T_base_imu\": ";
  append_transform(s, meta.T_base_imu);
  s += ",\n  \"imu_rate_hz\": ";
  append_double(s, meta.imu_rate_hz);
  s += ",\n  \"wheel_radius_left\": ";
  append_double(s, meta.wheel_radius_left);
  s += ",\n  \"wheel_radius_right\": ";
  append_double(s, meta.wheel_radius_right);
  s += ",\n  \"axle\": ";
  append_double(s, meta.axle);
  s += ",\n  \"origin_offset\": [";
  for (int k = 0; k < 3; ++k) {
    if (k > 0) s += ", ";
    append_double(s, meta.origin_offset[k]);
  }
  s += "]\n}\n";
  return s;
}

FrameDumpMeta parse_frame_dump_meta(const std::string& text, const std::string& name) {
  const JsonValue root = detail::parse_json(text, name);
  if (root.kind != JsonValue::Kind::kObject) fail_at(name, root, "the document must be a JSON object");
  FrameDumpMeta meta;
  if (const JsonValue* v = root.find("format")) {
    const std::string format = json_string(name, *v, "format");
    if (format != "plumb-frame-dump") fail_at(name, *v, "\"format\" must be \"plumb-frame-dump\", got \"" + format + "\"");
  }
  if (const JsonValue* v = root.find("version")) {
    const double version = json_number(name, *v, "version");
    if (version != 1.0) fail_at(name, *v, "unsupported \"version\" (this reader knows version 1)");
  }
  const JsonValue* lidar_T = root.find("T_base_lidar");
  if (lidar_T == nullptr) fail_at(name, root, "missing required key \"T_base_lidar\"");
  meta.T_base_lidar = get_transform(name, *lidar_T, "T_base_lidar");
  if (const JsonValue* v = root.find("T_base_imu")) meta.T_base_imu = get_transform(name, *v, "T_base_imu");
  auto non_negative = [&](const char* key, double& out) {
    if (const JsonValue* v = root.find(key)) {
      out = json_number(name, *v, key);
      if (out < 0.0) fail_at(name, *v, std::string("\"") + key + "\" must not be negative");
    }
  };
  non_negative("wheel_radius_left", meta.wheel_radius_left);
  non_negative("wheel_radius_right", meta.wheel_radius_right);
  non_negative("axle", meta.axle);
  non_negative("imu_rate_hz", meta.imu_rate_hz);
  if (const JsonValue* v = root.find("origin_offset")) {
    const std::vector<double> o = json_numbers(name, *v, "origin_offset");
    if (o.size() != 3) fail_at(name, *v, "\"origin_offset\" must hold 3 numbers");
    meta.origin_offset = Vector3d(o[0], o[1], o[2]);
  }
  if (const JsonValue* v = root.find("source")) meta.source = json_string(name, *v, "source");
  if (const JsonValue* v = root.find("model")) meta.model = json_string(name, *v, "model");
  if (const JsonValue* v = root.find("scenario")) meta.scenario = json_string(name, *v, "scenario");
  if (const JsonValue* l = root.find("lidar")) {
    if (l->kind != JsonValue::Kind::kObject) fail_at(name, *l, "\"lidar\" must be an object");
    if (const JsonValue* v = l->find("name")) meta.lidar.name = json_string(name, *v, "name");
    if (const JsonValue* v = l->find("rate_hz")) {
      // 0 = unknown; otherwise a spinning LiDAR's rate. It sets the tolerances of `plumb run` / `lio`
      // (one LiDAR period), which a rate like 1e-9 Hz would make meaningless.
      meta.lidar.rate_hz = json_number(name, *v, "rate_hz");
      if (meta.lidar.rate_hz != 0.0 && !(meta.lidar.rate_hz >= kMinLidarRateHz && meta.lidar.rate_hz <= kMaxLidarRateHz)) {
        fail_at(name, *v, "\"rate_hz\" must be 0 (unknown) or in [0.1, 1000] Hz");
      }
    }
    if (const JsonValue* v = l->find("columns")) {
      const double c = json_number(name, *v, "columns");
      if (c < 0 || c != std::floor(c) || c > 1e7) fail_at(name, *v, "\"columns\" must be a non-negative integer");
      meta.lidar.columns = static_cast<int>(c);
    }
    if (const JsonValue* v = l->find("min_range")) meta.lidar.min_range = json_number(name, *v, "min_range");
    if (const JsonValue* v = l->find("max_range")) meta.lidar.max_range = json_number(name, *v, "max_range");
    if (const JsonValue* v = l->find("elevations_rad")) {
      meta.lidar.elevations_rad = json_numbers(name, *v, "elevations_rad");
    }
  }
  return meta;
}

// ---- as_built.json -------------------------------------------------------------------------------

std::string frame_dump_as_built_json(const std::vector<ElementDeviation>& elements) {
  std::string s = "{\n  \"elements\": [";
  for (std::size_t i = 0; i < elements.size(); ++i) {
    s += i == 0 ? "\n    {\"global_id\": " : ",\n    {\"global_id\": ";
    detail::append_json_string(s, elements[i].global_id);
    s += ", \"type\": ";
    detail::append_json_string(s, elements[i].type);
    s += ", \"T_design_asbuilt\": ";
    append_transform(s, elements[i].T_design_asbuilt);
    s += '}';
  }
  s += elements.empty() ? "]\n}\n" : "\n  ]\n}\n";
  return s;
}

std::vector<ElementDeviation> parse_frame_dump_as_built(const std::string& text, const std::string& name) {
  const JsonValue root = detail::parse_json(text, name);
  if (root.kind != JsonValue::Kind::kObject) fail_at(name, root, "the document must be a JSON object");
  const JsonValue* list = root.find("elements");
  if (list == nullptr) fail_at(name, root, "missing required key \"elements\"");
  if (list->kind != JsonValue::Kind::kArray) fail_at(name, *list, "\"elements\" must be an array");
  std::vector<ElementDeviation> out;
  out.reserve(list->array.size());
  for (const JsonValue& entry : list->array) {
    if (entry.kind != JsonValue::Kind::kObject) fail_at(name, entry, "an entry of \"elements\" must be an object");
    auto required = [&](const char* key) {
      const JsonValue* v = entry.find(key);
      if (v == nullptr) fail_at(name, entry, std::string("missing required key \"") + key + "\"");
      return v;
    };
    ElementDeviation e;
    e.global_id = json_string(name, *required("global_id"), "global_id");
    e.type = json_string(name, *required("type"), "type");
    e.T_design_asbuilt = get_transform(name, *required("T_design_asbuilt"), "T_design_asbuilt");
    out.push_back(std::move(e));
  }
  return out;
}

// ---- CSV files -----------------------------------------------------------------------------------

FrameDumpIndex parse_frame_dump_frames(const std::string& text, const std::string& name) {
  static const char* const kNames[] = {"index", "stamp"};
  FrameDumpIndex out;
  read_csv(text, name, kFramesHeader, [&](const std::vector<std::string_view>& f, std::size_t line) {
    const double index = parse_double(f[0], name, line, kNames[0]);
    PLUMB_CHECK(index == static_cast<double>(out.stamps.size()),
                name << ':' << line << ": index " << f[0] << ", expected " << out.stamps.size());
    const double stamp = parse_double(f[1], name, line, kNames[1]);
    PLUMB_CHECK(out.stamps.empty() || stamp > out.stamps.back(),
                name << ':' << line << ": stamp " << stamp << " does not increase (previous " << out.stamps.back()
                     << ")");
    PLUMB_CHECK(!f[2].empty(), name << ':' << line << ": empty file name");
    out.stamps.push_back(stamp);
    out.files.emplace_back(f[2]);
  });
  return out;
}

std::vector<OdomSample> parse_frame_dump_odometry(const std::string& text, const std::string& name) {
  static const char* const kNames[] = {"stamp", "x", "y", "theta"};
  std::vector<OdomSample> out;
  double last = 0.0;
  read_csv(text, name, kOdomHeader, [&](const std::vector<std::string_view>& f, std::size_t line) {
    double v[4];
    parse_row(f, name, line, kNames, v, last, out.empty());
    out.push_back({v[0], Pose2{v[1], v[2], v[3]}});
  });
  return out;
}

std::vector<ImuSample> parse_frame_dump_imu(const std::string& text, const std::string& name) {
  std::vector<ImuSample> out;
  double last = 0.0;
  read_csv(text, name, kImuHeader, [&](const std::vector<std::string_view>& f, std::size_t line) {
    double v[7];
    parse_row(f, name, line, kImuNames, v, last, out.empty());
    out.push_back({v[0], Vector3d(v[1], v[2], v[3]), Vector3d(v[4], v[5], v[6])});
  });
  return out;
}

// ---- imu.csv, streamed ----------------------------------------------------------------------------

struct ImuCsvReader::State {
  State(const std::string& path) : in(open_input_file(path)), csv(path, kImuHeader) {}
  std::ifstream in;
  CsvLines csv;
  std::string line;
  double last = 0.0;
  bool first = true;
  bool done = false;
};

ImuCsvReader::ImuCsvReader(const std::string& path) : state_(std::make_unique<State>(path)) {}
ImuCsvReader::~ImuCsvReader() = default;
ImuCsvReader::ImuCsvReader(ImuCsvReader&&) noexcept = default;
ImuCsvReader& ImuCsvReader::operator=(ImuCsvReader&&) noexcept = default;

const std::string& ImuCsvReader::path() const { return state_->csv.path(); }

bool ImuCsvReader::next(ImuSample& out) {
  State& s = *state_;
  if (s.done) return false;
  while (std::getline(s.in, s.line)) {
    if (!s.csv.take(s.line)) continue;
    double v[7];
    parse_row(s.csv.fields(), s.csv.path(), s.csv.line_number(), kImuNames, v, s.last, s.first);
    s.first = false;
    out = {v[0], Vector3d(v[1], v[2], v[3]), Vector3d(v[4], v[5], v[6])};
    return true;
  }
  PLUMB_CHECK(!s.in.bad(), s.csv.path() << ": read error");
  s.done = true;
  s.csv.finish();
  return false;
}

// ---- writer --------------------------------------------------------------------------------------

FrameDumpWriter::FrameDumpWriter(const std::string& dir, const FrameDumpMeta& meta,
                                 const FrameDumpWriteSettings& settings)
    : dir_(dir), settings_(settings) {
  PLUMB_CHECK(!dir.empty(), "FrameDumpWriter: empty directory name");
  std::error_code ec;
  fs::create_directories(fs::path(dir) / "frames", ec);
  PLUMB_CHECK(!ec, dir << ": cannot create the frame dump directory: " << ec.message());
  const std::string meta_path = join_path(dir, "meta.json");
  // The whole set of a dump's files: without overwrite any of them refuses the directory; with
  // it they are all removed first, so that a shorter dump leaves no stale frame or file behind.
  static const char* const kDumpFiles[] = {"meta.json", "frames.csv", "wheels.csv", "odom.csv",
                                           "imu.csv",   "gt.tum",     "gt_dense.tum", "as_built.json"};
  for (const char* f : kDumpFiles) {
    const fs::path p = fs::path(dir) / f;
    if (!fs::exists(p)) continue;
    PLUMB_CHECK(settings.overwrite, dir << ": already holds a frame dump (" << f << "); refusing to overwrite");
    fs::remove(p, ec);
    PLUMB_CHECK(!ec, p.string() << ": cannot remove the earlier file: " << ec.message());
  }
  for (fs::directory_iterator it(fs::path(dir) / "frames", ec), end; !ec && it != end; it.increment(ec)) {
    const std::string f = it->path().filename().string();
    const bool frame_file = f.size() == 10 && f.compare(6, 4, ".pcd") == 0 &&
                            f.find_first_not_of("0123456789") == 6;
    if (!frame_file) continue;  // not the writer's: left alone
    PLUMB_CHECK(settings.overwrite, dir << ": already holds frames (frames/" << f << "); refusing to overwrite");
    std::error_code rm;
    fs::remove(it->path(), rm);
    PLUMB_CHECK(!rm, it->path().string() << ": cannot remove the earlier frame: " << rm.message());
  }
  PLUMB_CHECK(!ec, dir << "/frames: cannot list the directory: " << ec.message());
  write_text_file(meta_path, frame_dump_meta_json(meta));
  const std::string frames_path = join_path(dir, "frames.csv");
  frames_csv_ = std::fopen(frames_path.c_str(), "wb");
  PLUMB_CHECK(frames_csv_ != nullptr, frames_path << ": cannot open for writing: " << std::strerror(errno));
  std::fprintf(frames_csv_, "%s\n", kFramesHeader);
}

FrameDumpWriter::~FrameDumpWriter() {
  try {
    close();
  } catch (const Error&) {  // a destructor must not throw; close() explicitly to see errors
  }
}

void FrameDumpWriter::add_frame(double stamp, const PointCloud& cloud_lidar) {
  PLUMB_CHECK(frames_csv_ != nullptr, dir_ << ": FrameDumpWriter::add_frame after close()");
  PLUMB_CHECK(std::isfinite(stamp) && (num_frames_ == 0 || stamp > last_stamp_),
              dir_ << ": frame " << num_frames_ << ": stamp " << stamp << " does not increase (previous "
                   << last_stamp_ << ")");
  char name[32];
  std::snprintf(name, sizeof(name), "frames/%06zu.pcd", num_frames_);
  PcdWriteSettings pcd;
  pcd.encoding = settings_.encoding;
  write_pcd(join_path(dir_, name), cloud_lidar, pcd);
  std::string line = std::to_string(num_frames_) + ",";
  append_double(line, stamp);
  line += ',';
  line += name;
  line += '\n';
  PLUMB_CHECK(std::fwrite(line.data(), 1, line.size(), frames_csv_) == line.size(),
              join_path(dir_, "frames.csv") << ": write failed");
  last_stamp_ = stamp;
  ++num_frames_;
}

void FrameDumpWriter::write_wheels(const std::vector<WheelEncoderReading>& wheels) {
  write_wheel_encoders(wheels, join_path(dir_, "wheels.csv"));
}

void FrameDumpWriter::write_odometry(const std::vector<OdomSample>& odometry) {
  write_csv(join_path(dir_, "odom.csv"), kOdomHeader, odometry, [](std::string& s, const OdomSample& o) {
    append_values(s, {o.stamp, o.pose.x, o.pose.y, o.pose.theta});
  });
}

void FrameDumpWriter::write_imu(const std::vector<ImuSample>& imu) {
  write_csv(join_path(dir_, "imu.csv"), kImuHeader, imu, [](std::string& s, const ImuSample& m) {
    append_values(s, {m.stamp, m.gyro.x(), m.gyro.y(), m.gyro.z(), m.accel.x(), m.accel.y(), m.accel.z()});
  });
}

void FrameDumpWriter::write_ground_truth(const Trajectory& T_world_base) {
  write_tum(T_world_base, join_path(dir_, "gt.tum"));
}

void FrameDumpWriter::write_ground_truth_dense(const Trajectory& T_world_base) {
  write_tum(T_world_base, join_path(dir_, "gt_dense.tum"));
}

void FrameDumpWriter::write_as_built(const std::vector<ElementDeviation>& elements) {
  write_text_file(join_path(dir_, "as_built.json"), frame_dump_as_built_json(elements));
}

void FrameDumpWriter::close() {
  if (frames_csv_ == nullptr) return;
  const bool failed = std::fclose(frames_csv_) != 0;
  frames_csv_ = nullptr;
  PLUMB_CHECK(!failed, join_path(dir_, "frames.csv") << ": write failed");
}

// ---- reader --------------------------------------------------------------------------------------

FrameDumpReader::FrameDumpReader(const std::string& dir) : dir_(dir) {
  const std::string meta_path = join_path(dir, "meta.json");
  PLUMB_CHECK(std::filesystem::exists(meta_path), meta_path << ": no such file (not a frame dump directory?)");
  meta_ = parse_frame_dump_meta(read_text(meta_path), meta_path);

  const std::string frames_path = join_path(dir, "frames.csv");
  FrameDumpIndex index = parse_frame_dump_frames(read_text(frames_path), frames_path);
  stamps_ = std::move(index.stamps);
  files_ = std::move(index.files);
}

double FrameDumpReader::stamp(std::size_t i) const {
  PLUMB_CHECK(i < stamps_.size(), dir_ << ": frame " << i << " out of range (" << stamps_.size() << " frames)");
  return stamps_[i];
}

std::string FrameDumpReader::frame_path(std::size_t i) const {
  PLUMB_CHECK(i < files_.size(), dir_ << ": frame " << i << " out of range (" << files_.size() << " frames)");
  const fs::path p(files_[i]);
  return p.is_absolute() ? p.string() : (fs::path(dir_) / p).string();
}

PointCloud FrameDumpReader::frame(std::size_t i) const { return read_pcd(frame_path(i)); }

bool FrameDumpReader::has_wheels() const { return fs::exists(join_path(dir_, "wheels.csv")); }
bool FrameDumpReader::has_odometry() const { return fs::exists(join_path(dir_, "odom.csv")); }
bool FrameDumpReader::has_imu() const { return fs::exists(join_path(dir_, "imu.csv")); }
bool FrameDumpReader::has_ground_truth() const { return fs::exists(join_path(dir_, "gt.tum")); }
bool FrameDumpReader::has_ground_truth_dense() const { return fs::exists(join_path(dir_, "gt_dense.tum")); }
bool FrameDumpReader::has_as_built() const { return fs::exists(join_path(dir_, "as_built.json")); }

std::vector<WheelEncoderReading> FrameDumpReader::wheels() const {
  return read_wheel_encoders(join_path(dir_, "wheels.csv"));
}

std::vector<OdomSample> FrameDumpReader::odometry() const {
  const std::string path = join_path(dir_, "odom.csv");
  return parse_frame_dump_odometry(read_text(path), path);
}

std::vector<ImuSample> FrameDumpReader::imu() const {
  std::vector<ImuSample> out;
  ImuCsvReader reader = imu_reader();
  for (ImuSample m; reader.next(m);) out.push_back(m);
  return out;
}

ImuCsvReader FrameDumpReader::imu_reader() const { return ImuCsvReader(join_path(dir_, "imu.csv")); }

Trajectory FrameDumpReader::ground_truth() const { return read_tum(join_path(dir_, "gt.tum")); }
Trajectory FrameDumpReader::ground_truth_dense() const { return read_tum(join_path(dir_, "gt_dense.tum")); }

std::vector<ElementDeviation> FrameDumpReader::as_built() const {
  const std::string path = join_path(dir_, "as_built.json");
  return parse_frame_dump_as_built(read_text(path), path);
}

}  // namespace plumb::io
