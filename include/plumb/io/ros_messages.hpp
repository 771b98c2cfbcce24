// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief Decoders of the ROS messages a LiDAR-inertial recording holds, from their serialized
///        form: sensor_msgs/PointCloud2, sensor_msgs/Imu, nav_msgs/Odometry and tf2_msgs/TFMessage,
///        in ROS 1 serialization (little-endian, strings and variable arrays as a uint32 length
///        followed by the elements) or, for their ROS 2 versions (sensor_msgs/msg/PointCloud2, ...,
///        the same fields but a header without seq and with an int32 second), in CDR (a 4-byte
///        encapsulation header saying the byte order, then the fields aligned to their size counted
///        from the header's end; strings count their terminating NUL). Every read is bounds-checked: a short or inconsistent message gives
///        plumb::Error saying which field is wrong (callers add the bag, topic and message index).

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "plumb/core/point_cloud.hpp"
#include "plumb/core/sensor_data.hpp"
#include "plumb/io/recording.hpp"
#include "plumb/io/rosbag.hpp"

namespace plumb::io {

/// @name The md5sums of the decoded types' message definitions
/// As ROS computes them (genmsg), taken from the message packages (the `_md5sum` of Debian's
/// generated Python classes; a test checks them against those). A connection whose md5sum differs
/// carries another version of the type, which these decoders would misread.
/// @{
inline constexpr const char* kRosPointCloud2Md5 = "1158d486dd51d683ce2f1be655c3c181";
inline constexpr const char* kRosImuMd5 = "6a62c6daae103f4ff57a132d6f95cec2";
inline constexpr const char* kRosOdometryMd5 = "cd5e73d190d741a2f92e81eda573aca7";
inline constexpr const char* kRosTfMessageMd5 = "94810edda583a504dfda3829e70d7eec";
inline constexpr const char* kRosJointStateMd5 = "3066dcd76a6cfaef579bd0f34173e9fd";
/// @}

/// @brief The md5sum of a decoded type ("sensor_msgs/PointCloud2", ...), nullptr for another type.
const char* ros_known_md5sum(const std::string& type);

/// @brief std_msgs/Header.
struct RosHeader {
  std::uint32_t seq = 0;
  RosTime stamp;
  std::string frame_id;
};

/// @brief Which per-point field the times came from.
enum class PointTimeField {
  kNone,       ///< no time field: `cloud.times` is empty
  kTime,       ///< `time`: seconds since the stamp (Velodyne)
  kT,          ///< `t`: nanoseconds since the stamp (Ouster)
  kTimestamp,  ///< `timestamp`: absolute seconds (Hesai, Livox); the stamp is subtracted
};

/// @brief A decoded sensor_msgs/PointCloud2.
struct RosPointCloud2 {
  RosHeader header;
  /// x y z (any numeric type, converted to float), intensity (from `intensity` or else
  /// `reflectivity`), ring (from `ring` or else `channel`), times [s since the header stamp];
  /// every point, non-finite ones included, rows one after the other.
  PointCloud cloud;
  PointTimeField time_field = PointTimeField::kNone;
};

/// @brief Decode a sensor_msgs/PointCloud2, table-driven from its `fields` (any offsets and order,
///        datatypes INT8..FLOAT64, either byte order, padding, height x width with row_step).
/// @throws plumb::Error when the message is cut short, x, y or z is missing, a field does not fit
///         in point_step, the rows do not fit in row_step or the data, or a ring is not in 0..65535.
RosPointCloud2 decode_point_cloud2(const std::uint8_t* data, std::size_t size,
                                   RosSerialization serialization = RosSerialization::kRos1);

/// @brief Per-point times for a cloud whose driver sent none, from the azimuth atan2(y, x) of each
///        point: the sweep starts at the first point and turns in the direction most consecutive
///        points turn (counter-clockwise or clockwise), one turn per `period` seconds, so a point
///        `a` radians on from the first one gets the time a / (2 pi) * period. Approximate: exact for
///        a spinning LiDAR that sends its points in firing order, starting at the stamp.
/// @throws plumb::Error when `period` is not positive.
void synthesise_point_times(PointCloud& cloud, double period);

/// @brief A decoded sensor_msgs/Imu: the rates and specific force in the frame `header.frame_id`;
///        the sample's stamp is the header stamp in seconds.
struct RosImu {
  RosHeader header;
  ImuSample sample;
};
/// @throws plumb::Error when the message is cut short.
RosImu decode_imu(const std::uint8_t* data, std::size_t size, RosSerialization serialization = RosSerialization::kRos1);

/// @brief A decoded nav_msgs/Odometry: pose of `child_frame_id` in `header.frame_id`.
struct RosOdometry {
  RosHeader header;
  std::string child_frame_id;
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
};
/// @throws plumb::Error when the message is cut short or the quaternion is zero.
RosOdometry decode_odometry(const std::uint8_t* data, std::size_t size,
                            RosSerialization serialization = RosSerialization::kRos1);

/// @brief A decoded sensor_msgs/JointState: per joint its name and (when sent) position [rad or m].
struct RosJointState {
  RosHeader header;
  std::vector<std::string> name;
  std::vector<double> position;  ///< empty, or one per name
};
/// @throws plumb::Error when cut short or `position` is neither empty nor as long as `name`.
RosJointState decode_joint_state(const std::uint8_t* data, std::size_t size,
                                 RosSerialization serialization = RosSerialization::kRos1);

/// @brief One geometry_msgs/TransformStamped: T_parent_child, parent = `header.frame_id`.
struct RosTransform {
  RosHeader header;
  std::string child_frame_id;
  Eigen::Isometry3d T_parent_child = Eigen::Isometry3d::Identity();
};
/// @brief Decode a tf2_msgs/TFMessage. @throws plumb::Error when cut short or a quaternion is zero.
std::vector<RosTransform> decode_tf_message(const std::uint8_t* data, std::size_t size,
                                            RosSerialization serialization = RosSerialization::kRos1);

/// @brief T_base_frame from a set of transforms (a tree, e.g. /tf_static), by following `frame`'s
///        parents up to `base` (a leading `/` of a frame id is ignored). @return false when `frame`
///        does not lead to `base`.
bool resolve_transform(const std::vector<RosTransform>& tree, const std::string& base, const std::string& frame,
                       Eigen::Isometry3d& T_base_frame);

}  // namespace plumb::io
