// SPDX-License-Identifier: BSD-3-Clause
#include <cmath>
#include <limits>
#include <set>
#include <string>

#include <gtest/gtest.h>

#include "plumb/core/error.hpp"
#include "plumb/core/lie.hpp"
#include "plumb/core/point_cloud.hpp"
#include "plumb/core/rng.hpp"
#include "plumb/core/status.hpp"
#include "plumb/core/trajectory.hpp"

namespace plumb {
namespace {

TEST(ErrorTest, CheckThrowsWithStreamedMessageAndPlace) {
  const int n = 3;
  try {
    PLUMB_CHECK(n == 4, "file.pcd:12: expected 4, got " << n);
    FAIL() << "PLUMB_CHECK did not throw";
  } catch (const Error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("file.pcd:12: expected 4, got 3"), std::string::npos) << what;
    EXPECT_EQ(what, "file.pcd:12: expected 4, got 3");
  }
  try {
    PLUMB_CHECK(n == 5, "");
    FAIL() << "PLUMB_CHECK did not throw";
  } catch (const Error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("n == 5"), std::string::npos) << what;
    EXPECT_NE(what.find("core_types_test.cpp"), std::string::npos) << what;
  }
  EXPECT_NO_THROW(PLUMB_CHECK(n == 3, "never"));
  EXPECT_THROW(PLUMB_THROW("boom " << 1), Error);
}

TEST(StatusTest, NamesAreDistinct) {
  std::set<std::string> names;
  for (Status s : {Status::kOk, Status::kNotConverged, Status::kInsufficientData, Status::kDegenerate,
                   Status::kRejected, Status::kInvalidInput}) {
    names.insert(to_string(s));
  }
  EXPECT_EQ(names.size(), 6u);
  EXPECT_STREQ(to_string(Status::kOk), "ok");
}

TEST(PointCloudTest, SelectCopiesPresentFieldsInOrder) {
  PointCloud c;
  c.points = {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}};
  c.intensities = {10, 11, 12};
  c.labels = {7, 8, 9};
  const PointCloud s = c.select({2, 0});
  ASSERT_EQ(s.size(), 2u);
  EXPECT_EQ(s.points[0].x(), 2.f);
  EXPECT_EQ(s.intensities[1], 10.f);
  EXPECT_EQ(s.labels[0], 9);
  EXPECT_FALSE(s.has_normals());
  EXPECT_THROW(c.select({3}), Error);
}

TEST(PointCloudTest, InconsistentFieldThrows) {
  PointCloud c;
  c.points = {{0, 0, 0}, {1, 0, 0}};
  c.times = {0.f};
  EXPECT_THROW(c.check_consistent("test"), Error);
  c.times = {0.f, 0.1f};
  EXPECT_NO_THROW(c.check_consistent("test"));
}

TEST(PointCloudTest, FiniteIndicesSkipNanAndInf) {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float inf = std::numeric_limits<float>::infinity();
  PointCloud c;
  c.points = {{0, 0, 0}, {nan, 0, 0}, {1, inf, 0}, {1, 1, 1}};
  EXPECT_EQ(c.finite_indices(), (std::vector<std::size_t>{0, 3}));
}

TEST(PointCloudTest, TransformMovesPointsAndRotatesNormals) {
  PointCloud c;
  c.points = {{1, 0, 0}};
  c.normals = {{1, 0, 0}};
  Vector6d xi;
  xi << 1, 2, 3, 0, 0, 1.5707963267948966;
  const PointCloud t = transformed(c, se3::exp(xi));
  const Vector3d expected = se3::exp(xi) * Vector3d(1, 0, 0);
  EXPECT_LT((t.points[0].cast<double>() - expected).norm(), 1e-6);
  EXPECT_LT((t.normals[0] - Vector3f(0, 1, 0)).norm(), 1e-6);
}

TEST(TrajectoryTest, ConsistencyCheck) {
  Trajectory t;
  t.push_back(0.0, Eigen::Isometry3d::Identity());
  EXPECT_NO_THROW(t.check_consistent());
  t.poses.push_back(Eigen::Isometry3d::Identity());
  EXPECT_THROW(t.check_consistent(), Error);
}

TEST(RngTest, SameSeedSameSequenceAndSaneMoments) {
  Rng a(123), b(123), c(124);
  bool differs = false;
  for (int i = 0; i < 100; ++i) {
    const double x = a.uniform();
    EXPECT_EQ(x, b.uniform());
    differs |= (x != c.uniform());
  }
  EXPECT_TRUE(differs);
  Rng r(9);
  double sum = 0, sum_sq = 0;
  const int n = 200000;
  for (int i = 0; i < n; ++i) {
    const double x = r.normal();
    sum += x;
    sum_sq += x * x;
  }
  EXPECT_NEAR(sum / n, 0.0, 0.01);
  EXPECT_NEAR(sum_sq / n, 1.0, 0.02);
  std::vector<int> counts(7, 0);
  for (int i = 0; i < 70000; ++i) ++counts[r.uniform_index(7)];
  for (int k : counts) EXPECT_NEAR(k, 10000, 500);
}

}  // namespace
}  // namespace plumb
