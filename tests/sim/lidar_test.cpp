// SPDX-License-Identifier: BSD-3-Clause
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "plumb/bim/mesh.hpp"
#include "plumb/core/error.hpp"
#include "plumb/core/rng.hpp"
#include "plumb/sim/lidar.hpp"
#include "plumb/sim/lidar_model_json.hpp"
#include "plumb/sim/world.hpp"

using plumb::PointCloud;
using plumb::Rng;
using plumb::Vector3d;
using plumb::bim::BimMesh;
using namespace plumb::sim;

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
const Vector3d kLo(-4.0, -3.0, -1.0), kHi(6.0, 5.0, 2.0);

/// The inside of a box room as six elements: floor (IfcSlab), ceiling (IfcSlab), four walls.
BimMesh room() {
  BimMesh m;
  for (int i = 0; i < 8; ++i) {
    m.vertices.emplace_back((i & 1) ? kHi.x() : kLo.x(), (i & 2) ? kHi.y() : kLo.y(), (i & 4) ? kHi.z() : kLo.z());
  }
  const std::uint32_t quads[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 4, 6, 2},
                                     {1, 3, 7, 5}, {0, 1, 5, 4}, {2, 6, 7, 3}};
  const char* types[6] = {"IfcSlab", "IfcSlab", "IfcWall", "IfcWall", "IfcWall", "IfcWall"};
  for (int f = 0; f < 6; ++f) {
    plumb::bim::BimElement el;
    el.type = types[f];
    el.first_triangle = m.triangles.size();
    el.num_triangles = 2;
    el.bbox_min = kLo;
    el.bbox_max = kHi;
    m.elements.push_back(el);
    const auto& q = quads[f];
    m.triangles.push_back({q[0], q[1], q[2]});
    m.triangles.push_back({q[0], q[2], q[3]});
    m.triangle_element.push_back(f);
    m.triangle_element.push_back(f);
  }
  return m;
}

World exact_world(const BimMesh& m) {
  WorldSettings s;
  s.as_built_sigma_m = 0.0;
  s.as_built_sigma_rad = 0.0;
  s.clutter = 0.0;
  s.num_people = 0;
  return World(m, s);
}

double box_exit(const Vector3d& o, const Vector3d& d) {
  double best = kInf;
  for (int k = 0; k < 3; ++k) {
    if (d[k] != 0.0) best = std::min(best, ((d[k] > 0.0 ? kHi[k] : kLo[k]) - o[k]) / d[k]);
  }
  return best;
}

Eigen::Isometry3d pose(const Vector3d& t, double yaw) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(yaw, Vector3d::UnitZ()).toRotationMatrix();
  T.translation() = t;
  return T;
}

/// Beam direction of a point's ring and column in the LiDAR frame, from the model.
Vector3d beam(const LidarModel& lidar, std::size_t ring, double time) {
  const double column = std::round(time * lidar.rate_hz * lidar.columns);
  const double az = lidar.azimuth_offset_rad + 2.0 * M_PI * column / lidar.columns;
  const double el = lidar.elevations_rad[ring];
  return Vector3d(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az), std::sin(el));
}

LidarModel small_lidar() {
  LidarModel m = lidar_preset("vlp16");
  m.columns = 360;
  m.range_sigma = 0.0;
  return m;
}

}  // namespace

TEST(LidarTest, Presets) {
  const LidarModel r = lidar_preset("rfans32");
  EXPECT_EQ(r.elevations_rad.size(), 32u);
  EXPECT_EQ(r.columns, 2000);
  EXPECT_EQ(r.num_rays(), 64000u);
  EXPECT_DOUBLE_EQ(r.rate_hz, 10.0);
  const LidarModel v = lidar_preset("vlp16");
  ASSERT_EQ(v.elevations_rad.size(), 16u);
  EXPECT_NEAR(v.elevations_rad.front(), -15.0 * M_PI / 180.0, 1e-12);
  EXPECT_NEAR(v.elevations_rad.back(), 15.0 * M_PI / 180.0, 1e-12);
  EXPECT_NEAR(v.elevations_rad[1] - v.elevations_rad[0], 2.0 * M_PI / 180.0, 1e-12);
  EXPECT_NEAR(2.0 * M_PI / v.columns, 0.2 * M_PI / 180.0, 1e-12);  // 0.2 deg horizontal
  const LidarModel o = lidar_preset("os1-64");
  EXPECT_EQ(o.elevations_rad.size(), 64u);
  EXPECT_EQ(o.columns, 1024);
  EXPECT_NEAR(o.elevations_rad.back(), 16.6 * M_PI / 180.0, 1e-12);
  for (const std::string& name : lidar_preset_names()) EXPECT_NO_THROW(lidar_preset(name).validate());
  try {
    lidar_preset("hdl64");
    FAIL() << "no exception";
  } catch (const plumb::Error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("hdl64"), std::string::npos);
    EXPECT_NE(what.find("rfans32"), std::string::npos);
    EXPECT_NE(what.find("vlp16"), std::string::npos);
    EXPECT_NE(what.find("os1-64"), std::string::npos);
  }
}

TEST(LidarTest, StaticSweepHasExactRangesRingsAndTimes) {
  const BimMesh m = room();
  const World world = exact_world(m);
  LidarModel lidar = small_lidar();
  lidar.azimuth_offset_rad = 0.1;
  const Eigen::Isometry3d T = pose(Vector3d(1.0, 0.5, 0.2), 0.7);
  Rng rng(1);
  const PointCloud cloud = simulate_sweep(world, lidar, [&](double) { return T; }, 5.0, rng);
  ASSERT_NO_THROW(cloud.check_consistent());
  ASSERT_EQ(cloud.size(), lidar.num_rays());  // a closed room: every beam returns
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const std::size_t column = i / lidar.elevations_rad.size();
    EXPECT_EQ(cloud.rings[i], i % lidar.elevations_rad.size());
    EXPECT_NEAR(cloud.times[i], column / (lidar.rate_hz * lidar.columns), 1e-6);
    const Vector3d d = beam(lidar, cloud.rings[i], cloud.times[i]);
    const Vector3d p = cloud.points[i].cast<double>();
    EXPECT_LT((p.normalized() - d).norm(), 1e-6);
    const double expected = box_exit(T.translation(), T.linear() * d);
    EXPECT_NEAR(p.norm(), expected, 2e-6 * expected);  // float storage
    const Vector3d w = T * p;
    const SimLabel expected_label = std::abs(w.z() - kLo.z()) < 1e-4 ? kSimGround
                                    : std::abs(w.z() - kHi.z()) < 1e-4 ? kSimOtherElement
                                                                       : kSimWall;
    EXPECT_EQ(cloud.labels[i], expected_label);
    EXPECT_GE(cloud.intensities[i], 0.0f);
    EXPECT_LE(cloud.intensities[i], 255.0f);
  }
}

TEST(LidarTest, MotionDistortsTheFrameExactlyByTheMotionAtEachPointsTime) {
  const BimMesh m = room();
  const World world = exact_world(m);
  const LidarModel lidar = small_lidar();
  // 2 m/s forward and 1 rad/s of yaw: 0.2 m and 0.1 rad within the sweep.
  auto trajectory = [](double t) { return pose(Vector3d(-1.0 + 2.0 * (t - 3.0), 0.3, 0.0), 0.2 + 1.0 * (t - 3.0)); };
  Rng rng(1);
  SweepSettings s;
  s.noise = false;
  const PointCloud moving = simulate_sweep(world, lidar, trajectory, 3.0, rng, s);
  s.motion_distortion = false;
  const PointCloud still = simulate_sweep(world, lidar, trajectory, 3.0, rng, s);
  ASSERT_EQ(moving.size(), lidar.num_rays());
  ASSERT_EQ(still.size(), lidar.num_rays());
  double max_diff = 0.0;
  for (std::size_t i = 0; i < moving.size(); ++i) {
    const double t = 3.0 + moving.times[i];
    const Vector3d d = beam(lidar, moving.rings[i], moving.times[i]);
    // Each moving point is the beam fired from the pose at its own time.
    const Eigen::Isometry3d T = trajectory(t);
    EXPECT_NEAR(moving.points[i].cast<double>().norm(), box_exit(T.translation(), T.linear() * d), 1e-5);
    // The undistorted frame is the same beam fired from the pose at the stamp.
    const Eigen::Isometry3d T0 = trajectory(3.0);
    EXPECT_NEAR(still.points[i].cast<double>().norm(), box_exit(T0.translation(), T0.linear() * d), 1e-5);
    EXPECT_EQ(still.times[i], moving.times[i]);
    max_diff = std::max(max_diff, (moving.points[i] - still.points[i]).cast<double>().norm());
  }
  EXPECT_GT(max_diff, 0.1);  // the distortion is real (0.2 m and 0.1 rad by the end)
  // Moving points mapped with the pose at their own time land on the room's surface.
  for (std::size_t i = 0; i < moving.size(); i += 7) {
    const Vector3d w = trajectory(3.0 + moving.times[i]) * moving.points[i].cast<double>();
    const double to_surface = std::min({std::abs(w.x() - kLo.x()), std::abs(w.x() - kHi.x()), std::abs(w.y() - kLo.y()),
                                        std::abs(w.y() - kHi.y()), std::abs(w.z() - kLo.z()), std::abs(w.z() - kHi.z())});
    EXPECT_LT(to_surface, 1e-5);
  }
}

TEST(LidarTest, NoiseDropoutsAndRangeLimits) {
  const BimMesh m = room();
  const World world = exact_world(m);
  LidarModel lidar = small_lidar();
  lidar.range_sigma = 0.05;
  lidar.dropout = 0.2;
  const Eigen::Isometry3d T = pose(Vector3d(0.5, 0.5, 0.5), 0.0);
  Rng rng(3);
  const PointCloud cloud = simulate_sweep(world, lidar, [&](double) { return T; }, 0.0, rng);
  const double kept = static_cast<double>(cloud.size()) / static_cast<double>(lidar.num_rays());
  EXPECT_NEAR(kept, 0.8, 0.02);
  double sum = 0.0, sum_sq = 0.0;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const Vector3d d = beam(lidar, cloud.rings[i], cloud.times[i]);
    const double err = cloud.points[i].cast<double>().norm() - box_exit(T.translation(), d);
    sum += err;
    sum_sq += err * err;
  }
  const double n = static_cast<double>(cloud.size());
  EXPECT_NEAR(sum / n, 0.0, 0.005);
  EXPECT_NEAR(std::sqrt(sum_sq / n), 0.05, 0.005);
  // Range limits: a max range shorter than the nearest wall leaves only what is nearer.
  LidarModel near_only = small_lidar();
  near_only.max_range = 4.0;
  Rng rng2(3);
  const PointCloud close = simulate_sweep(world, near_only, [&](double) { return T; }, 0.0, rng2);
  EXPECT_GT(close.size(), 0u);
  EXPECT_LT(close.size(), near_only.num_rays());
  for (const auto& p : close.points) EXPECT_LT(p.norm(), 4.0f);
  LidarModel far_only = small_lidar();
  far_only.min_range = 3.0;
  const PointCloud far = simulate_sweep(world, far_only, [&](double) { return T; }, 0.0, rng2);
  EXPECT_EQ(far.size() + [&] {
    std::size_t c = 0;
    for (const auto& p : simulate_sweep(world, small_lidar(), [&](double) { return T; }, 0.0, rng2).points) c += p.norm() < 3.0f;
    return c;
  }(), far_only.num_rays());
  for (const auto& p : far.points) EXPECT_GE(p.norm(), 3.0f);
}

TEST(LidarTest, IntensityFallsWithIncidenceAngle) {
  const BimMesh m = room();
  const World world = exact_world(m);
  LidarModel lidar = small_lidar();
  lidar.elevations_rad = {-M_PI / 2 + 0.05, -0.6, -0.2};  // floor nearly head-on ... obliquely
  lidar.min_range = 0.1;
  const Eigen::Isometry3d T = pose(Vector3d(1.0, 1.0, -0.5), 0.0);  // 0.5 m above the floor
  Rng rng(1);
  const PointCloud cloud = simulate_sweep(world, lidar, [&](double) { return T; }, 0.0, rng);
  double mean[3] = {0, 0, 0};
  int count[3] = {0, 0, 0};
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    if (cloud.labels[i] != kSimGround) continue;
    mean[cloud.rings[i]] += cloud.intensities[i];
    ++count[cloud.rings[i]];
  }
  ASSERT_GT(count[0], 0);
  ASSERT_GT(count[1], 0);
  ASSERT_GT(count[2], 0);
  for (int r = 0; r < 3; ++r) mean[r] /= count[r];
  EXPECT_GT(mean[0], mean[1]);
  EXPECT_GT(mean[1], mean[2]);
  // The cosine law: intensity ratio = ratio of the sines of the elevations.
  EXPECT_NEAR(mean[1] / mean[0], std::sin(0.6) / std::sin(M_PI / 2 - 0.05), 1e-3);
}

TEST(LidarTest, DeterministicForARngSeed) {
  const BimMesh m = room();
  WorldSettings ws;
  ws.seed = 5;
  const World world(m, ws);
  LidarModel lidar = small_lidar();
  lidar.range_sigma = 0.02;
  lidar.dropout = 0.1;
  auto trajectory = [](double t) { return pose(Vector3d(0.1 * t, 0.0, 0.0), 0.05 * t); };
  Rng a(17), b(17), c(18);
  const PointCloud pa = simulate_sweep(world, lidar, trajectory, 1.0, a);
  const PointCloud pb = simulate_sweep(world, lidar, trajectory, 1.0, b);
  const PointCloud pc = simulate_sweep(world, lidar, trajectory, 1.0, c);
  ASSERT_EQ(pa.size(), pb.size());
  EXPECT_EQ(pa.points, pb.points);
  EXPECT_EQ(pa.labels, pb.labels);
  EXPECT_EQ(pa.times, pb.times);
  EXPECT_EQ(pa.intensities, pb.intensities);
  EXPECT_NE(pa.points, pc.points);
}

TEST(LidarTest, BadInputThrows) {
  const BimMesh m = room();
  const World world = exact_world(m);
  Rng rng(1);
  const auto T = [](double) { return Eigen::Isometry3d::Identity(); };
  LidarModel lidar = small_lidar();
  lidar.elevations_rad.clear();
  EXPECT_THROW(simulate_sweep(world, lidar, T, 0.0, rng), plumb::Error);
  lidar = small_lidar();
  lidar.columns = 0;
  EXPECT_THROW(simulate_sweep(world, lidar, T, 0.0, rng), plumb::Error);
  lidar = small_lidar();
  lidar.dropout = 1.5;
  EXPECT_THROW(simulate_sweep(world, lidar, T, 0.0, rng), plumb::Error);
  lidar = small_lidar();
  lidar.max_range = 0.1;
  EXPECT_THROW(simulate_sweep(world, lidar, T, 0.0, rng), plumb::Error);
  lidar = small_lidar();
  EXPECT_THROW(simulate_sweep(world, lidar, std::function<Eigen::Isometry3d(double)>{}, 0.0, rng), plumb::Error);
  EXPECT_THROW(simulate_sweep(world, lidar, T, std::numeric_limits<double>::quiet_NaN(), rng), plumb::Error);
  const auto nan_pose = [](double) {
    Eigen::Isometry3d P = Eigen::Isometry3d::Identity();
    P.translation().x() = std::numeric_limits<double>::quiet_NaN();
    return P;
  };
  EXPECT_THROW(simulate_sweep(world, lidar, nan_pose, 0.0, rng), plumb::Error);
  // Outside an empty world nothing returns.
  const World empty(BimMesh{}, WorldSettings{});
  EXPECT_TRUE(simulate_sweep(empty, lidar, T, 0.0, rng).empty());
}

// ---- the LiDAR model file (plumb simulate --lidar FILE.json) ---------------------------------------

namespace {

std::string rows_json(std::size_t rows, const std::string& columns) {
  std::string text = "{\"name\": \"big\", \"elevations_deg\": [";
  for (std::size_t r = 0; r < rows; ++r) {
    text += (r > 0 ? ", " : "") + std::to_string(-30.0 + 60.0 * static_cast<double>(r) / static_cast<double>(rows));
  }
  return text + "], \"columns\": " + columns + "}";
}

std::string error_of(const std::string& text) {
  try {
    parse_lidar_model(text, "model.json");
  } catch (const plumb::Error& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST(LidarModelJsonTest, PresetAndFieldsAreReadAsWritten) {
  const LidarModel m = parse_lidar_model(R"({"preset": "vlp16", "columns": 900, "dropout": 0.25})", "m.json");
  const LidarModel vlp16 = lidar_preset("vlp16");
  EXPECT_EQ(m.elevations_rad, vlp16.elevations_rad);
  EXPECT_EQ(m.columns, 900);
  EXPECT_EQ(m.dropout, 0.25);
  EXPECT_EQ(m.max_range, vlp16.max_range);
  const LidarModel d = parse_lidar_model(R"({"elevations_deg": [-90, 0, 45], "rate_hz": 20})", "d.json");
  ASSERT_EQ(d.elevations_rad.size(), 3u);
  EXPECT_DOUBLE_EQ(d.elevations_rad[0], -M_PI / 2);
  EXPECT_DOUBLE_EQ(d.elevations_rad[2], M_PI / 4);
  EXPECT_EQ(d.name, "custom");
  EXPECT_EQ(d.rate_hz, 20.0);
  const LidarModel r = parse_lidar_model(R"({"elevations_rad": [0.1], "columns": 7})", "r.json");
  EXPECT_EQ(r.elevations_rad, std::vector<double>{0.1});
}

// The largest legal model (65535 rows x 64 columns, just under 2^22 rays) is read; one row, one
// column or one ray more is refused by name, before anything of its size is built.
TEST(LidarModelJsonTest, LargestLegalModelIsReadAndOneMoreIsRefused) {
  const LidarModel m = parse_lidar_model(rows_json(LidarModel::kMaxRows, "64"), "big.json");
  EXPECT_EQ(m.elevations_rad.size(), LidarModel::kMaxRows);
  EXPECT_LE(m.num_rays(), LidarModel::kMaxRaysPerSweep);
  const std::string rows = error_of(rows_json(LidarModel::kMaxRows + 1, "1"));
  EXPECT_EQ(rows.rfind("model.json: ", 0), 0u) << rows;
  EXPECT_NE(rows.find("at most 65535"), std::string::npos) << rows;
  const std::string rays = error_of(rows_json(LidarModel::kMaxRows, "65"));
  EXPECT_NE(rays.find("rays per sweep"), std::string::npos) << rays;
  const std::string columns = error_of(R"({"elevations_deg": [0], "columns": 100001})");
  EXPECT_NE(columns.find("\"columns\" must be a whole number in [1, 100000]"), std::string::npos) << columns;
}

TEST(LidarModelJsonTest, BadFilesAreNamedWithLineAndColumn) {
  const std::string syntax = error_of("{\n  \"columns\": 10,\n  oops\n}");
  EXPECT_EQ(syntax.rfind("model.json: not valid JSON", 0), 0u) << syntax;
  EXPECT_NE(syntax.find("line 3"), std::string::npos) << syntax;
  for (const char* text : {"[1, 2]", R"({"elevations_deg": "low"})", R"({"elevations_deg": [0], "rate_hz": "fast"})",
                           R"({"preset": "hdl64"})", R"({"columns": 10})", R"({"elevations_deg": [0], "rate_hz": 0.5})",
                           R"({"elevations_deg": [100]})", R"({"elevations_deg": [0], "columns": 2.5})", "{}", ""}) {
    const std::string e = error_of(text);
    EXPECT_EQ(e.rfind("model.json: ", 0), 0u) << text << " -> " << e;
  }
}
