// SPDX-License-Identifier: BSD-3-Clause
// `plumb import BAG -o DUMP [--lidar TOPIC] [--imu TOPIC] [--odom TOPIC] [--wheels TOPIC --wheel-joints L R]
// [--base-frame NAME] [--T-base-lidar x y z roll pitch yaw] [--T-base-imu ...] [--start S] [--duration S] [--json]`:
// a ROS 1 bag or a ROS 2 bag in MCAP (sensor_msgs/PointCloud2, sensor_msgs/Imu, nav_msgs/Odometry,
// /tf_static; in ROS 2 sensor_msgs/msg/PointCloud2, ...) becomes a frame dump. `plumb import BAG
// --list` prints the bag's topics as `rosbag info` does. The bag is read chunk by chunk: /tf_static
// first, then the chosen topics in bag order (MCAP: log-time order); frames are written as they are
// read. DUMP is staged and moved into place as `plumb simulate` does (OutputDir).

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <iostream>
#include <limits>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "cli_support.hpp"
#include "registry.hpp"
#include "run_output.hpp"
#include "plumb/core/error.hpp"
#include "plumb/io/frame_dump.hpp"
#include "plumb/io/recording.hpp"
#include "plumb/io/ros_messages.hpp"

namespace plumb::cli {
namespace {

struct ImportOptions {
  std::string bag, output, lidar, imu, odom, wheels, base_frame = "base_link";
  std::vector<std::string> wheel_joints;  // left, right (with --wheels)
  std::vector<double> T_base_lidar, T_base_imu;  // x y z roll pitch yaw, empty = from /tf_static
  double start = 0.0;
  double duration = std::numeric_limits<double>::infinity();
  bool list = false, json = false, overwrite = false;
};

// x y z roll pitch yaw (fixed axes, R = Rz(yaw) Ry(pitch) Rx(roll), as ROS) to a transform.
Eigen::Isometry3d from_xyz_rpy(const std::vector<double>& v) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = (Eigen::AngleAxisd(v[5], Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(v[4], Eigen::Vector3d::UnitY()) *
                Eigen::AngleAxisd(v[3], Eigen::Vector3d::UnitX()))
                   .toRotationMatrix();
  T.translation() = Eigen::Vector3d(v[0], v[1], v[2]);
  return T;
}

// `topic` (when the recording has it and it is not empty), checked to carry `type` in the version
// the decoders read.
std::vector<std::string> checked_topic(const io::Recording& bag, const std::string& topic, const char* type) {
  if (topic.empty()) return {};
  bag.check_type(topic, type);
  return {topic};
}

// The topic to read: the one given (which must exist), else the only one of `type`, else none
// (or an error when `required`).
std::string choose_topic(const std::vector<io::BagTopic>& topics, const std::string& given, const char* type,
                         const char* option, bool required, const std::string& path) {
  std::vector<std::string> of_type;
  for (const io::BagTopic& t : topics) {
    if (io::ros1_type_name(t.type) == type) of_type.push_back(t.topic);
  }
  if (!given.empty()) {
    const bool exists = std::any_of(topics.begin(), topics.end(), [&](const io::BagTopic& t) { return t.topic == given; });
    PLUMB_CHECK(exists, path << ": no topic " << given << " (" << option << "); `plumb import BAG --list` lists them");
    return given;
  }
  if (of_type.size() == 1) return of_type[0];
  std::string names;
  for (const std::string& n : of_type) names += ' ' + n;
  PLUMB_CHECK(of_type.empty(), path << ": several " << type << " topics (" << names.substr(1) << "): choose one with "
                                    << option);
  PLUMB_CHECK(!required, path << ": no " << type << " topic; `plumb import BAG --list` lists the topics");
  return "";
}

void print_list(const io::Recording& bag, bool json) {
  const std::vector<io::BagTopic> topics = bag.topics();
  const double start = bag.start_time().seconds(), end = bag.end_time().seconds();
  const auto compression = bag.compression();
  if (json) {
    nlohmann::json j = {{"path", bag.path()},   {"format", bag.format()}, {"size", bag.file_size()},
                        {"start", start},       {"end", end},           {"duration", end - start},
                        {"messages", bag.num_messages()}, {"chunks", bag.num_chunks()}};
    if (bag.format() == "ROS 1 bag 2.0") j["version"] = "2.0";
    for (const auto& c : compression) j["compression"][c.first] = c.second;
    j["topics"] = nlohmann::json::array();
    for (const io::BagTopic& t : topics) {
      j["topics"].push_back({{"topic", t.topic}, {"type", t.type}, {"md5sum", t.md5sum}, {"messages", t.messages},
                             {"rate_hz", t.rate_hz}, {"first", t.first.seconds()}, {"last", t.last.seconds()}});
    }
    std::cout << j.dump(2) << '\n';
    return;
  }
  std::printf("path:        %s\nformat:      %s\nduration:    %.3f s\nstart:       %.9f\nend:         %.9f\n",
              bag.path().c_str(), bag.format().c_str(), end - start, start, end);
  std::printf("size:        %llu bytes\nmessages:    %llu\ncompression:",
              static_cast<unsigned long long>(bag.file_size()), static_cast<unsigned long long>(bag.num_messages()));
  for (const auto& c : compression) std::printf(" %s [%zu/%zu chunks]", c.first.c_str(), c.second, bag.num_chunks());
  std::printf("\ntopics:\n");
  for (const io::BagTopic& t : topics) {
    std::printf("  %-32s %8llu msgs @ %8.2f Hz : %s\n", t.topic.c_str(), static_cast<unsigned long long>(t.messages),
                t.rate_hz, t.type.c_str());
  }
}

// What import() found and wrote.
struct ImportSummary {
  std::string lidar, imu, odom, wheels;
  std::size_t frames = 0, points = 0, nonfinite = 0, skipped_frames = 0, imu_samples = 0, odometry = 0,
              wheel_readings = 0;
  std::string T_base_lidar_from, T_base_imu_from;
  bool times = true;
};

// Samples sorted by stamp, later ones with an equal stamp dropped (a dump's stamps increase strictly).
template <class T>
std::size_t sort_unique(std::vector<T>& v) {
  std::stable_sort(v.begin(), v.end(), [](const T& a, const T& b) { return a.stamp < b.stamp; });
  const std::size_t n = v.size();
  v.erase(std::unique(v.begin(), v.end(), [](const T& a, const T& b) { return a.stamp == b.stamp; }), v.end());
  return n - v.size();
}

// The extrinsic of `frame`: the option's value, else /tf_static, else an error naming both.
Eigen::Isometry3d extrinsic(const std::vector<double>& given, const std::vector<io::RosTransform>& tf,
                            const std::string& base, const std::string& frame, const char* option,
                            const std::string& path, std::string& from) {
  if (!given.empty()) {
    from = option;
    return from_xyz_rpy(given);
  }
  Eigen::Isometry3d T;
  PLUMB_CHECK(io::resolve_transform(tf, base, frame, T),
              path << ": /tf_static has no transform from " << base << " to '" << frame << "': give " << option
                   << " x y z roll pitch yaw (or --base-frame)");
  from = "/tf_static";
  return T;
}

// Prefix a decoder's error with the bag, the topic and the message.
template <class F>
auto decoding(const io::RecordedMessage& m, std::size_t index, F&& f) {
  try {
    return f();
  } catch (const plumb::Error& e) {
    PLUMB_THROW(*m.topic << " message " << index << " (chunk at offset " << m.chunk_offset
                                    << ", record at " << m.offset << "): " << e.what());
  }
}

// meta.json: the extrinsics (options, else /tf_static to the frames of the sensors' first
// messages) and the rates of the topics.
io::FrameDumpMeta dump_meta(const ImportOptions& o, const io::Recording& bag, const std::vector<io::BagTopic>& topics,
                            ImportSummary& s) {
  std::vector<io::RosTransform> tf;
  std::size_t index = 0;
  bag.read_topics(checked_topic(bag, "/tf_static", "tf2_msgs/TFMessage"), [&](const io::RecordedMessage& m) {
    const auto t = decoding(m, index++, [&] { return io::decode_tf_message(m.data, m.size, m.serialization); });
    tf.insert(tf.end(), t.begin(), t.end());
    return true;
  });
  // The frames of the sensors: from their first messages.
  std::string lidar_frame, imu_frame;
  bool have_lidar = false, have_imu = s.imu.empty();
  std::vector<std::string> first_topics = {s.lidar};
  if (!s.imu.empty()) first_topics.push_back(s.imu);
  bag.read_topics(first_topics, [&](const io::RecordedMessage& m) {
    const bool is_lidar = *m.topic == s.lidar;
    if (is_lidar && !have_lidar) {
      lidar_frame = decoding(m, 0, [&] { return io::decode_point_cloud2(m.data, m.size, m.serialization).header.frame_id; });
      have_lidar = true;
    } else if (!is_lidar && !have_imu) {
      imu_frame = decoding(m, 0, [&] { return io::decode_imu(m.data, m.size, m.serialization).header.frame_id; });
      have_imu = true;
    }
    return !(have_lidar && have_imu);
  });
  io::FrameDumpMeta meta;
  meta.T_base_lidar = extrinsic(o.T_base_lidar, tf, o.base_frame, lidar_frame, "--T-base-lidar", o.bag, s.T_base_lidar_from);
  if (!s.imu.empty()) {
    meta.T_base_imu = extrinsic(o.T_base_imu, tf, o.base_frame, imu_frame, "--T-base-imu", o.bag, s.T_base_imu_from);
  }
  for (const io::BagTopic& t : topics) {
    const double rate = t.rate_hz >= 0.1 && t.rate_hz <= 1000 ? t.rate_hz : 0.0;
    if (t.topic == s.lidar) meta.lidar.rate_hz = rate;
    if (t.topic == s.imu) meta.imu_rate_hz = rate;
  }
  return meta;
}

// The wheel angles of a sensor_msgs/JointState: the positions of the joints `joints` (left, right).
WheelEncoderReading wheel_reading(const io::RecordedMessage& m, std::size_t index, const std::vector<std::string>& joints) {
  return decoding(m, index, [&] {
    const io::RosJointState js = io::decode_joint_state(m.data, m.size, m.serialization);
    WheelEncoderReading r;
    r.stamp = js.header.stamp.seconds();
    for (int side = 0; side < 2; ++side) {
      const auto at = std::find(js.name.begin(), js.name.end(), joints[side]);
      PLUMB_CHECK(at != js.name.end(), "no joint '" << joints[side] << "' (--wheel-joints)");
      PLUMB_CHECK(!js.position.empty(), "no positions");
      (side == 0 ? r.left : r.right) = js.position[static_cast<std::size_t>(at - js.name.begin())];
    }
    return r;
  });
}

ImportSummary import_bag(const ImportOptions& o, const io::Recording& bag) {
  ImportSummary s;
  const std::vector<io::BagTopic> topics = bag.topics();
  s.lidar = choose_topic(topics, o.lidar, "sensor_msgs/PointCloud2", "--lidar", true, o.bag);
  s.imu = choose_topic(topics, o.imu, "sensor_msgs/Imu", "--imu", false, o.bag);
  s.odom = choose_topic(topics, o.odom, "nav_msgs/Odometry", "--odom", false, o.bag);
  std::vector<std::string> ids = checked_topic(bag, s.lidar, "sensor_msgs/PointCloud2");
  for (const std::string& t : checked_topic(bag, s.imu, "sensor_msgs/Imu")) ids.push_back(t);
  for (const std::string& t : checked_topic(bag, s.odom, "nav_msgs/Odometry")) ids.push_back(t);
  if (!o.wheels.empty()) {
    PLUMB_CHECK(o.wheel_joints.size() == 2, "import: --wheels needs --wheel-joints LEFT RIGHT (the joint names)");
    s.wheels = choose_topic(topics, o.wheels, "sensor_msgs/JointState", "--wheels", true, o.bag);
    for (const std::string& t : checked_topic(bag, s.wheels, "sensor_msgs/JointState")) ids.push_back(t);
  }
  io::FrameDumpMeta meta = dump_meta(o, bag, topics, s);
  meta.source = "plumb import " + o.bag.substr(o.bag.find_last_of('/') + 1) + " (" + s.lidar + ")";

  OutputDir out(o.output, "import", frame_dump_names(), o.overwrite, false);
  io::FrameDumpWriter writer(out.staging(), meta);
  const std::int64_t begin_ns = bag.start_time().nanoseconds() + static_cast<std::int64_t>(std::llround(o.start * 1e9));
  const double end_s = static_cast<double>(begin_ns) * 1e-9 + o.duration;
  std::vector<io::ImuSample> imu;
  std::vector<io::OdomSample> odom;
  std::vector<WheelEncoderReading> wheels;
  std::size_t lidar_index = 0, imu_index = 0, odom_index = 0, wheel_index = 0;
  double last_stamp = -std::numeric_limits<double>::infinity();
  const bool tty = isatty(fileno(stderr)) != 0;
  bag.read_topics(
      ids,
      [&](const io::RecordedMessage& m) {
        if (m.time.nanoseconds() < begin_ns) return true;
        if (m.time.seconds() > end_s) return true;
        const std::string& topic = *m.topic;
        if (topic == s.lidar) {
          io::RosPointCloud2 pc = decoding(m, lidar_index++, [&] { return io::decode_point_cloud2(m.data, m.size, m.serialization); });
          const std::vector<std::size_t> finite = pc.cloud.finite_indices();
          s.nonfinite += pc.cloud.size() - finite.size();
          if (finite.size() < pc.cloud.size()) pc.cloud = pc.cloud.select(finite);
          if (pc.time_field == io::PointTimeField::kNone) {
            s.times = false;
            io::synthesise_point_times(pc.cloud, 1.0 / (meta.lidar.rate_hz > 0 ? meta.lidar.rate_hz : 10.0));
          }
          const double stamp = pc.header.stamp.seconds();
          if (stamp <= last_stamp) {
            ++s.skipped_frames;
            return true;
          }
          last_stamp = stamp;
          writer.add_frame(stamp, pc.cloud);
          ++s.frames;
          s.points += pc.cloud.size();
        } else if (topic == s.imu) {
          imu.push_back(decoding(m, imu_index++, [&] { return io::decode_imu(m.data, m.size, m.serialization); }).sample);
        } else if (topic == s.wheels) {
          wheels.push_back(wheel_reading(m, wheel_index++, o.wheel_joints));
        } else {
          const io::RosOdometry od = decoding(m, odom_index++, [&] { return io::decode_odometry(m.data, m.size, m.serialization); });
          const Eigen::Matrix3d R = od.pose.linear();
          io::OdomSample sample;
          sample.stamp = od.header.stamp.seconds();
          sample.pose = Pose2{od.pose.translation().x(), od.pose.translation().y(), std::atan2(R(1, 0), R(0, 0))};
          odom.push_back(sample);
        }
        return true;
      },
      [&](std::uint64_t done, std::uint64_t total) {
        if (tty) std::fprintf(stderr, "\rimport: %5.1f %% of the bag, %zu frames", 100.0 * done / total, s.frames);
      });
  if (tty) std::fprintf(stderr, "\n");
  PLUMB_CHECK(s.frames > 0, o.bag << ": no " << s.lidar << " message in the time window");
  if (!s.times) {
    std::cerr << "plumb: warning: " << o.bag << ": " << s.lidar
              << " has no per-point time field (time, t or timestamp): times synthesised from the azimuth, one turn in "
              << 1.0 / (meta.lidar.rate_hz > 0 ? meta.lidar.rate_hz : 10.0) << " s\n";
  }
  const std::size_t dropped = sort_unique(imu) + sort_unique(odom) + sort_unique(wheels);
  if (dropped > 0) {
    std::cerr << "plumb: warning: " << dropped << " IMU / odometry / wheel messages with a repeated stamp dropped\n";
  }
  if (s.skipped_frames > 0) {
    std::cerr << "plumb: warning: " << s.skipped_frames << " frames whose stamp does not increase were skipped\n";
  }
  if (!s.imu.empty()) writer.write_imu(imu);
  if (!s.odom.empty()) writer.write_odometry(odom);
  if (!s.wheels.empty()) writer.write_wheels(wheels);
  writer.close();
  out.commit();
  s.imu_samples = imu.size();
  s.odometry = odom.size();
  s.wheel_readings = wheels.size();
  return s;
}

void run_import(const ImportOptions& o) {
  const std::unique_ptr<io::Recording> bag = io::open_recording(o.bag);
  if (o.list) {
    print_list(*bag, o.json);
    return;
  }
  PLUMB_CHECK(!o.output.empty(), "import: give the output frame dump with -o DUMP (or --list)");
  const ImportSummary s = import_bag(o, *bag);
  if (o.json) {
    nlohmann::json j = {{"lidar", s.lidar},
                        {"imu", s.imu},
                        {"odom", s.odom},
                        {"frames", s.frames},
                        {"points", s.points},
                        {"nonfinite_points", s.nonfinite},
                        {"skipped_frames", s.skipped_frames},
                        {"imu_samples", s.imu_samples},
                        {"odometry", s.odometry},
                        {"wheels", s.wheels},
                        {"wheel_readings", s.wheel_readings},
                        {"point_times", s.times},
                        {"T_base_lidar_from", s.T_base_lidar_from},
                        {"T_base_imu_from", s.T_base_imu_from},
                        {"output", o.output}};
    std::cout << j.dump(2) << '\n';
  } else {
    std::printf("%s: %zu frames (%zu points) from %s, %zu IMU samples, %zu odometry poses -> %s\n", o.bag.c_str(),
                s.frames, s.points, s.lidar.c_str(), s.imu_samples, s.odometry, o.output.c_str());
  }
}

}  // namespace

void register_import_command(CLI::App& app) {
  auto opts = std::make_shared<ImportOptions>();
  CLI::App* cmd = app.add_subcommand("import", "Import a ROS 1 bag or a ROS 2 bag in MCAP as a frame dump, or list its topics");
  cmd->add_option("bag", opts->bag, "ROS 1 bag (.bag, format 2.0) or ROS 2 bag in MCAP (.mcap); sqlite3 (.db3) is not read")
      ->required();
  cmd->add_option("-o,--output", opts->output, "Output frame dump directory");
  cmd->add_flag("--list", opts->list, "List the bag's topics (type, messages, rate) instead of importing");
  cmd->add_option("--lidar", opts->lidar, "sensor_msgs/PointCloud2 topic (default: the only one)");
  cmd->add_option("--imu", opts->imu, "sensor_msgs/Imu topic (default: the only one, if any)");
  cmd->add_option("--odom", opts->odom, "nav_msgs/Odometry topic for odom.csv (default: the only one, if any)");
  cmd->add_option("--wheels", opts->wheels,
                  "sensor_msgs/JointState topic of the wheel angles for wheels.csv (needs --wheel-joints)");
  cmd->add_option("--wheel-joints", opts->wheel_joints, "The left and right wheel joints' names in --wheels")
      ->expected(2);
  cmd->add_option("--base-frame", opts->base_frame, "The robot's base frame in /tf_static (default base_link)");
  cmd->add_option("--T-base-lidar", opts->T_base_lidar,
                  "LiDAR mounting: x y z [m] roll pitch yaw [rad] (default: from /tf_static)")
      ->expected(6)
      ->check(finite_number());
  cmd->add_option("--T-base-imu", opts->T_base_imu, "IMU mounting: x y z roll pitch yaw (default: from /tf_static)")
      ->expected(6)
      ->check(finite_number());
  cmd->add_option("--start", opts->start, "Skip this many seconds from the bag's start (default 0)")
      ->check(non_negative_number());
  cmd->add_option("--duration", opts->duration, "Import this many seconds (default: to the end)")
      ->check(positive_number());
  cmd->add_flag("--overwrite", opts->overwrite,
                "Write into a non-empty directory: every frame dump file in it is replaced (other files are kept)");
  cmd->add_flag("--json", opts->json, "Print a JSON summary (with --list: the topics as JSON)");
  cmd->callback([opts] { naming_inputs({opts->bag}, [&] { run_import(*opts); }); });
}

}  // namespace plumb::cli

PLUMB_CLI_COMMAND(import, plumb::cli::register_import_command);
