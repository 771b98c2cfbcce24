// SPDX-License-Identifier: BSD-3-Clause
// Range image, cosine features and LOAM matching on frames of an analytic 16-ring LiDAR (the
// paper's sensor: 16 rings 2 deg apart, 0.2 deg azimuth) ray-cast in a box room with pillars and
// a crate, made here: ground truth is exact, so rows, columns, feature geometry and the recovered
// motion are checked against it.
#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <vector>

#include <Eigen/Eigenvalues>
#include <gtest/gtest.h>

#include "plumb/core/error.hpp"
#include "plumb/core/lie.hpp"
#include "plumb/loam/features.hpp"
#include "plumb/loam/odometry.hpp"
#include "plumb/loam/range_image.hpp"

namespace plumb {
namespace {

constexpr double kDegree = kPi / 180.0;

struct RoomBox {
  Vector3d lo, hi;
};

// The room (seen from inside) and solid obstacles (seen from outside), world frame [m].
const RoomBox kRoom{{-6.0, -5.0, -1.2}, {9.0, 7.0, 2.8}};
const std::vector<RoomBox> kObstacles = {
    {{2.0, 1.5, -1.2}, {2.6, 2.3, 2.8}},     // pillar
    {{-3.0, -2.5, -1.2}, {-2.2, -1.8, 2.8}}, // pillar
    {{3.5, -3.5, -1.2}, {4.5, -2.5, 0.0}},   // crate
    {{-4.0, 3.0, -1.2}, {-3.4, 3.7, 2.8}},   // pillar
};

// Distance along the unit ray o + t d to the first surface.
double cast(const Vector3d& o, const Vector3d& d) {
  double t_room = std::numeric_limits<double>::infinity();
  for (int a = 0; a < 3; ++a) {
    if (d(a) > 1e-12) t_room = std::min(t_room, (kRoom.hi(a) - o(a)) / d(a));
    if (d(a) < -1e-12) t_room = std::min(t_room, (kRoom.lo(a) - o(a)) / d(a));
  }
  double best = t_room;
  for (const RoomBox& b : kObstacles) {
    double t0 = -std::numeric_limits<double>::infinity(), t1 = std::numeric_limits<double>::infinity();
    for (int a = 0; a < 3; ++a) {
      if (std::abs(d(a)) < 1e-12) {
        if (o(a) < b.lo(a) || o(a) > b.hi(a)) { t0 = 1; t1 = 0; }
        continue;
      }
      double ta = (b.lo(a) - o(a)) / d(a), tb = (b.hi(a) - o(a)) / d(a);
      if (ta > tb) std::swap(ta, tb);
      t0 = std::max(t0, ta);
      t1 = std::min(t1, tb);
    }
    if (t0 <= t1 && t0 > 0.0) best = std::min(best, t0);
  }
  return best;
}

std::vector<double> ring_angles_deg() {
  std::vector<double> a;
  for (int r = 0; r < 16; ++r) a.push_back(-15.0 + 2.0 * r);
  return a;
}

// One frame in the sensor frame, with rings; the sensor is at T_world_sensor.
PointCloud scan(const Eigen::Isometry3d& T_world_sensor, bool with_rings = true) {
  PointCloud cloud;
  const auto angles = ring_angles_deg();
  const Matrix3d R = T_world_sensor.linear();
  const Vector3d o = T_world_sensor.translation();
  for (int c = 0; c < 1800; ++c) {
    const double beta = (c + 0.5) * 0.2 * kDegree;
    for (int r = 0; r < 16; ++r) {
      const double alpha = angles[static_cast<std::size_t>(r)] * kDegree;
      const Vector3d d(std::cos(alpha) * std::sin(beta), std::cos(alpha) * std::cos(beta), std::sin(alpha));
      const double t = cast(o, R * d);
      cloud.points.push_back((t * d).cast<float>());
      if (with_rings) cloud.rings.push_back(static_cast<std::uint16_t>(r));
    }
  }
  return cloud;
}

// Distance of x to the nearest edge of any box (room or obstacle).
double distance_to_box_edges(const Vector3d& x) {
  double best = std::numeric_limits<double>::infinity();
  auto seg = [&](const Vector3d& a, const Vector3d& b) {
    const Vector3d ab = b - a;
    const double s = std::clamp((x - a).dot(ab) / ab.squaredNorm(), 0.0, 1.0);
    best = std::min(best, (a + s * ab - x).norm());
  };
  auto box_edges = [&](const RoomBox& b) {
    for (int a = 0; a < 3; ++a) {
      const int u = (a + 1) % 3, v = (a + 2) % 3;
      for (int i = 0; i < 2; ++i) {
        for (int j = 0; j < 2; ++j) {
          Vector3d p0, p1;
          p0(a) = b.lo(a);
          p1(a) = b.hi(a);
          p0(u) = p1(u) = i ? b.hi(u) : b.lo(u);
          p0(v) = p1(v) = j ? b.hi(v) : b.lo(v);
          seg(p0, p1);
        }
      }
    }
  };
  box_edges(kRoom);
  for (const RoomBox& b : kObstacles) box_edges(b);
  return best;
}

Eigen::Isometry3d pose(double x, double y, double z, double yaw_deg, double pitch_deg, double roll_deg) {
  const Matrix3d R = (Eigen::AngleAxisd(yaw_deg * kDegree, Vector3d::UnitZ()) *
                      Eigen::AngleAxisd(pitch_deg * kDegree, Vector3d::UnitY()) *
                      Eigen::AngleAxisd(roll_deg * kDegree, Vector3d::UnitX()))
                         .toRotationMatrix();
  return se3::make(R, Vector3d(x, y, z));
}

double translation_error(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return (a.inverse() * b).translation().norm();
}
double rotation_error_deg(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return so3::log((a.inverse() * b).linear()).norm() / kDegree;
}

RangeImageSettings image_settings() {
  RangeImageSettings s;
  s.horizontal_resolution_deg = 0.2;
  return s;
}

// ---------------------------------------------------------------------------------------------
// Range image

TEST(RangeImageTest, RowsAreRingsAndColumnsAreAzimuthBins) {
  const PointCloud cloud = scan(Eigen::Isometry3d::Identity());
  const RangeImage img = build_range_image(cloud, image_settings());
  ASSERT_EQ(img.status, Status::kOk);
  EXPECT_EQ(img.num_rows, 16);
  EXPECT_EQ(img.num_columns, 1800);
  EXPECT_EQ(img.num_dropped, 0u);
  EXPECT_EQ(img.num_collisions, 0u);
  EXPECT_EQ(img.num_pixels_filled, cloud.size());
  // Points were generated column-major: point c * 16 + r has ring r and azimuth bin c.
  for (int c = 0; c < 1800; c += 37) {
    for (int r = 0; r < 16; ++r) {
      EXPECT_EQ(img.at(r, c), c * 16 + r);
      EXPECT_NEAR(img.range_at(r, c), cloud.points[static_cast<std::size_t>(c * 16 + r)].norm(), 1e-5);
    }
  }
  for (int r = 0; r < 16; ++r) {
    EXPECT_NEAR(img.row_elevation[static_cast<std::size_t>(r)] / kDegree, -15.0 + 2.0 * r, 1e-4);
  }
}

TEST(RangeImageTest, AutoBinningAndVerticalAnglesReproduceTheRingField) {
  const PointCloud with = scan(pose(0.4, -0.3, 0.1, 20.0, 0.0, 0.0));
  PointCloud without = with;
  without.rings.clear();
  const RangeImage from_field = build_range_image(with, image_settings());
  const RangeImage from_bins = build_range_image(without, image_settings());
  RangeImageSettings s = image_settings();
  s.vertical_angles_deg = ring_angles_deg();
  std::reverse(s.vertical_angles_deg.begin(), s.vertical_angles_deg.end());  // any order
  const RangeImage from_angles = build_range_image(without, s);
  ASSERT_EQ(from_bins.num_rows, 16);
  ASSERT_EQ(from_angles.num_rows, 16);
  EXPECT_EQ(from_bins.point_row, from_field.point_row);
  EXPECT_EQ(from_angles.point_row, from_field.point_row);
  EXPECT_EQ(from_bins.index, from_field.index);
}

TEST(RangeImageTest, CollisionKeepsTheNearerPointAndInvalidPointsAreDropped) {
  PointCloud cloud;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  cloud.points = {{0.0f, 5.0f, 0.0f}, {0.0f, 3.0f, 0.0f}, {nan, 1.0f, 0.0f}, {0.0f, 0.1f, 0.0f},
                  {3.0f, 0.0f, 0.0f}};
  cloud.rings = {0, 0, 0, 0, 1};
  const RangeImage img = build_range_image(cloud, image_settings());
  EXPECT_EQ(img.num_rows, 2);
  EXPECT_EQ(img.at(0, 0), 1);       // beta = 0: the nearer of points 0 and 1
  EXPECT_EQ(img.at(1, 450), 4);     // beta = 90 deg (+x) -> column 450
  EXPECT_EQ(img.num_collisions, 1u);
  EXPECT_EQ(img.num_dropped, 2u);   // NaN and closer than min_range
  EXPECT_EQ(img.point_row[2], RangeImage::kNoRing);
  EXPECT_EQ(img.point_row[3], RangeImage::kNoRing);
}

TEST(RangeImageTest, BadInput) {
  EXPECT_EQ(build_range_image(PointCloud{}).status, Status::kInsufficientData);
  PointCloud all_nan;
  all_nan.points.assign(10, Vector3f::Constant(std::numeric_limits<float>::quiet_NaN()));
  EXPECT_EQ(build_range_image(all_nan).status, Status::kInsufficientData);
  PointCloud no_rings = scan(Eigen::Isometry3d::Identity(), false);
  RangeImageSettings s;
  s.ring_source = RingSource::kField;
  EXPECT_THROW(build_range_image(no_rings, s), Error);
  s.ring_source = RingSource::kVerticalAngles;
  EXPECT_THROW(build_range_image(no_rings, s), Error);
  s = {};
  s.horizontal_resolution_deg = 0.0;
  EXPECT_THROW(build_range_image(no_rings, s), Error);
  PointCloud bad_rings = scan(Eigen::Isometry3d::Identity());
  s = {};
  s.num_rings = 8;
  EXPECT_THROW(build_range_image(bad_rings, s), Error);
  bad_rings.rings.pop_back();
  EXPECT_THROW(build_range_image(bad_rings), Error);
}

// ---------------------------------------------------------------------------------------------
// Features

TEST(LoamFeaturesTest, EdgesLieOnBoxEdgesAndPlanesAwayFromThem) {
  const Eigen::Isometry3d T_world_sensor = pose(0.3, 0.2, 0.0, 10.0, 0.0, 0.0);
  const PointCloud cloud = scan(T_world_sensor);
  const LoamFeatureSettings fs;
  const LoamFeatures f = extract_loam_features(cloud, image_settings(), fs);
  ASSERT_EQ(f.status, Status::kOk);
  EXPECT_EQ(f.num_rings, 16);
  EXPECT_EQ(f.num_sectors, 6);
  ASSERT_EQ(f.sector_counts.size(), 96u);
  EXPECT_GT(f.edges.size(), 20u);
  EXPECT_GT(f.planes.size(), 200u);
  for (const Vector3f& p : f.edges.points) {
    EXPECT_LT(distance_to_box_edges(T_world_sensor * p.cast<double>()), 0.25);
  }
  for (const Vector3f& p : f.planes.points) {
    EXPECT_GT(distance_to_box_edges(T_world_sensor * p.cast<double>()), 0.005);
  }
  // Per-sector limits and totals.
  std::size_t plane_interval = 0, edge_interval = 0, planes = 0, edges = 0, plane_c = 0, edge_c = 0;
  for (const LoamSectorCounts& sc : f.sector_counts) {
    EXPECT_LE(sc.num_planes, 4u);
    EXPECT_LE(sc.num_plane_candidates, 4u);
    EXPECT_LE(sc.num_edges, 2u);
    EXPECT_LE(sc.num_edge_candidates, 2u);
    EXPECT_LE(sc.num_planes + sc.num_plane_candidates, sc.num_plane_interval);
    EXPECT_LE(sc.num_edges + sc.num_edge_candidates, sc.num_edge_interval);
    plane_interval += sc.num_plane_interval;
    edge_interval += sc.num_edge_interval;
    planes += sc.num_planes;
    edges += sc.num_edges;
    plane_c += sc.num_plane_candidates;
    edge_c += sc.num_edge_candidates;
  }
  EXPECT_EQ(plane_interval, f.num_plane_interval);
  EXPECT_EQ(edge_interval, f.num_edge_interval);
  EXPECT_EQ(planes, f.planes.size());
  EXPECT_EQ(edges, f.edges.size());
  EXPECT_EQ(plane_c, f.plane_candidates.size());
  EXPECT_EQ(edge_c, f.edge_candidates.size());
  // Every feature keeps its source index and ring.
  for (std::size_t i = 0; i < f.planes.size(); ++i) {
    EXPECT_EQ(f.planes.points[i], cloud.points[f.plane_indices[i]]);
    EXPECT_EQ(f.planes.rings[i], cloud.rings[f.plane_indices[i]]);
  }
}

TEST(LoamFeaturesTest, SelectedFeaturesAreSpreadAlongTheirRing) {
  const PointCloud cloud = scan(Eigen::Isometry3d::Identity());
  const RangeImage img = build_range_image(cloud, image_settings());
  LoamFeatureSettings fs;
  fs.suppression_radius = 7;
  const LoamFeatures f = extract_loam_features(cloud, img, fs);
  // The synthetic rings have no gaps, so "places along the ring" are columns.
  std::vector<std::vector<int>> cols(16);
  for (const auto* v : {&f.edge_indices, &f.edge_candidate_indices, &f.plane_indices, &f.plane_candidate_indices}) {
    for (std::size_t i : *v) cols[img.point_row[i]].push_back(img.point_column[i]);
  }
  for (auto& c : cols) {
    std::sort(c.begin(), c.end());
    for (std::size_t i = 1; i < c.size(); ++i) EXPECT_GT(c[i] - c[i - 1], 7);
  }
}

TEST(LoamFeaturesTest, CosineIntervalsCountWhatTheyShould) {
  // A flat wall in front of the sensor: every scored point is in the plane interval, none in the edge one.
  PointCloud wall;
  for (int c = -200; c <= 200; ++c) {
    const double beta = (c + 0.5) * 0.2 * kDegree;  // bin centres
    wall.points.push_back(Vector3f(static_cast<float>(5.0 * std::tan(beta)), 5.0f, 0.0f));
    wall.rings.push_back(0);
  }
  const LoamFeatures f = extract_loam_features(wall, image_settings(), LoamFeatureSettings{});
  EXPECT_GT(f.num_scored, 350u);
  EXPECT_EQ(f.num_plane_interval, f.num_scored);
  EXPECT_EQ(f.num_edge_interval, 0u);
  EXPECT_TRUE(f.edges.empty());
  EXPECT_FALSE(f.planes.empty());
}

TEST(LoamFeaturesTest, BadInput) {
  const PointCloud cloud = scan(Eigen::Isometry3d::Identity());
  const RangeImage img = build_range_image(cloud, image_settings());
  PointCloud other = cloud;
  other.points.pop_back();
  other.rings.pop_back();
  EXPECT_THROW(extract_loam_features(other, img), Error);
  LoamFeatureSettings fs;
  fs.num_sectors = 0;
  EXPECT_THROW(extract_loam_features(cloud, img, fs), Error);
  fs = {};
  fs.neighbor_offset = 0;
  EXPECT_THROW(extract_loam_features(cloud, img, fs), Error);
  const LoamFeatures empty = extract_loam_features(PointCloud{}, RangeImageSettings{});
  EXPECT_EQ(empty.status, Status::kInsufficientData);
  EXPECT_TRUE(empty.planes.empty());
}

// ---------------------------------------------------------------------------------------------
// Scan matching

LoamFeatures features_at(const Eigen::Isometry3d& T_world_sensor) {
  return extract_loam_features(scan(T_world_sensor), image_settings(), LoamFeatureSettings{});
}

TEST(LoamOdometryTest, ScanToScanRecoversKnownMotionForwardAndInverse) {
  const Eigen::Isometry3d T_w_a = pose(0.1, -0.2, 0.0, 5.0, 0.0, 0.0);
  const Eigen::Isometry3d T_w_b = pose(0.35, -0.32, 0.03, 9.0, -0.4, 0.6);
  const LoamFeatures fa = features_at(T_w_a), fb = features_at(T_w_b);
  const Eigen::Isometry3d T_a_b = T_w_a.inverse() * T_w_b;

  const LoamResult fwd = loam_scan_to_scan(fa, fb, Eigen::Isometry3d::Identity());
  EXPECT_EQ(fwd.status, Status::kOk);
  EXPECT_TRUE(fwd.converged);
  EXPECT_GT(fwd.num_plane, 100u);
  EXPECT_GT(fwd.num_edge, 10u);
  EXPECT_LT(translation_error(fwd.T_prev_cur, T_a_b), 0.01);
  EXPECT_LT(rotation_error_deg(fwd.T_prev_cur, T_a_b), 0.1);

  const LoamResult inv = loam_scan_to_scan(fb, fa, Eigen::Isometry3d::Identity());
  EXPECT_EQ(inv.status, Status::kOk);
  EXPECT_LT(translation_error(inv.T_prev_cur, T_a_b.inverse()), 0.01);
  EXPECT_LT(rotation_error_deg(inv.T_prev_cur, T_a_b.inverse()), 0.1);
}

TEST(LoamOdometryTest, ScanToScanFromSeveralStarts) {
  const Eigen::Isometry3d T_w_a = Eigen::Isometry3d::Identity();
  const Eigen::Isometry3d T_w_b = pose(-0.2, 0.25, 0.0, -6.0, 0.3, 0.0);
  const LoamFeatures fa = features_at(T_w_a), fb = features_at(T_w_b);
  const Eigen::Isometry3d T_a_b = T_w_b;
  std::optional<Eigen::Isometry3d> first;
  for (const Eigen::Isometry3d& start :
       {Eigen::Isometry3d::Identity(), T_a_b * pose(0.15, 0.0, 0.0, 0.0, 0.0, 0.0),
        T_a_b * pose(0.0, -0.1, 0.05, 3.0, 0.0, 0.0), T_a_b * pose(0.05, 0.05, 0.0, -2.0, 1.0, -1.0)}) {
    const LoamResult r = loam_scan_to_scan(fa, fb, start);
    EXPECT_EQ(r.status, Status::kOk);
    // Every start reaches the same optimum ...
    if (first) {
      EXPECT_LT(translation_error(r.T_prev_cur, *first), 5e-3);
    }
    if (!first) first = r.T_prev_cur;
    // ... which for this motion is biased by ~3 cm / 0.15 deg (known limitation, open: the
    // sampled edge lines and j-l-m planes near pillar corners), hence the looser bound here.
    EXPECT_LT(translation_error(r.T_prev_cur, T_a_b), 0.04);
    EXPECT_LT(rotation_error_deg(r.T_prev_cur, T_a_b), 0.2);
  }
}

TEST(LoamOdometryTest, ScanToMapRecoversThePoseInTheMap) {
  // Map: features of two frames placed in the world frame with their true poses.
  PointCloud map_edges, map_planes;
  for (const Eigen::Isometry3d& T : {pose(0.0, 0.0, 0.0, 0.0, 0.0, 0.0), pose(1.0, 0.5, 0.0, 30.0, 0.0, 0.0)}) {
    const LoamFeatures f = features_at(T);
    for (const Vector3f& p : f.edge_pool.points) map_edges.points.push_back((T * p.cast<double>()).cast<float>());
    for (const Vector3f& p : f.plane_pool.points) map_planes.points.push_back((T * p.cast<double>()).cast<float>());
  }
  const LoamMap map(map_edges, map_planes);
  const Eigen::Isometry3d T_w_c = pose(0.5, 0.3, 0.02, 14.0, 0.5, -0.3);
  const LoamResult r = loam_scan_to_map(map, features_at(T_w_c), pose(0.35, 0.4, 0.0, 10.0, 0.0, 0.0));
  EXPECT_EQ(r.status, Status::kOk);
  EXPECT_GT(r.num_plane, 100u);
  EXPECT_LT(translation_error(r.T_prev_cur, T_w_c), 0.02);
  EXPECT_LT(rotation_error_deg(r.T_prev_cur, T_w_c), 0.2);
  // The association on several threads: the same correspondences, so the same result bit for bit.
  for (const int threads : {2, 3, 0}) {
    LoamSettings s;
    s.threads = threads;
    const LoamResult t = loam_scan_to_map(map, features_at(T_w_c), pose(0.35, 0.4, 0.0, 10.0, 0.0, 0.0), s);
    EXPECT_EQ(t.T_prev_cur.matrix(), r.T_prev_cur.matrix()) << threads;
    EXPECT_EQ(t.iterations, r.iterations) << threads;
    EXPECT_EQ(t.num_plane, r.num_plane) << threads;
    EXPECT_EQ(t.num_edge, r.num_edge) << threads;
  }
}

TEST(LoamOdometryTest, PointToPointIcpRecoversAnExactlyTransformedCloud) {
  const PointCloud prev = scan(Eigen::Isometry3d::Identity());
  PointCloud prev_sub;
  for (std::size_t i = 0; i < prev.size(); i += 7) prev_sub.points.push_back(prev.points[i]);
  const Eigen::Isometry3d T_prev_cur = pose(0.06, -0.04, 0.01, 1.0, 0.2, -0.1);
  const PointCloud cur = transformed(prev_sub, T_prev_cur.inverse());
  const KdTree3f tree(prev_sub);
  const LoamResult r = loam_icp_scan_to_scan(prev_sub, tree, cur, Eigen::Isometry3d::Identity());
  EXPECT_EQ(r.status, Status::kOk);
  EXPECT_EQ(r.num_point, cur.size());
  EXPECT_LT(translation_error(r.T_prev_cur, T_prev_cur), 1e-4);
  EXPECT_LT(rotation_error_deg(r.T_prev_cur, T_prev_cur), 1e-3);
  EXPECT_LT(r.rmse, 1e-3);
}

TEST(LoamOdometryTest, DegenerateInputGivesStatusNotCrash) {
  const LoamFeatures fa = features_at(Eigen::Isometry3d::Identity());
  const Eigen::Isometry3d guess = pose(0.1, 0.0, 0.0, 1.0, 0.0, 0.0);
  // Nothing to match.
  const LoamResult none = loam_scan_to_scan(fa, LoamFeatures{}, guess);
  EXPECT_EQ(none.status, Status::kInsufficientData);
  EXPECT_TRUE(none.T_prev_cur.isApprox(guess));
  EXPECT_EQ(loam_scan_to_scan(LoamFeatures{}, fa, guess).status, Status::kInsufficientData);
  // One ring: no l / m on another ring.
  PointCloud one_ring;
  const PointCloud full = scan(Eigen::Isometry3d::Identity());
  for (std::size_t i = 0; i < full.size(); ++i) {
    if (full.rings[i] == 9) {
      one_ring.points.push_back(full.points[i]);
      one_ring.rings.push_back(0);
    }
  }
  const LoamFeatures f1 = extract_loam_features(one_ring, image_settings(), LoamFeatureSettings{});
  EXPECT_EQ(f1.num_rings, 1);
  EXPECT_EQ(loam_scan_to_scan(f1, f1, guess).status, Status::kInsufficientData);
  // NaN query points are skipped.
  LoamFeatures with_nan = fa;
  with_nan.planes.points[0] = Vector3f::Constant(std::numeric_limits<float>::quiet_NaN());
  with_nan.edges.points[0] = Vector3f::Constant(std::numeric_limits<float>::quiet_NaN());
  const LoamResult r = loam_scan_to_scan(fa, with_nan, Eigen::Isometry3d::Identity());
  EXPECT_EQ(r.status, Status::kOk);
  EXPECT_LT(r.T_prev_cur.translation().norm(), 1e-3);
  // Misuse.
  LoamFeatures no_rings = fa;
  no_rings.plane_pool.rings.clear();
  EXPECT_THROW(loam_scan_to_scan(no_rings, fa, guess), Error);
  Eigen::Isometry3d bad = guess;
  bad.translation().x() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(loam_scan_to_scan(fa, fa, bad), Error);
  LoamSettings s;
  s.max_iterations = 0;
  EXPECT_THROW(loam_scan_to_scan(fa, fa, guess, s), Error);
  const LoamMap empty_map(PointCloud{}, PointCloud{});
  EXPECT_EQ(loam_scan_to_map(empty_map, fa, guess).status, Status::kInsufficientData);
}

TEST(LoamOdometryTest, NeighbourMomentsMatchADirectComputation) {
  // Points on a tilted line far from the origin, listed out of order, and a tenth point at the
  // origin that is not selected: the two-pass moments must match sums in long double, and a
  // line's covariance has one non-zero eigenvalue.
  PointCloud cloud;
  const Vector3d origin(120.0, -80.0, 3.0), dir = Vector3d(1.0, 2.0, 0.5).normalized();
  for (int i = 0; i < 9; ++i) cloud.points.push_back((origin + (0.1 * i) * dir).cast<float>());
  cloud.points.push_back(Vector3f(0.0f, 0.0f, 0.0f));  // not selected
  const std::size_t idx[] = {8, 0, 3, 5, 1, 7, 2, 6, 4};
  Vector3d mean;
  Matrix3d cov;
  loam_neighbour_moments(cloud, idx, 9, mean, cov);
  long double m[3] = {0, 0, 0};
  for (std::size_t i : idx) {
    for (int a = 0; a < 3; ++a) m[a] += static_cast<long double>(cloud.points[i](a)) / 9.0L;
  }
  for (int a = 0; a < 3; ++a) {
    EXPECT_NEAR(mean(a), static_cast<double>(m[a]), 1e-12);
    for (int b = 0; b < 3; ++b) {
      long double c = 0;
      for (std::size_t i : idx) {
        c += (cloud.points[i](a) - m[a]) * (cloud.points[i](b) - m[b]) / 9.0L;
      }
      EXPECT_NEAR(cov(a, b), static_cast<double>(c), 1e-12);
    }
  }
  const Eigen::SelfAdjointEigenSolver<Matrix3d> eig(cov);
  EXPECT_LT(eig.eigenvalues()(1), 1e-9);
  EXPECT_NEAR(eig.eigenvalues()(2), 0.0666667, 1e-4);  // var of 0, 0.1, ..., 0.8 = 0.4 * 1/6
  EXPECT_NEAR(std::abs(eig.eigenvectors().col(2).dot(dir)), 1.0, 1e-6);
  // One point: its own mean, zero covariance.
  loam_neighbour_moments(cloud, idx + 4, 1, mean, cov);
  EXPECT_TRUE(mean.isApprox(cloud.points[1].cast<double>()));
  EXPECT_EQ(cov, Matrix3d::Zero());
  // No point: a clear error, not a division by zero.
  EXPECT_THROW(loam_neighbour_moments(cloud, idx, 0, mean, cov), Error);
}

TEST(LoamOdometryTest, CorrespondenceWeightScalesItsResidual) {
  // Without a robust kernel (plain least squares) a weight w multiplies the residual, so the
  // cost, the normal matrix and the gradient all grow by w^2; weight 1 is the unweighted factor.
  const Eigen::Isometry3d T = pose(0.2, -0.1, 0.05, 5.0, 1.0, -2.0);
  std::vector<LoamCorrespondence> plain = {
      {LoamCorrespondence::Kind::kPlane, Vector3d(1.0, 2.0, 0.5), Vector3d(1.3, 1.9, 0.2), Vector3d::UnitZ()},
      {LoamCorrespondence::Kind::kEdge, Vector3d(-2.0, 1.0, 1.0), Vector3d(-1.8, 0.7, 0.0), Vector3d::UnitX()},
      {LoamCorrespondence::Kind::kPoint, Vector3d(0.5, -1.0, 2.0), Vector3d(0.8, -1.2, 2.1), Vector3d::Zero()}};
  for (const LoamCorrespondence& c : plain) EXPECT_EQ(c.weight, 1.0);
  for (std::size_t k = 0; k < plain.size(); ++k) {
    std::vector<LoamCorrespondence> one = {plain[k]}, heavy = {plain[k]};
    heavy[0].weight = 3.0;
    Matrix6d H1, H3, P1, P3;
    Vector6d g1, g3;
    double s1 = 0.0, s3 = 0.0;
    const double c1 = loam_detail::evaluate(one, T, RobustLoss::none(), &H1, &g1, &P1, &s1);
    const double c3 = loam_detail::evaluate(heavy, T, RobustLoss::none(), &H3, &g3, &P3, &s3);
    EXPECT_GT(c1, 1e-4) << k;
    EXPECT_NEAR(c3, 9.0 * c1, 1e-12) << k;
    EXPECT_NEAR(s3, 9.0 * s1, 1e-12) << k;
    EXPECT_LT((H3 - 9.0 * H1).norm(), 1e-9 * H1.norm()) << k;
    EXPECT_LT((g3 - 9.0 * g1).norm(), 1e-9 * g1.norm()) << k;
  }
}

}  // namespace
}  // namespace plumb
