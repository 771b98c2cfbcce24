// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/segmentation/plane_ransac.hpp"

#include <cmath>
#include <limits>
#include <vector>

#include <gtest/gtest.h>

#include "plumb/core/rng.hpp"
#include "plumb/features/normals.hpp"
#include "plumb/io/cloud_io.hpp"
#include "plumb/segmentation/presegment.hpp"
#include "test_data.hpp"

namespace plumb {
namespace {

constexpr double kDeg = kPi / 180.0;

double angle_between_lines(const Vector3d& a, const Vector3d& b) {
  return std::acos(std::min(1.0, std::abs(a.normalized().dot(b.normalized()))));
}

/// Points on the plane n.x = d (square of half-size `half` around the foot point), Gaussian noise.
void add_plane(std::vector<Vector3f>& pts, const Vector3d& n_in, double d, double half, int count, double sigma,
               Rng& rng) {
  const Vector3d n = n_in.normalized();
  const Vector3d u = n.unitOrthogonal();
  const Vector3d v = n.cross(u);
  for (int i = 0; i < count; ++i) {
    const Vector3d p = d * n + rng.uniform(-half, half) * u + rng.uniform(-half, half) * v + rng.normal(0, sigma) * n;
    pts.push_back(p.cast<float>());
  }
}

void add_uniform(std::vector<Vector3f>& pts, double half, int count, Rng& rng) {
  for (int i = 0; i < count; ++i) {
    pts.emplace_back(static_cast<float>(rng.uniform(-half, half)), static_cast<float>(rng.uniform(-half, half)),
                     static_cast<float>(rng.uniform(-half, half)));
  }
}

// ---- eq. 8, 9, 12 ------------------------------------------------------------------------------

TEST(PresegmentTest, AnglesAndProjectionLengthMatchTheEquations) {
  EXPECT_NEAR(normal_axis_angle(Vector3f(0, 0, 2), Vector3d::UnitZ()), 0.0, 1e-12);
  EXPECT_NEAR(normal_axis_angle(Vector3f(0, 0, -1), Vector3d::UnitZ()), kPi, 1e-12);
  EXPECT_NEAR(normal_axis_angle(Vector3f(1, 0, 1), Vector3d(0, 0, 3)), kPi / 4, 1e-7);
  EXPECT_TRUE(std::isnan(normal_axis_angle(Vector3f::Zero(), Vector3d::UnitZ())));
  // l = |n . q| / |n|: the floor 1.3 m below the origin, whatever the point on it.
  EXPECT_NEAR(projection_length(Vector3f(4, -2, -1.3f), Vector3f(0, 0, 2)), 1.3, 1e-6);
  EXPECT_NEAR(projection_length(Vector3f(3, 1, 0), Vector3f(1, 1, 0)), 4.0 / std::sqrt(2.0), 1e-6);
  // eq. 12: a horizontal normal gives u parallel to z (angle 0), a vertical normal pi/2.
  EXPECT_NEAR(vertical_u_angle(Vector3f(0.6f, 0.8f, 0)), 0.0, 1e-7);
  EXPECT_NEAR(vertical_u_angle(Vector3f(1, 0, 0)), 0.0, 1e-7);  // u1 = 0 -> u2 = n x j
  EXPECT_NEAR(vertical_u_angle(Vector3f(0, 0, 1)), kPi / 2, 1e-7);
  // n = (0, cos a, sin a): u1 = n x i = (0, sin a, -cos a) -> angle a to z.
  const double a = 20 * kDeg;
  EXPECT_NEAR(vertical_u_angle(Vector3f(0, static_cast<float>(std::cos(a)), static_cast<float>(std::sin(a)))), a,
              1e-6);
}

TEST(PresegmentTest, SelectsByAngleAndLength) {
  const std::vector<Vector3f> pts = {{1, 0, -1.3f}, {1, 0, 1.7f}, {2, 0, -0.5f}, {3, 0, 0}, {0, 0, -1.3f}};
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const std::vector<Vector3f> normals = {{0, 0, 1}, {0, 0, -1}, {0, 0, 1}, {-1, 0, 0}, {nan, nan, nan}};
  PresegmentSettings s;
  s.max_angle = 10 * kDeg;
  EXPECT_EQ(presegment(pts, normals, s), (std::vector<std::size_t>{0, 2}));
  s.min_length = 1.0;
  s.max_length = 1.5;
  EXPECT_EQ(presegment(pts, normals, s), (std::vector<std::size_t>{0}));
  PresegmentSettings v;
  v.angle_kind = PresegmentAngle::kVerticalU;
  EXPECT_EQ(presegment(pts, normals, v), (std::vector<std::size_t>{3}));
  EXPECT_THROW(presegment(pts, std::vector<Vector3f>(2), s), Error);
}

// presegment() decides the angle window on cosines; the selection must be the one the angles of
// eq. 8 / eq. 12 give, also for normals exactly at a window's edge and for windows at 0 and pi.
TEST(PresegmentTest, CosineWindowSelectsAsTheAngles) {
  Rng rng(17);
  std::vector<Vector3f> pts, normals;
  const std::vector<double> edges = {-0.1, 0.0, 1e-6, 10 * kDeg, 15 * kDeg, 45 * kDeg, 90 * kDeg, 170 * kDeg, kPi, 4.0};
  for (int i = 0; i < 4000; ++i) {
    pts.emplace_back(rng.uniform(-5, 5), rng.uniform(-5, 5), rng.uniform(-3, 3));
    Vector3d n(rng.normal(), rng.normal(), rng.normal());
    if (i % 3 == 0) {  // exactly at an edge angle to z (as exactly as float allows)
      const double a = edges[rng.uniform_index(edges.size())], phi = rng.uniform(0, 2 * kPi);
      n = Vector3d(std::sin(a) * std::cos(phi), std::sin(a) * std::sin(phi), std::cos(a));
    }
    if (i % 7 == 0) n = Vector3d::UnitZ();
    if (i % 11 == 0) n = Vector3d(1, 0, 0);
    if (i % 101 == 0) n.setZero();
    normals.push_back(n.cast<float>());
  }
  for (const PresegmentAngle kind : {PresegmentAngle::kNormalToAxis, PresegmentAngle::kVerticalU}) {
    for (double lo : edges) {
      for (double hi : edges) {
        PresegmentSettings s;
        s.angle_kind = kind;
        s.axis = Vector3d(0, 0, 2);
        s.min_angle = lo;
        s.max_angle = hi;
        std::vector<std::size_t> expected;
        for (std::size_t i = 0; i < pts.size(); ++i) {
          const double theta = kind == PresegmentAngle::kNormalToAxis ? normal_axis_angle(normals[i], s.axis)
                                                                       : vertical_u_angle(normals[i]);
          if (theta >= lo && theta <= hi) expected.push_back(i);
        }
        ASSERT_EQ(presegment(pts, normals, s), expected) << "lo " << lo << " hi " << hi;
      }
    }
  }
}

// ---- RANSAC ------------------------------------------------------------------------------------

TEST(PlaneRansacTest, RecoversPlaneAmongOutliers) {
  Rng rng(1);
  std::vector<Vector3f> pts;
  const Vector3d n(0.2, -0.3, 0.93);
  add_plane(pts, n, -1.2, 4.0, 3000, 0.01, rng);
  add_uniform(pts, 5.0, 3000, rng);  // 50 % outliers
  PlaneRansacSettings s;
  s.distance_threshold = 0.03;
  const PlaneRansacResult r = fit_plane_ransac(pts, {}, {}, s);
  ASSERT_EQ(r.status, Status::kOk);
  EXPECT_LT(angle_between_lines(r.plane.normal, n), 0.5 * kDeg);
  EXPECT_NEAR(std::abs(r.plane.offset), 1.2, 0.01);
  EXPECT_LE(r.plane.offset, 0.0);  // normal toward the origin
  // Every plane point within 3 sigma is found; few outliers fall inside the 6 cm slab (~0.6 %).
  EXPECT_GE(r.inliers.size(), 2950u);
  EXPECT_LE(r.inliers.size(), 3100u);
  EXPECT_TRUE(r.converged);
  EXPECT_LT(r.iterations, 100);  // w ~ 0.5: ~35 draws for 99 %
  EXPECT_NEAR(r.rmse, 0.01, 0.004);
  // Same seed, same result; candidate subset restricts the search.
  const PlaneRansacResult again = fit_plane_ransac(pts, {}, {}, s);
  EXPECT_EQ(again.inliers, r.inliers);
  EXPECT_EQ(again.plane.normal, r.plane.normal);
  std::vector<std::size_t> outliers_only;
  for (std::size_t i = 3000; i < 6000; ++i) outliers_only.push_back(i);
  const PlaneRansacResult sub = fit_plane_ransac(pts, outliers_only, {}, s);
  for (std::size_t i : sub.inliers) EXPECT_GE(i, 3000u);
}

TEST(PlaneRansacTest, AxisConstraintPicksTheHorizontalPlaneNotTheLargest) {
  Rng rng(2);
  std::vector<Vector3f> pts;
  add_plane(pts, Vector3d(1, 0, 0), -3.0, 3.0, 4000, 0.005, rng);  // large wall
  add_plane(pts, Vector3d(0.05, 0, 1), -1.5, 3.0, 1500, 0.005, rng);  // floor tilted 2.9 deg
  PlaneRansacSettings s;
  s.constraint = AxisConstraint::kPerpendicular;
  s.max_axis_angle = 5 * kDeg;
  const PlaneRansacResult floor = fit_plane_ransac(pts, {}, {}, s);
  ASSERT_EQ(floor.status, Status::kOk);
  EXPECT_LT(angle_between_lines(floor.plane.normal, Vector3d(0.05, 0, 1)), 0.2 * kDeg);
  EXPECT_GT(floor.plane.normal.z(), 0.0);  // toward the origin above it
  EXPECT_GE(floor.inliers.size(), 1450u);
  s.max_axis_angle = 1 * kDeg;  // the floor's tilt now violates the constraint: at best a band
  const PlaneRansacResult band = fit_plane_ransac(pts, {}, {}, s);
  if (band.status == Status::kOk) {
    EXPECT_LT(angle_between_lines(band.plane.normal, Vector3d::UnitZ()), 1 * kDeg + 1e-9);
    EXPECT_LT(band.inliers.size(), 700u);
  }
  s.constraint = AxisConstraint::kParallel;
  s.max_axis_angle = 5 * kDeg;
  const PlaneRansacResult wall = fit_plane_ransac(pts, {}, {}, s);
  ASSERT_EQ(wall.status, Status::kOk);
  EXPECT_LT(angle_between_lines(wall.plane.normal, Vector3d::UnitX()), 0.2 * kDeg);
  EXPECT_GE(wall.inliers.size(), 3950u);
}

TEST(PlaneRansacTest, PointNormalSamplingFindsASmallPlaneFast) {
  Rng rng(3);
  std::vector<Vector3f> pts;
  std::vector<Vector3f> normals;
  // Five walls of 400 points each: each holds 20 % of the candidates.
  for (int k = 0; k < 5; ++k) {
    const double a = k * 0.6;
    add_plane(pts, Vector3d(std::cos(a), std::sin(a), 0), -2.0 - k, 2.0, 400, 0.005, rng);
    for (int i = 0; i < 400; ++i) {
      normals.push_back(Vector3f(static_cast<float>(std::cos(a)), static_cast<float>(std::sin(a)), 0.02f).normalized());
    }
  }
  PlaneRansacSettings s;
  s.sampling = PlaneSampling::kPointNormal;
  s.constraint = AxisConstraint::kParallel;
  const PlaneRansacResult r = fit_plane_ransac(pts, {}, normals, s);
  ASSERT_EQ(r.status, Status::kOk);
  EXPECT_GE(r.inliers.size(), 395u);
  EXPECT_LE(r.inliers.size(), 400u + 20u);
  EXPECT_LT(r.iterations, 40);  // log(0.01) / log(0.8) = 21 draws
  EXPECT_THROW(fit_plane_ransac(pts, {}, {}, s), Error);  // needs normals
}

TEST(PlaneRansacTest, TooFewOrDegeneratePointsGiveStatus) {
  PlaneRansacSettings s;
  EXPECT_EQ(fit_plane_ransac({}, {}, {}, s).status, Status::kInsufficientData);
  EXPECT_EQ(fit_plane_ransac({{0, 0, 0}, {1, 0, 0}}, {}, {}, s).status, Status::kInsufficientData);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  EXPECT_EQ(fit_plane_ransac({{nan, 0, 0}, {nan, nan, nan}, {0, 0, 0}, {1, 1, 1}}, {}, {}, s).status,
            Status::kInsufficientData);
  std::vector<Vector3f> line;
  for (int i = 0; i < 50; ++i) line.emplace_back(static_cast<float>(i), 0.0f, 0.0f);
  const PlaneRansacResult r = fit_plane_ransac(line, {}, {}, s);
  EXPECT_EQ(r.status, Status::kDegenerate);
  EXPECT_EQ(r.iterations, s.max_iterations);
  Plane p;
  EXPECT_FALSE(fit_plane_least_squares(line, {}, p));
}

TEST(PlaneRansacTest, InvalidSettingsAndIndicesThrow) {
  const std::vector<Vector3f> pts = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  PlaneRansacSettings s;
  s.distance_threshold = 0.0;
  EXPECT_THROW(fit_plane_ransac(pts, {}, {}, s), Error);
  s = {};
  s.max_iterations = 0;
  EXPECT_THROW(fit_plane_ransac(pts, {}, {}, s), Error);
  s = {};
  s.confidence = 1.5;
  EXPECT_THROW(fit_plane_ransac(pts, {}, {}, s), Error);
  s = {};
  s.axis = Vector3d::Zero();
  EXPECT_THROW(fit_plane_ransac(pts, {}, {}, s), Error);
  EXPECT_THROW(fit_plane_ransac(pts, {0, 7}, {}, PlaneRansacSettings{}), Error);
  EXPECT_THROW(fit_plane_ransac(pts, {}, std::vector<Vector3f>(2), PlaneRansacSettings{}), Error);
}

TEST(PlaneRansacTest, LeastSquaresIsExactOnNoiseFreePoints) {
  Rng rng(4);
  std::vector<Vector3f> pts;
  const Vector3d n = Vector3d(-0.3, 0.4, 0.5).normalized();
  add_plane(pts, n, 2.5, 3.0, 200, 0.0, rng);
  Plane p;
  double rmse = 1.0;
  ASSERT_TRUE(fit_plane_least_squares(pts, {}, p, &rmse));
  EXPECT_LT(angle_between_lines(p.normal, n), 1e-5);
  EXPECT_NEAR(std::abs(p.offset), 2.5, 1e-5);
  EXPECT_LT(rmse, 1e-5);
}

// PCL's own sample-consensus plane test cloud. The file carries PCL's normals: the plane RANSAC
// finds must agree with PCL's normals of the inlier points (an independent estimate).
TEST(PlaneRansacTest, SacPlaneTestAgreesWithPclNormals) {
  PLUMB_REQUIRE_DATA(path, "cloud3d/pcl_test/sac_plane_test.pcd");
  const PointCloud cloud = io::read_cloud(path);
  ASSERT_EQ(cloud.size(), 3283u);
  ASSERT_TRUE(cloud.has_normals());
  PlaneRansacSettings s;
  s.distance_threshold = 0.03;
  const PlaneRansacResult r = fit_plane_ransac(cloud.points, {}, {}, s);
  ASSERT_EQ(r.status, Status::kOk);
  EXPECT_GT(r.inliers.size(), cloud.size() / 2);
  Vector3d mean = Vector3d::Zero();
  for (std::size_t i : r.inliers) {
    Vector3d nn = cloud.normals[i].cast<double>();
    if (nn.dot(r.plane.normal) < 0) nn = -nn;
    mean += nn;
  }
  EXPECT_LT(angle_between_lines(mean, r.plane.normal), 3 * kDeg);
  // With PCL's normals as agreement test, the same plane comes out.
  s.max_normal_angle = 20 * kDeg;
  const PlaneRansacResult with_normals = fit_plane_ransac(cloud.points, {}, cloud.normals, s);
  ASSERT_EQ(with_normals.status, Status::kOk);
  EXPECT_LT(angle_between_lines(with_normals.plane.normal, r.plane.normal), 3 * kDeg);
}

// The dominant plane of PCL's table scene (the table) is stable: other seeds find the same plane.
TEST(PlaneRansacTest, TableSceneDominantPlaneIsStableAcrossSeeds) {
  PLUMB_REQUIRE_DATA(path, "cloud3d/pcl_test/table_scene_mug_stereo_textured.pcd");
  const PointCloud cloud = io::read_cloud(path);
  PlaneRansacSettings s;
  s.distance_threshold = 0.02;
  s.max_iterations = 200;
  const PlaneRansacResult a = fit_plane_ransac(cloud.points, {}, {}, s);
  s.seed = 1234;
  const PlaneRansacResult b = fit_plane_ransac(cloud.points, {}, {}, s);
  ASSERT_EQ(a.status, Status::kOk);
  ASSERT_EQ(b.status, Status::kOk);
  const std::size_t finite = cloud.finite_indices().size();
  EXPECT_GT(a.inliers.size(), finite / 4);
  EXPECT_LT(angle_between_lines(a.plane.normal, b.plane.normal), 2 * kDeg);  // noisy stereo table
  EXPECT_NEAR(a.plane.offset, b.plane.offset, 0.02);
  EXPECT_LT(a.rmse, s.distance_threshold / std::sqrt(3.0) + 1e-3);
}

}  // namespace
}  // namespace plumb
