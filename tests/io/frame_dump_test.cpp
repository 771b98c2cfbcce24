// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/io/frame_dump.hpp"

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "cli_runner.hpp"
#include "plumb/core/error.hpp"
#include "plumb/core/rng.hpp"
#include "test_data.hpp"
#include "test_util.hpp"

namespace plumb::io {
namespace {

namespace fs = std::filesystem;

std::string fresh_dir(const std::string& name) {
  const std::string dir = test::temp_path("frame_dump_" + name);
  fs::remove_all(dir);
  return dir;
}

Eigen::Isometry3d some_pose(double yaw, const Vector3d& t) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = (Eigen::AngleAxisd(yaw, Vector3d::UnitZ()) * Eigen::AngleAxisd(0.1, Vector3d::UnitX())).toRotationMatrix();
  T.translation() = t;
  return T;
}

PointCloud random_frame(Rng& rng, std::size_t n) {
  PointCloud c;
  for (std::size_t i = 0; i < n; ++i) {
    c.points.emplace_back(static_cast<float>(rng.uniform(-20, 20)), static_cast<float>(rng.uniform(-20, 20)),
                          static_cast<float>(rng.uniform(-2, 5)));
    c.intensities.push_back(static_cast<float>(rng.uniform(0, 255)));
    c.rings.push_back(static_cast<std::uint16_t>(rng.uniform_index(32)));
    c.times.push_back(static_cast<float>(rng.uniform(0, 0.1)));
    c.labels.push_back(static_cast<std::int32_t>(rng.uniform_index(5)));
  }
  return c;
}

FrameDumpMeta some_meta() {
  FrameDumpMeta meta;
  meta.lidar.name = "rfans32";
  meta.lidar.rate_hz = 10.0;
  meta.lidar.columns = 2000;
  meta.lidar.elevations_rad = {-0.349, 0.0, 0.1745329251994};
  meta.lidar.min_range = 0.3;
  meta.lidar.max_range = 150.0;
  meta.T_base_lidar = some_pose(0.3, Vector3d(0.1, -0.02, 0.6));
  meta.T_base_imu = some_pose(-1.2, Vector3d(0.05, 0.02, 0.2));
  meta.wheel_radius_left = 0.1;
  meta.wheel_radius_right = 0.1001;
  meta.axle = 0.5;
  meta.imu_rate_hz = 200.0;
  meta.origin_offset = Vector3d(1200.0, -300.0, 0.0);
  meta.source = "test \"quoted\"\n";
  meta.model = "AC20-FZK-Haus.ifc";
  meta.scenario = "indoor";
  return meta;
}

TEST(FrameDumpTest, RoundTripsEveryFile) {
  const std::string dir = fresh_dir("round_trip");
  const FrameDumpMeta meta = some_meta();
  Rng rng(7);
  std::vector<PointCloud> frames;
  std::vector<double> stamps = {1700000000.05, 1700000000.15, 1700000000.25};
  std::vector<WheelEncoderReading> wheels;
  std::vector<OdomSample> odom;
  std::vector<ImuSample> imu;
  Trajectory gt, gt_dense;
  for (int k = 0; k < 20; ++k) {
    const double t = 1700000000.0 + 0.0125 * k;
    wheels.push_back({t, rng.uniform(-10, 10), rng.normal()});
    odom.push_back({t, Pose2{rng.normal(), rng.normal(), rng.uniform(-3, 3)}});
    imu.push_back({t, Vector3d(rng.normal(), rng.normal(), rng.normal()), Vector3d(rng.normal(), 9.81, 1e-17)});
    gt_dense.push_back(t, some_pose(rng.normal(), Vector3d(rng.normal(), rng.normal(), 0.0)));
  }
  {
    FrameDumpWriter writer(dir, meta);
    for (double s : stamps) {
      frames.push_back(random_frame(rng, 100));
      writer.add_frame(s, frames.back());
      gt.push_back(s, some_pose(s, Vector3d(1, 2, 3)));
    }
    writer.write_wheels(wheels);
    writer.write_odometry(odom);
    writer.write_imu(imu);
    writer.write_ground_truth(gt);
    writer.write_ground_truth_dense(gt_dense);
    writer.close();
    EXPECT_EQ(writer.num_frames(), 3u);
  }
  EXPECT_TRUE(fs::exists(dir + "/frames/000002.pcd"));

  const FrameDumpReader reader(dir);
  const FrameDumpMeta& m = reader.meta();
  EXPECT_EQ(m.lidar.name, meta.lidar.name);
  EXPECT_EQ(m.lidar.rate_hz, meta.lidar.rate_hz);
  EXPECT_EQ(m.lidar.columns, meta.lidar.columns);
  EXPECT_EQ(m.lidar.elevations_rad, meta.lidar.elevations_rad);
  EXPECT_EQ(m.lidar.max_range, meta.lidar.max_range);
  EXPECT_TRUE(m.T_base_lidar.isApprox(meta.T_base_lidar, 1e-14));
  EXPECT_TRUE(m.T_base_imu.isApprox(meta.T_base_imu, 1e-14));
  EXPECT_EQ(m.wheel_radius_left, meta.wheel_radius_left);
  EXPECT_EQ(m.wheel_radius_right, meta.wheel_radius_right);
  EXPECT_EQ(m.axle, meta.axle);
  EXPECT_EQ(m.imu_rate_hz, meta.imu_rate_hz);
  EXPECT_EQ(m.origin_offset, meta.origin_offset);
  EXPECT_EQ(m.source, meta.source);
  EXPECT_EQ(m.model, meta.model);
  EXPECT_EQ(m.scenario, meta.scenario);

  ASSERT_EQ(reader.num_frames(), 3u);
  for (std::size_t i = 0; i < 3; ++i) {
    EXPECT_EQ(reader.stamp(i), stamps[i]);
    const PointCloud c = reader.frame(i);
    ASSERT_EQ(c.size(), frames[i].size());
    EXPECT_EQ(c.points, frames[i].points);
    EXPECT_EQ(c.intensities, frames[i].intensities);
    EXPECT_EQ(c.rings, frames[i].rings);
    EXPECT_EQ(c.times, frames[i].times);
    EXPECT_EQ(c.labels, frames[i].labels);
  }
  ASSERT_TRUE(reader.has_wheels() && reader.has_odometry() && reader.has_imu() && reader.has_ground_truth() &&
              reader.has_ground_truth_dense());
  const auto w = reader.wheels();
  ASSERT_EQ(w.size(), wheels.size());
  const auto o = reader.odometry();
  ASSERT_EQ(o.size(), odom.size());
  const auto im = reader.imu();
  ASSERT_EQ(im.size(), imu.size());
  for (std::size_t k = 0; k < wheels.size(); ++k) {
    EXPECT_EQ(w[k].stamp, wheels[k].stamp);
    EXPECT_EQ(w[k].left, wheels[k].left);
    EXPECT_EQ(w[k].right, wheels[k].right);
    EXPECT_EQ(o[k].stamp, odom[k].stamp);
    EXPECT_EQ(o[k].pose.vector(), odom[k].pose.vector());
    EXPECT_EQ(im[k].stamp, imu[k].stamp);
    EXPECT_EQ(im[k].gyro, imu[k].gyro);
    EXPECT_EQ(im[k].accel, imu[k].accel);
  }
  const Trajectory g = reader.ground_truth();
  ASSERT_EQ(g.size(), gt.size());
  for (std::size_t k = 0; k < gt.size(); ++k) {
    EXPECT_EQ(g.stamps[k], gt.stamps[k]);
    EXPECT_TRUE(g.poses[k].isApprox(gt.poses[k], 1e-12));
  }
  EXPECT_EQ(reader.ground_truth_dense().size(), gt_dense.size());
}

TEST(FrameDumpTest, MinimalUserDumpReadsWithDefaults) {
  // A user's own dump: a meta.json with only the LiDAR extrinsics, frames.csv and no other file.
  const std::string dir = fresh_dir("minimal");
  fs::create_directories(dir + "/scans");
  test::write_text(dir + "/meta.json", "{\"T_base_lidar\": [1,0,0,0.5, 0,1,0,0, 0,0,1,1.2, 0,0,0,1]}");
  test::write_text(dir + "/frames.csv", "# my robot\nindex,stamp,file\r\n0,10.0,scans/a.pcd\r\n1,10.1,scans/b.pcd\r\n");
  const FrameDumpReader reader(dir);
  EXPECT_EQ(reader.num_frames(), 2u);
  EXPECT_EQ(reader.meta().T_base_lidar.translation(), Vector3d(0.5, 0.0, 1.2));
  EXPECT_TRUE(reader.meta().T_base_imu.isApprox(Eigen::Isometry3d::Identity()));
  EXPECT_EQ(reader.frame_path(1), (fs::path(dir) / "scans/b.pcd").string());
  EXPECT_FALSE(reader.has_imu());
  EXPECT_FALSE(reader.has_wheels());
  EXPECT_THROW(reader.imu(), Error);
  EXPECT_THROW(reader.stamp(2), Error);
  // The frame file itself is read only when asked for.
  const std::string msg = test::error_of([&] { reader.frame(0); });
  EXPECT_NE(msg.find("a.pcd"), std::string::npos) << msg;
}

TEST(FrameDumpTest, MalformedMetaNamesFileLineAndColumn) {
  const std::string dir = fresh_dir("bad_meta");
  fs::create_directories(dir);
  test::write_text(dir + "/frames.csv", "index,stamp,file\n");
  struct Case {
    std::string json;
    std::string expected;  // substring of the message
  };
  const Case cases[] = {
      {"{\n  \"T_base_lidar\": [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1],\n  \"axle\": 0.5,,\n}", "meta.json:3:"},
      {"{\"axle\": 0.5}", "T_base_lidar"},
      {"{\"T_base_lidar\": [1,0,0,0, 0,1,0,0, 0,0,1,0]}", "16 numbers"},
      {"{\"T_base_lidar\": [2,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1]}", "not a rotation"},
      {"{\"T_base_lidar\": [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1], \"axle\": \"wide\"}", "\"axle\" must be a number"},
      {"{\"T_base_lidar\": [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1], \"axle\": -1}", "must not be negative"},
      {"{\"T_base_lidar\": [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1], \"format\": \"rosbag\"}", "format"},
      {"{\"T_base_lidar\": [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1]", "expected '}'"},
      {"[1, 2]", "must be a JSON object"},
      {"{\"T_base_lidar\": [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1], \"T_base_lidar\": 1}", "duplicate key"},
      {"", "unexpected end"},
      // Not finite: the message names the key (a number beyond a double is not a parse error).
      {"{\"T_base_lidar\": [1,0,0,1e999, 0,1,0,0, 0,0,1,0, 0,0,0,1]}", "\"T_base_lidar\" must be a finite number"},
      {"{\"T_base_lidar\": [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1], \"T_base_imu\": [-1e999,0,0,0, 0,1,0,0, 0,0,1,0, "
       "0,0,0,1]}",
       "\"T_base_imu\" must be a finite number"},
      {"{\"T_base_lidar\": [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1], \"lidar\": {\"rate_hz\": 1e-9}}", "rate_hz"},
      {"{\"T_base_lidar\": [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1], \"lidar\": {\"rate_hz\": -10}}", "rate_hz"},
  };
  for (const Case& c : cases) {
    test::write_text(dir + "/meta.json", c.json);
    const std::string msg = test::error_of([&] { FrameDumpReader r(dir); });
    EXPECT_NE(msg.find("meta.json"), std::string::npos) << c.json << " -> " << msg;
    EXPECT_NE(msg.find(c.expected), std::string::npos) << c.json << " -> " << msg;
  }
}

TEST(FrameDumpTest, MalformedCsvNamesFileAndLine) {
  const std::string dir = fresh_dir("bad_csv");
  fs::create_directories(dir);
  test::write_text(dir + "/meta.json", frame_dump_meta_json(some_meta()));
  struct Case {
    std::string file, text, expected;
  };
  const Case frames_cases[] = {
      {"frames.csv", "index,stamp,file\n0,1.0,frames/000000.pcd\n1,1.1\n", "frames.csv:3: expected 3"},
      {"frames.csv", "index,stamp,file\n0,1.0,a.pcd\n1,0.9,b.pcd\n", "frames.csv:3: stamp"},
      {"frames.csv", "index,stamp,file\n0,1.0,a.pcd\n2,1.1,b.pcd\n", "frames.csv:3: index"},
      {"frames.csv", "index,stamp,file\n0,nan,a.pcd\n", "frames.csv:2: stamp is not a finite number"},
      {"frames.csv", "idx,t,path\n0,1.0,a.pcd\n", "frames.csv:1: expected the header"},
      {"frames.csv", "", "frames.csv: empty file"},
  };
  for (const Case& c : frames_cases) {
    test::write_text(dir + "/" + c.file, c.text);
    const std::string msg = test::error_of([&] { FrameDumpReader r(dir); });
    EXPECT_NE(msg.find(c.expected), std::string::npos) << c.text << " -> " << msg;
  }
  test::write_text(dir + "/frames.csv", "index,stamp,file\n0,1.0,a.pcd\n");
  const FrameDumpReader reader(dir);
  test::write_text(dir + "/imu.csv", "stamp,wx,wy,wz,ax,ay,az\n0.0,0,0,0,0,0,9.8\n0.005,0,0,0,0,9.8\n");
  std::string msg = test::error_of([&] { reader.imu(); });
  EXPECT_NE(msg.find("imu.csv:3: expected 7"), std::string::npos) << msg;
  test::write_text(dir + "/imu.csv", "stamp,wx,wy,wz,ax,ay,az\n0.0,0,0,0,0,0,9.8\n0.0,0,0,0,0,0,9.8\n");
  msg = test::error_of([&] { reader.imu(); });
  EXPECT_NE(msg.find("imu.csv:3: stamp"), std::string::npos) << msg;
  test::write_text(dir + "/odom.csv", "stamp,x,y,theta\n0.0,1,2,x3\n");
  msg = test::error_of([&] { reader.odometry(); });
  EXPECT_NE(msg.find("odom.csv:2: theta"), std::string::npos) << msg;
  test::write_text(dir + "/wheels.csv", "stamp,left,right\n0.0,1\n");
  msg = test::error_of([&] { reader.wheels(); });
  EXPECT_NE(msg.find("wheels.csv:2"), std::string::npos) << msg;
  test::write_text(dir + "/gt.tum", "0 1 2 3 0 0 0\n");
  msg = test::error_of([&] { reader.ground_truth(); });
  EXPECT_NE(msg.find("gt.tum:1"), std::string::npos) << msg;
}

// ImuCsvReader hands out the samples parse_frame_dump_imu() gives for the same text (comments,
// blank lines, CRLF line ends and a last line without its end included), and a bad row throws
// only when it is reached, after the good samples before it, naming file:line.
TEST(FrameDumpTest, ImuReaderStreamsWhatTheParserReads) {
  const std::string dir = test::temp_path("frame_dump_imu_reader");
  fs::create_directories(dir);
  const std::string path = dir + "/imu.csv";
  const std::string text =
      "# IMU\r\nstamp,wx,wy,wz,ax,ay,az\r\n\n0.0,0.1,0.2,0.3,0.4,0.5,9.8\r\n# gap\n"
      "0.005,-1e-3,2,3,4,5,6\n  0.010 , 1,2,3,4,5,+6\n0.015,7,8,9,10,11,12";
  test::write_text(path, text);
  const std::vector<ImuSample> parsed = parse_frame_dump_imu(text, path);
  ASSERT_EQ(parsed.size(), 4u);
  std::vector<ImuSample> streamed;
  ImuCsvReader reader(path);
  EXPECT_EQ(reader.path(), path);
  for (ImuSample m; reader.next(m);) streamed.push_back(m);
  EXPECT_FALSE(reader.next(*streamed.begin()));  // stays at the end
  ASSERT_EQ(streamed.size(), parsed.size());
  for (std::size_t k = 0; k < parsed.size(); ++k) {
    EXPECT_EQ(streamed[k].stamp, parsed[k].stamp) << k;
    EXPECT_EQ(streamed[k].gyro, parsed[k].gyro) << k;
    EXPECT_EQ(streamed[k].accel, parsed[k].accel) << k;
  }

  test::write_text(path, "stamp,wx,wy,wz,ax,ay,az\n0.0,0,0,0,0,0,9.8\n0.005,0,0,0,0,0,9.8\n0.004,0,0,0,0,0,9.8\n");
  ImuCsvReader bad(path);
  ImuSample m;
  EXPECT_TRUE(bad.next(m));
  EXPECT_TRUE(bad.next(m));
  std::string msg = test::error_of([&] { bad.next(m); });
  EXPECT_NE(msg.find(path + ":4: stamp 0.004 does not increase"), std::string::npos) << msg;

  test::write_text(path, "# only a comment\n");
  ImuCsvReader empty(path);
  msg = test::error_of([&] { empty.next(m); });
  EXPECT_NE(msg.find(path + ": empty file"), std::string::npos) << msg;
  test::write_text(path, "t,gx,gy,gz,ax,ay,az\n");
  ImuCsvReader header(path);
  msg = test::error_of([&] { header.next(m); });
  EXPECT_NE(msg.find(path + ":1: expected the header line"), std::string::npos) << msg;

  msg = test::error_of([&] { ImuCsvReader(dir + "/absent.csv"); });
  EXPECT_NE(msg.find(dir + "/absent.csv: no such file"), std::string::npos) << msg;
  msg = test::error_of([&] { ImuCsvReader{dir}; });
  EXPECT_NE(msg.find("is a directory"), std::string::npos) << msg;
  fs::remove_all(dir);
}

TEST(FrameDumpTest, MissingDirectoryAndOverwriteAreErrors) {
  const std::string dir = fresh_dir("missing");
  std::string msg = test::error_of([&] { FrameDumpReader r(dir); });
  EXPECT_NE(msg.find("meta.json"), std::string::npos) << msg;
  {
    FrameDumpWriter w(dir, some_meta());
    PointCloud c;
    c.points.emplace_back(1.0f, 2.0f, 3.0f);
    w.add_frame(1.0, c);
    EXPECT_THROW(w.add_frame(1.0, c), Error);  // stamps must increase
    w.close();
    EXPECT_THROW(w.add_frame(2.0, c), Error);
  }
  msg = test::error_of([&] { FrameDumpWriter w(dir, some_meta()); });
  EXPECT_NE(msg.find("refusing to overwrite"), std::string::npos) << msg;
  FrameDumpWriteSettings overwrite;
  overwrite.overwrite = true;
  EXPECT_NO_THROW(FrameDumpWriter(dir, some_meta(), overwrite));
}

TEST(FrameDumpTest, OverwriteReplacesTheWholeDump) {
  const std::string dir = fresh_dir("overwrite_whole");
  PointCloud c;
  c.points.emplace_back(1.0f, 2.0f, 3.0f);
  {
    FrameDumpWriter w(dir, some_meta());
    for (int i = 0; i < 3; ++i) w.add_frame(1.0 + i, c);
    w.write_odometry({{1.0, Pose2{}}});
  }
  test::write_text(dir + "/frames/notes.txt", "a user's file");
  FrameDumpWriteSettings overwrite;
  overwrite.overwrite = true;
  {
    FrameDumpWriter w(dir, some_meta(), overwrite);
    w.add_frame(5.0, c);
  }
  // One frame, no stale frame file nor odom.csv of the earlier dump; files not the writer's are kept.
  EXPECT_EQ(FrameDumpReader(dir).num_frames(), 1u);
  EXPECT_FALSE(fs::exists(dir + "/frames/000001.pcd"));
  EXPECT_FALSE(fs::exists(dir + "/odom.csv"));
  EXPECT_TRUE(fs::exists(dir + "/frames/notes.txt"));
}

TEST(FrameDumpTest, MetaJsonIsValidJsonWithTheDocumentedKeys) {
  const std::string json = frame_dump_meta_json(some_meta());
  for (const char* key : {"\"format\"", "\"units\"", "\"lidar\"", "\"T_base_lidar\"", "\"T_base_imu\"",
                          "\"wheel_radius_left\"", "\"wheel_radius_right\"", "\"axle\"", "\"origin_offset\""}) {
    EXPECT_NE(json.find(key), std::string::npos) << key;
  }
  // Parsing what we write gives back the same values (the strict parser accepts it).
  const FrameDumpMeta m = parse_frame_dump_meta(json);
  EXPECT_EQ(m.axle, 0.5);
}

// Every meta.json error names the line and column (from 1, in bytes) where the offending value
// starts, or for a syntax error the byte where the JSON lexer stopped.
TEST(FrameDumpTest, MetaErrorsNameTheLineAndColumnOfTheValue) {
  const std::string T = "\"T_base_lidar\": [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1]";
  struct Case {
    std::string json;
    std::string expected;
  };
  const Case cases[] = {
      {"{\n  " + T + ",\n  \"axle\": \"wide\"}", "m.json:3:11: \"axle\" must be a number"},
      {"{\n  " + T + ",\n  \"lidar\": {\"name\": \"a\", \"name\": \"b\"}}", "m.json:3:26: duplicate key \"name\""},
      {"{\n\t" + T + ",\n\t\"lidar\": {\"columns\": 1.5}}", "m.json:3:23: \"columns\" must be a non-negative integer"},
      {"{\"T_base_lidar\": [1,0,0,1e999, 0,1,0,0, 0,0,1,0, 0,0,0,1]}", "m.json:1:25: \"T_base_lidar\" must be"},
      {"{\n  " + T + ",\n  \"axle\": 0.5,,\n}", "m.json:3:15: "},
      {"{" + T + ", \"model\": \"a\xff\"}", "m.json:1:67: "},
      {"", "m.json:1:1: "},
      {std::string(65, '[') + std::string(65, ']'), "m.json:1:65: nesting too deep"},
  };
  for (const Case& c : cases) {
    const std::string msg = test::error_of([&] { parse_frame_dump_meta(c.json, "m.json"); });
    EXPECT_EQ(msg.rfind(c.expected, 0), 0u) << c.json << " -> " << msg;
  }
}

TEST(FrameDumpTest, MetaStringsAndNumbersReadAsJsonMeansThem) {
  const std::string T = "\"T_base_lidar\": [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1]";
  // \u escapes beyond ASCII, a surrogate pair included, are UTF-8 in the string; "-0" is -0.0.
  const FrameDumpMeta m = parse_frame_dump_meta(
      "{" + T + ", \"source\": \"caf\\u00e9 \\ud83d\\ude00\\t\", \"axle\": -0, \"imu_rate_hz\": 2e2}");
  EXPECT_EQ(m.source, "caf\xc3\xa9 \xf0\x9f\x98\x80\t");
  EXPECT_EQ(m.axle, 0.0);
  EXPECT_TRUE(std::signbit(m.axle));
  EXPECT_EQ(m.imu_rate_hz, 200.0);
  // A string that is not UTF-8 is written with U+FFFD in its place, so the file still reads.
  FrameDumpMeta w = some_meta();
  w.model = "haus\xff.ifc";
  w.scenario = std::string("a\0b\x01", 4);
  const FrameDumpMeta back = parse_frame_dump_meta(frame_dump_meta_json(w));
  EXPECT_EQ(back.model, "haus\xef\xbf\xbd.ifc");
  EXPECT_EQ(back.scenario, w.scenario);
}

// The writer's shortest round-trip numbers read back bit for bit, whatever their magnitude.
TEST(FrameDumpTest, MetaNumbersRoundTripBitForBit) {
  Rng rng(11);
  FrameDumpMeta meta = some_meta();
  meta.lidar.elevations_rad = {0.0, -0.0, 5e-324, -2.2250738585072014e-308, 1.7976931348623157e308, 0.1, 1.0 / 3.0,
                               9007199254740993.0, 123456789012345678901234.0};
  for (int k = 0; k < 2000; ++k) {
    meta.lidar.elevations_rad.push_back(rng.normal() * std::pow(10.0, rng.uniform(-300, 300)));
  }
  meta.axle = 0.1 + 0.2;
  const FrameDumpMeta back = parse_frame_dump_meta(frame_dump_meta_json(meta));
  ASSERT_EQ(back.lidar.elevations_rad.size(), meta.lidar.elevations_rad.size());
  for (std::size_t i = 0; i < meta.lidar.elevations_rad.size(); ++i) {
    const double a = meta.lidar.elevations_rad[i], b = back.lidar.elevations_rad[i];
    EXPECT_TRUE(a == b && std::signbit(a) == std::signbit(b)) << i << ": " << a << " read back as " << b;
  }
  EXPECT_EQ(back.axle, meta.axle);
}

// ---- as_built.json ---------------------------------------------------------------------------------

FrameDumpMeta identity_meta() {
  FrameDumpMeta meta;
  meta.lidar.name = "vlp16";
  return meta;
}

/// Elements with random small rigid motions and ids as IFC writes them ($ and _ included).
std::vector<ElementDeviation> some_elements(std::size_t n) {
  Rng rng(5);
  std::vector<ElementDeviation> out;
  for (std::size_t i = 0; i < n; ++i) {
    ElementDeviation e;
    e.global_id = "0a$B_" + std::to_string(i) + "xY9\"q\\";
    e.type = i % 2 == 0 ? "IfcWallStandardCase" : "IfcSlab";
    const Vector3d axis = Vector3d(rng.normal(), rng.normal(), rng.normal()).normalized();
    e.T_design_asbuilt.linear() = Eigen::AngleAxisd(rng.uniform(-0.01, 0.01), axis).toRotationMatrix();
    e.T_design_asbuilt.translation() = Vector3d(rng.normal(), rng.normal(), rng.normal()) * 0.01;
    out.push_back(e);
  }
  return out;
}

// Written, then read back by the reader and by nlohmann_json: the ids and types as given, the 16
// numbers bit for bit as written (nlohmann), the transforms within rounding (the reader makes the
// rotation exactly orthonormal).
TEST(AsBuiltJsonTest, RoundTripsThroughTheDump) {
  const std::string dir = fresh_dir("as_built_round_trip");
  const std::vector<ElementDeviation> elements = some_elements(7);
  {
    FrameDumpWriter w(dir, identity_meta());
    w.write_as_built(elements);
  }
  const FrameDumpReader reader(dir);
  ASSERT_TRUE(reader.has_as_built());
  const std::vector<ElementDeviation> back = reader.as_built();
  ASSERT_EQ(back.size(), elements.size());
  const nlohmann::json doc = nlohmann::json::parse(test::read_text(dir + "/as_built.json"));
  ASSERT_EQ(doc.at("elements").size(), elements.size());
  for (std::size_t i = 0; i < elements.size(); ++i) {
    EXPECT_EQ(back[i].global_id, elements[i].global_id);
    EXPECT_EQ(back[i].type, elements[i].type);
    EXPECT_TRUE(back[i].T_design_asbuilt.isApprox(elements[i].T_design_asbuilt, 1e-14)) << i;
    const nlohmann::json& e = doc["elements"][i];
    EXPECT_EQ(e.at("global_id").get<std::string>(), elements[i].global_id);
    EXPECT_EQ(e.at("type").get<std::string>(), elements[i].type);
    const std::vector<double> m = e.at("T_design_asbuilt").get<std::vector<double>>();
    ASSERT_EQ(m.size(), 16u);
    for (int r = 0; r < 4; ++r) {
      for (int c = 0; c < 4; ++c) {
        EXPECT_EQ(m[static_cast<std::size_t>(4 * r + c)], elements[i].T_design_asbuilt.matrix()(r, c)) << i;
      }
    }
  }
  // No elements: an empty list, read back as such.
  EXPECT_TRUE(parse_frame_dump_as_built(frame_dump_as_built_json({})).empty());
  fs::remove_all(dir);
}

// A dump without as_built.json reads as before; asking for it names the file. Overwriting a dump
// removes the earlier as_built.json with the rest of the set.
TEST(AsBuiltJsonTest, MissingFileAndOverwrite) {
  const std::string dir = fresh_dir("as_built_missing");
  {
    FrameDumpWriter w(dir, identity_meta());
  }
  const FrameDumpReader reader(dir);
  EXPECT_FALSE(reader.has_as_built());
  const std::string msg = test::error_of([&] { reader.as_built(); });
  EXPECT_NE(msg.find("as_built.json"), std::string::npos) << msg;

  {
    FrameDumpWriter w(dir, identity_meta(), {PcdEncoding::kBinary, true});
    w.write_as_built(some_elements(2));
  }
  EXPECT_TRUE(FrameDumpReader(dir).has_as_built());
  EXPECT_THROW(FrameDumpWriter(dir, identity_meta()), Error);
  {
    FrameDumpWriter w(dir, identity_meta(), {PcdEncoding::kBinary, true});
  }
  EXPECT_FALSE(FrameDumpReader(dir).has_as_built());
  fs::remove_all(dir);
}

// Every malformed as_built.json names the file, line and column of the offending value.
TEST(AsBuiltJsonTest, MalformedFileNamesFileLineAndColumn) {
  const std::string dir = fresh_dir("as_built_malformed");
  {
    FrameDumpWriter w(dir, identity_meta());
  }
  const std::string T = "[1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1]";
  struct Case {
    std::string json;
    std::string expected;  // the message after DIR/
  };
  const Case cases[] = {
      {"{\"elements\": [\n  {\"global_id\": \"a\", \"type\": \"IfcWall\", \"T_design_asbuilt\": " + T + "},,\n]}",
       "as_built.json:2:"},
      {"{\"elements\": 3}", "as_built.json:1:14: \"elements\" must be an array"},
      {"{\"items\": []}", "as_built.json:1:1: missing required key \"elements\""},
      {"[]", "as_built.json:1:1: the document must be a JSON object"},
      {"{\"elements\": [7]}", "as_built.json:1:15: an entry of \"elements\" must be an object"},
      {"{\"elements\": [{\"type\": \"IfcWall\", \"T_design_asbuilt\": " + T + "}]}",
       "as_built.json:1:15: missing required key \"global_id\""},
      {"{\"elements\": [\n{\"global_id\": 12, \"type\": \"IfcWall\", \"T_design_asbuilt\": " + T + "}]}",
       "as_built.json:2:15: \"global_id\" must be a string"},
      {"{\"elements\": [{\"global_id\": \"a\", \"type\": \"IfcWall\", \"T_design_asbuilt\": [1,0,0]}]}",
       "as_built.json:1:73: \"T_design_asbuilt\" must hold 16 numbers"},
      {"{\"elements\": [{\"global_id\": \"a\", \"type\": \"IfcWall\", \"T_design_asbuilt\": "
       "[2,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1]}]}",
       "as_built.json:1:73: \"T_design_asbuilt\": upper-left 3x3 block is not a rotation"},
      {"{\"elements\": [{\"global_id\": \"a\", \"type\": \"IfcWall\", \"T_design_asbuilt\": "
       "[1,0,0,1e999, 0,1,0,0, 0,0,1,0, 0,0,0,1]}]}",
       "as_built.json:1:80: \"T_design_asbuilt\" must be a finite number"},
      {"", "as_built.json:1:1: "},
  };
  const FrameDumpReader reader(dir);
  const std::string path = (fs::path(dir) / "as_built.json").string();
  for (const Case& c : cases) {
    test::write_text(path, c.json);
    const std::string msg = test::error_of([&] { reader.as_built(); });
    EXPECT_EQ(msg.rfind(path.substr(0, path.size() - std::strlen("as_built.json")) + c.expected, 0), 0u)
        << c.json << " -> " << msg;
  }
  fs::remove_all(dir);
}

}  // namespace
}  // namespace plumb::io
