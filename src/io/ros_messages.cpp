// SPDX-License-Identifier: BSD-3-Clause
// ROS 1 message decoders. The serialized layouts (ROS 1 serialization, fields in definition order):
//   std_msgs/Header            uint32 seq, time stamp (uint32 sec, uint32 nsec), string frame_id
//   sensor_msgs/PointField     string name, uint32 offset, uint8 datatype, uint32 count
//   sensor_msgs/PointCloud2    Header, uint32 height, uint32 width, PointField[] fields,
//                              bool is_bigendian, uint32 point_step, uint32 row_step, uint8[] data,
//                              bool is_dense
//   sensor_msgs/Imu            Header, Quaternion orientation, float64[9] covariance,
//                              Vector3 angular_velocity, float64[9], Vector3 linear_acceleration,
//                              float64[9]
//   nav_msgs/Odometry          Header, string child_frame_id, Pose (Point, Quaternion x y z w),
//                              float64[36], Twist (Vector3 linear, Vector3 angular), float64[36]
//   sensor_msgs/JointState     Header, string[] name, float64[] position, float64[] velocity,
//                              float64[] effort
//   tf2_msgs/TFMessage         TransformStamped[]: Header, string child_frame_id,
//                              Transform (Vector3 translation, Quaternion rotation)
#include "plumb/io/ros_messages.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

#include "plumb/core/error.hpp"
#include "detail_cloud_io.hpp"

namespace plumb::io {
namespace {

const char* chars(const std::uint8_t* p) { return reinterpret_cast<const char*>(p); }

// Bounds-checked reader of a serialized message: ROS 1 (little-endian, packed) or CDR (the
// encapsulation header's byte order; a primitive of k bytes aligned to k from the header's end).
class Cursor {
 public:
  Cursor(const std::uint8_t* p, std::size_t n, const char* type, RosSerialization s)
      : p_(p), n_(n), type_(type), cdr_(s == RosSerialization::kCdr) {
    if (!cdr_) return;
    const std::uint8_t* e = take(4, "the CDR encapsulation header");
    PLUMB_CHECK(e[0] == 0 && (e[1] == 0 || e[1] == 1),
                type_ << ": CDR encapsulation " << int(e[0]) << ' ' << int(e[1])
                      << " (plain CDR, 0 0 big-endian or 0 1 little-endian, is read)");
    swap_ = e[1] == 0;  // plumb runs on little-endian hosts (as cloud_detail::load assumes)
    origin_ = 4;
  }
  const std::uint8_t* take(std::size_t k, const char* what) {
    PLUMB_CHECK(k <= n_ - i_, type_ << ": message cut short reading " << what << " (needs " << k << " bytes at byte "
                                    << i_ << ", message has " << n_ << ')');
    const std::uint8_t* at = p_ + i_;
    i_ += k;
    return at;
  }
  // CDR: skip the padding before a primitive of k bytes.
  void align(std::size_t k, const char* what) {
    if (cdr_ && (i_ - origin_) % k != 0) take(k - (i_ - origin_) % k, what);
  }
  template <class T>
  T num(const char* what) {
    align(sizeof(T), what);
    const char* b = chars(take(sizeof(T), what));
    return swap_ ? cloud_detail::load_swapped<T>(b) : cloud_detail::load<T>(b);
  }
  std::uint8_t u8(const char* what) { return *take(1, what); }
  std::uint32_t u32(const char* what) { return num<std::uint32_t>(what); }
  double f64(const char* what) { return num<double>(what); }
  std::string str(const char* what) {
    const std::uint32_t len = u32(what);
    const std::uint8_t* b = take(len, what);
    std::size_t n = len;
    if (cdr_ && n > 0 && b[n - 1] == 0) --n;  // CDR counts the terminating NUL
    return std::string(reinterpret_cast<const char*>(b), n);
  }
  Eigen::Vector3d vec3(const char* what) {
    const double x = f64(what), y = f64(what), z = f64(what);
    return {x, y, z};
  }
  Eigen::Quaterniond quat(const char* what) {
    const double x = f64(what), y = f64(what), z = f64(what), w = f64(what);
    const Eigen::Quaterniond q(w, x, y, z);
    PLUMB_CHECK(std::isfinite(q.norm()) && q.norm() > 1e-9, type_ << ": " << what << " is not a rotation (norm " << q.norm() << ')');
    return q.normalized();
  }
  void skip_f64(std::size_t k, const char* what) {
    align(8, what);
    take(8 * k, what);
  }
  // std_msgs/Header (ROS 1: seq, uint32 sec, nsec, frame_id) or std_msgs/msg/Header (ROS 2: int32
  // sec, uint32 nanosec, frame_id).
  RosHeader header() {
    RosHeader h;
    if (!cdr_) h.seq = u32("header.seq");
    if (cdr_) {
      const auto sec = num<std::int32_t>("header.stamp");
      PLUMB_CHECK(sec >= 0, type_ << ": header.stamp " << sec << " s is before 1970");
      h.stamp.sec = static_cast<std::uint32_t>(sec);
    } else {
      h.stamp.sec = u32("header.stamp");
    }
    h.stamp.nsec = u32("header.stamp");
    h.frame_id = str("header.frame_id");
    return h;
  }
  const char* type() const { return type_; }

 private:
  const std::uint8_t* p_;
  std::size_t n_, i_ = 0;
  const char* type_;
  bool cdr_, swap_ = false;
  std::size_t origin_ = 0;
};

struct PointField {
  std::string name;
  std::uint32_t offset = 0;
  std::uint8_t datatype = 0;
};

std::size_t datatype_size(std::uint8_t t) {
  static const std::size_t sizes[] = {0, 1, 1, 2, 2, 4, 4, 4, 8};
  return t >= 1 && t <= 8 ? sizes[t] : 0;
}

template <class T>
T load_as(const std::uint8_t* p, bool swap) {
  return swap ? cloud_detail::load_swapped<T>(chars(p)) : cloud_detail::load<T>(chars(p));
}

// The value of a field of datatype t (1 INT8 .. 8 FLOAT64) at p, byte-swapped when `swap`.
double field_value(const std::uint8_t* p, std::uint8_t t, bool swap) {
  switch (t) {
    case 1: return load_as<std::int8_t>(p, swap);
    case 2: return load_as<std::uint8_t>(p, swap);
    case 3: return load_as<std::int16_t>(p, swap);
    case 4: return load_as<std::uint16_t>(p, swap);
    case 5: return load_as<std::int32_t>(p, swap);
    case 6: return load_as<std::uint32_t>(p, swap);
    case 7: return load_as<float>(p, swap);
    default: return load_as<double>(p, swap);
  }
}

const PointField* find_field(const std::vector<PointField>& fields, const char* name) {
  for (const PointField& f : fields) {
    if (f.name == name) return &f;
  }
  return nullptr;
}

}  // namespace

const char* ros_known_md5sum(const std::string& type) {
  if (type == "sensor_msgs/PointCloud2") return kRosPointCloud2Md5;
  if (type == "sensor_msgs/Imu") return kRosImuMd5;
  if (type == "nav_msgs/Odometry") return kRosOdometryMd5;
  if (type == "tf2_msgs/TFMessage") return kRosTfMessageMd5;
  if (type == "sensor_msgs/JointState") return kRosJointStateMd5;
  return nullptr;
}

RosPointCloud2 decode_point_cloud2(const std::uint8_t* data, std::size_t size, RosSerialization serialization) {
  Cursor c(data, size, "PointCloud2", serialization);
  RosPointCloud2 out;
  out.header = c.header();
  const std::uint32_t height = c.u32("height");
  const std::uint32_t width = c.u32("width");
  const std::uint32_t num_fields = c.u32("fields");
  std::vector<PointField> fields;
  for (std::uint32_t i = 0; i < num_fields; ++i) {
    PointField f;
    f.name = c.str("fields.name");
    f.offset = c.u32("fields.offset");
    f.datatype = c.u8("fields.datatype");
    c.u32("fields.count");
    fields.push_back(f);
  }
  const bool big_endian = c.u8("is_bigendian") != 0;
  const std::uint32_t point_step = c.u32("point_step");
  const std::uint32_t row_step = c.u32("row_step");
  const std::uint32_t data_size = c.u32("data");
  const std::uint8_t* points = c.take(data_size, "data");
  // The fields read: any other (label, padding, ...) is ignored.
  auto field = [&](const char* name, const char* alternative = nullptr) -> const PointField* {
    const PointField* f = find_field(fields, name);
    if (f == nullptr && alternative != nullptr) f = find_field(fields, alternative);
    if (f == nullptr) return nullptr;
    PLUMB_CHECK(datatype_size(f->datatype) != 0,
                "PointCloud2: field '" << f->name << "' has datatype " << int(f->datatype) << " (1..8 are defined)");
    PLUMB_CHECK(std::uint64_t{f->offset} + datatype_size(f->datatype) <= point_step,
                "PointCloud2: field '" << f->name << "' at offset " << f->offset << " (" << datatype_size(f->datatype)
                                       << " bytes) does not fit in point_step " << point_step);
    return f;
  };
  const PointField* x = field("x");
  const PointField* y = field("y");
  const PointField* z = field("z");
  PLUMB_CHECK(x != nullptr && y != nullptr && z != nullptr, "PointCloud2: fields x, y and z are required");
  const PointField* intensity = field("intensity", "reflectivity");
  const PointField* ring = field("ring", "channel");
  const PointField* time = field("time");
  out.time_field = PointTimeField::kTime;
  if (time == nullptr) {
    time = field("t");
    out.time_field = PointTimeField::kT;
  }
  if (time == nullptr) {
    time = field("timestamp");
    out.time_field = PointTimeField::kTimestamp;
  }
  if (time == nullptr) out.time_field = PointTimeField::kNone;
  PLUMB_CHECK(std::uint64_t{width} * point_step <= row_step,
              "PointCloud2: width " << width << " x point_step " << point_step << " exceeds row_step " << row_step);
  PLUMB_CHECK(std::uint64_t{height} * row_step <= data_size,
              "PointCloud2: height " << height << " x row_step " << row_step << " exceeds the data (" << data_size
                                     << " bytes)");
  const std::size_t n = std::size_t{height} * width;
  PointCloud& cloud = out.cloud;
  cloud.points.resize(n);
  if (intensity != nullptr) cloud.intensities.resize(n);
  if (ring != nullptr) cloud.rings.resize(n);
  if (time != nullptr) cloud.times.resize(n);
  const double stamp = out.header.stamp.seconds();
  std::size_t i = 0;
  for (std::uint32_t r = 0; r < height; ++r) {
    for (std::uint32_t col = 0; col < width; ++col, ++i) {
      const std::uint8_t* p = points + std::size_t{r} * row_step + std::size_t{col} * point_step;
      auto value = [&](const PointField* f) { return field_value(p + f->offset, f->datatype, big_endian); };
      cloud.points[i] = Vector3f(static_cast<float>(value(x)), static_cast<float>(value(y)), static_cast<float>(value(z)));
      if (intensity != nullptr) cloud.intensities[i] = static_cast<float>(value(intensity));
      if (ring != nullptr) {
        const double v = value(ring);
        PLUMB_CHECK(v >= 0 && v <= 65535, "PointCloud2: point " << i << ": ring " << v << " is not in 0..65535");
        cloud.rings[i] = static_cast<std::uint16_t>(v);
      }
      if (time != nullptr) {
        const double v = value(time);
        const double t = out.time_field == PointTimeField::kT ? v * 1e-9
                         : out.time_field == PointTimeField::kTimestamp ? v - stamp : v;
        cloud.times[i] = static_cast<float>(t);
      }
    }
  }
  return out;
}

void synthesise_point_times(PointCloud& cloud, double period) {
  PLUMB_CHECK(period > 0.0 && std::isfinite(period), "synthesise_point_times: period " << period << " is not positive");
  const std::size_t n = cloud.size();
  cloud.times.assign(n, 0.0f);
  if (n == 0) return;
  constexpr double kTwoPi = 2.0 * kPi;
  auto azimuth = [&](std::size_t i) {
    return std::atan2(static_cast<double>(cloud.points[i].y()), static_cast<double>(cloud.points[i].x()));
  };
  // The direction of the turn: the sign of most steps between consecutive points (wrapped to +-pi).
  std::ptrdiff_t turn = 0;
  for (std::size_t i = 1; i < n; ++i) {
    const double step = std::remainder(azimuth(i) - azimuth(i - 1), kTwoPi);
    turn += step > 0 ? 1 : step < 0 ? -1 : 0;
  }
  const double sign = turn >= 0 ? 1.0 : -1.0;
  const double first = azimuth(0);
  for (std::size_t i = 0; i < n; ++i) {
    double a = sign * (azimuth(i) - first);  // on from the first point, in the turn's direction
    a -= kTwoPi * std::floor(a / kTwoPi);
    // A point of the first half just short of the start (another ring of the first column) is at
    // the start, one of the second half just past it is at the end (as LOAM decides).
    if (2 * i < n && a > 1.5 * kPi) a = 0.0;
    if (2 * i >= n && a < 0.5 * kPi) a = kTwoPi;
    cloud.times[i] = static_cast<float>(a / kTwoPi * period);
  }
}

RosImu decode_imu(const std::uint8_t* data, std::size_t size, RosSerialization serialization) {
  Cursor c(data, size, "Imu", serialization);
  RosImu out;
  out.header = c.header();
  c.skip_f64(4 + 9, "orientation");
  out.sample.gyro = c.vec3("angular_velocity");
  c.skip_f64(9, "angular_velocity_covariance");
  out.sample.accel = c.vec3("linear_acceleration");
  c.skip_f64(9, "linear_acceleration_covariance");
  out.sample.stamp = out.header.stamp.seconds();
  return out;
}

RosOdometry decode_odometry(const std::uint8_t* data, std::size_t size, RosSerialization serialization) {
  Cursor c(data, size, "Odometry", serialization);
  RosOdometry out;
  out.header = c.header();
  out.child_frame_id = c.str("child_frame_id");
  const Eigen::Vector3d t = c.vec3("pose.position");
  const Eigen::Quaterniond q = c.quat("pose.orientation");
  out.pose = Eigen::Isometry3d::Identity();
  out.pose.linear() = q.toRotationMatrix();
  out.pose.translation() = t;
  c.skip_f64(36 + 6 + 36, "pose.covariance and twist");
  return out;
}

RosJointState decode_joint_state(const std::uint8_t* data, std::size_t size, RosSerialization serialization) {
  Cursor c(data, size, "JointState", serialization);
  RosJointState out;
  out.header = c.header();
  const std::uint32_t names = c.u32("name");
  for (std::uint32_t i = 0; i < names; ++i) out.name.push_back(c.str("name"));
  const std::uint32_t positions = c.u32("position");
  PLUMB_CHECK(positions == 0 || positions == names,
              "JointState: " << positions << " positions for " << names << " joint names");
  for (std::uint32_t i = 0; i < positions; ++i) out.position.push_back(c.f64("position"));
  return out;  // velocity and effort are not used
}

std::vector<RosTransform> decode_tf_message(const std::uint8_t* data, std::size_t size, RosSerialization serialization) {
  Cursor c(data, size, "TFMessage", serialization);
  const std::uint32_t n = c.u32("transforms");
  std::vector<RosTransform> out;
  for (std::uint32_t i = 0; i < n; ++i) {
    RosTransform tf;
    tf.header = c.header();
    tf.child_frame_id = c.str("child_frame_id");
    const Eigen::Vector3d t = c.vec3("transform.translation");
    const Eigen::Quaterniond q = c.quat("transform.rotation");
    tf.T_parent_child.linear() = q.toRotationMatrix();
    tf.T_parent_child.translation() = t;
    out.push_back(std::move(tf));
  }
  return out;
}

bool resolve_transform(const std::vector<RosTransform>& tree, const std::string& base, const std::string& frame,
                       Eigen::Isometry3d& T_base_frame) {
  // ROS 1 frame ids may carry a leading '/' ("/base_link"): it is not part of the name.
  auto bare = [](const std::string& s) { return s.substr(std::min(s.find_first_not_of('/'), s.size())); };
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();  // T_current_frame
  std::string current = bare(frame);
  for (std::size_t depth = 0; depth <= tree.size(); ++depth) {
    if (current == bare(base)) {
      T_base_frame = T;
      return true;
    }
    const RosTransform* up = nullptr;
    for (const RosTransform& tf : tree) {
      if (bare(tf.child_frame_id) == current) up = &tf;  // the last one wins, as in tf
    }
    if (up == nullptr) return false;
    T = up->T_parent_child * T;
    current = bare(up->header.frame_id);
  }
  return false;  // a cycle
}

}  // namespace plumb::io
