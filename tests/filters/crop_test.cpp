// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/filters/crop.hpp"

#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include <gtest/gtest.h>

#include "plumb/core/error.hpp"
#include "plumb/core/lie.hpp"
#include "plumb/core/rng.hpp"

namespace plumb {
namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
constexpr float kInf = std::numeric_limits<float>::infinity();

PointCloud random_cloud(std::uint64_t seed, std::size_t n, double lo, double hi) {
  Rng rng(seed);
  PointCloud c;
  for (std::size_t i = 0; i < n; ++i) {
    const float x = static_cast<float>(rng.uniform(lo, hi));
    const float y = static_cast<float>(rng.uniform(lo, hi));
    const float z = static_cast<float>(rng.uniform(lo, hi));
    c.points.emplace_back(x, y, z);
    c.normals.push_back(Vector3f(x, y, z + 10.0f).normalized());
    c.intensities.push_back(static_cast<float>(i));
    c.rings.push_back(static_cast<std::uint16_t>(i % 32));
    c.times.push_back(static_cast<float>(i) * 1e-5f);
    c.labels.push_back(static_cast<std::int32_t>(i) - 100);
  }
  return c;
}

void expect_fields_copied(const PointCloud& src, const CropResult& r) {
  ASSERT_EQ(r.cloud.size(), r.indices.size());
  EXPECT_NO_THROW(r.cloud.check_consistent());
  for (std::size_t k = 0; k < r.indices.size(); ++k) {
    const std::size_t i = r.indices[k];
    if (k > 0) {
      EXPECT_LT(r.indices[k - 1], i);  // source order
    }
    EXPECT_EQ(r.cloud.points[k], src.points[i]);
    EXPECT_EQ(r.cloud.normals[k], src.normals[i]);
    EXPECT_EQ(r.cloud.intensities[k], src.intensities[i]);
    EXPECT_EQ(r.cloud.rings[k], src.rings[i]);
    EXPECT_EQ(r.cloud.times[k], src.times[i]);
    EXPECT_EQ(r.cloud.labels[k], src.labels[i]);
  }
}

// ---- crop_box -------------------------------------------------------------------------------

TEST(CropBoxTest, MatchesBruteForceAndNegativeIsTheComplement) {
  const PointCloud cloud = random_cloud(1, 5000, -3.0, 3.0);
  CropBoxSettings s;
  s.min = Vector3d(-1.0, -2.5, 0.2);
  s.max = Vector3d(1.5, 0.5, 2.0);
  std::vector<std::size_t> inside, outside;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const Vector3f& p = cloud.points[i];
    const bool in = p.x() >= -1.0 && p.x() <= 1.5 && p.y() >= -2.5 && p.y() <= 0.5 && p.z() >= 0.2 &&
                    p.z() <= 2.0;
    (in ? inside : outside).push_back(i);
  }
  ASSERT_GT(inside.size(), 100u);
  const CropResult r = crop_box(cloud, s);
  EXPECT_EQ(r.indices, inside);
  EXPECT_EQ(r.status, Status::kOk);
  EXPECT_EQ(r.num_dropped_non_finite, 0u);
  expect_fields_copied(cloud, r);
  s.negative = true;
  const CropResult neg = crop_box(cloud, s);
  EXPECT_EQ(neg.indices, outside);
  expect_fields_copied(cloud, neg);
}

TEST(CropBoxTest, BoundsAreInclusive) {
  PointCloud cloud;
  cloud.points = {Vector3f(0, 0, 0), Vector3f(1, 1, 1), Vector3f(1.0000001f, 0.5f, 0.5f),
                  Vector3f(0.5f, -1e-7f, 0.5f), Vector3f(0.5f, 0.5f, 0.5f)};
  CropBoxSettings s;
  s.min = Vector3d(0, 0, 0);
  s.max = Vector3d(1, 1, 1);
  EXPECT_EQ(crop_box(cloud, s).indices, (std::vector<std::size_t>{0, 1, 4}));
  s.negative = true;
  EXPECT_EQ(crop_box(cloud, s).indices, (std::vector<std::size_t>{2, 3}));
}

TEST(CropBoxTest, PosedBoxKeepsPointsInsideInTheBoxFrame) {
  // Points drawn in the box frame, clearly inside or clearly outside (10 cm margin), then mapped
  // into the cloud frame with T_cloud_box; crop_box with T_box_cloud must recover the split.
  Rng rng(7);
  const Eigen::Isometry3d T_cloud_box =
      se3::exp((Vector6d() << 3.0, -1.0, 0.5, 0.3, -0.2, 1.1).finished());
  const Vector3d lo(-1.0, -0.5, -0.25), hi(2.0, 0.5, 0.75);
  PointCloud cloud;
  std::vector<std::size_t> inside;
  while (cloud.size() < 3000) {
    const Vector3d q(rng.uniform(-2.0, 3.0), rng.uniform(-1.5, 1.5), rng.uniform(-1.0, 1.5));
    const Vector3d dist_in = (q - lo).cwiseMin(hi - q);  // > 0 on an axis: inside on that axis
    const double margin = dist_in.minCoeff();
    if (std::abs(margin) < 0.1) continue;
    if (margin > 0) inside.push_back(cloud.size());
    cloud.points.push_back((T_cloud_box * q).cast<float>());
  }
  ASSERT_GT(inside.size(), 100u);
  CropBoxSettings s;
  s.min = lo;
  s.max = hi;
  s.T_box_cloud = T_cloud_box.inverse();
  const CropResult r = crop_box(cloud, s);
  EXPECT_EQ(r.indices, inside);
  // Without the pose the axis-aligned box in the cloud frame selects something else.
  s.T_box_cloud.reset();
  EXPECT_NE(crop_box(cloud, s).indices, inside);
}

TEST(CropBoxTest, NonFinitePointsAreDroppedAndCountedInBothModes) {
  PointCloud cloud = random_cloud(3, 200, -1.0, 1.0);
  cloud.points[3] = Vector3f(kNaN, 0, 0);
  cloud.points[50] = Vector3f(0, kInf, 0);
  cloud.points[199] = Vector3f(0, 0, -kInf);
  for (bool negative : {false, true}) {
    CropBoxSettings s;
    s.min = Vector3d(-0.5, -0.5, -0.5);
    s.max = Vector3d(0.5, 0.5, 0.5);
    s.negative = negative;
    const CropResult r = crop_box(cloud, s);
    EXPECT_EQ(r.num_dropped_non_finite, 3u);
    for (std::size_t i : r.indices) EXPECT_TRUE(cloud.points[i].allFinite());
    expect_fields_copied(cloud, r);
  }
  // Default settings (infinite box) keep exactly the finite points.
  const CropResult all = crop_box(cloud);
  EXPECT_EQ(all.cloud.size(), 197u);
  EXPECT_EQ(all.num_dropped_non_finite, 3u);
}

TEST(CropBoxTest, EmptyInputAndEmptyCropGiveStatusNotException) {
  const CropResult r = crop_box(PointCloud{});
  EXPECT_TRUE(r.cloud.empty());
  EXPECT_EQ(r.status, Status::kInsufficientData);
  PointCloud cloud;
  cloud.points = {Vector3f(5, 5, 5)};
  CropBoxSettings s;
  s.min = Vector3d::Zero();
  s.max = Vector3d::Ones();
  const CropResult none = crop_box(cloud, s);
  EXPECT_TRUE(none.cloud.empty());
  EXPECT_EQ(none.status, Status::kInsufficientData);
}

TEST(CropBoxTest, InvalidSettingsThrow) {
  const PointCloud cloud = random_cloud(4, 10, -1.0, 1.0);
  CropBoxSettings s;
  s.min = Vector3d(0, 0, 0);
  s.max = Vector3d(1, -1, 1);  // min > max on y
  EXPECT_THROW(crop_box(cloud, s), Error);
  s.max = Vector3d(1, std::nan(""), 1);
  EXPECT_THROW(crop_box(cloud, s), Error);
  s.max = Vector3d(1, 1, 1);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation().x() = std::numeric_limits<double>::infinity();
  s.T_box_cloud = T;
  EXPECT_THROW(crop_box(cloud, s), Error);
  PointCloud inconsistent = cloud;
  inconsistent.labels.pop_back();
  EXPECT_THROW(crop_box(inconsistent), Error);
}

// ---- range_filter --------------------------------------------------------------------------

TEST(RangeFilterTest, MatchesBruteForceAroundAnOrigin) {
  const PointCloud cloud = random_cloud(5, 5000, -10.0, 10.0);
  RangeFilterSettings s;
  s.min_range = 2.0;
  s.max_range = 7.5;
  s.origin = Vector3d(1.0, -2.0, 0.5);
  std::vector<std::size_t> expected;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const double r = (cloud.points[i].cast<double>() - s.origin).norm();
    if (r >= 2.0 && r <= 7.5) expected.push_back(i);
  }
  ASSERT_GT(expected.size(), 100u);
  const CropResult r = range_filter(cloud, s);
  EXPECT_EQ(r.indices, expected);
  EXPECT_EQ(r.status, Status::kOk);
  expect_fields_copied(cloud, r);
}

TEST(RangeFilterTest, BoundsAreInclusiveAndDefaultsKeepAllFinite) {
  PointCloud cloud;
  cloud.points = {Vector3f(2, 0, 0), Vector3f(0, -4, 0), Vector3f(0, 0, 1.999f), Vector3f(0, 4.001f, 0),
                  Vector3f(3, 0, 0), Vector3f(kNaN, 0, 0), Vector3f(0, 0, 0)};
  RangeFilterSettings s;
  s.min_range = 2.0;
  s.max_range = 4.0;
  const CropResult r = range_filter(cloud, s);
  EXPECT_EQ(r.indices, (std::vector<std::size_t>{0, 1, 4}));
  EXPECT_EQ(r.num_dropped_non_finite, 1u);
  const CropResult all = range_filter(cloud);
  EXPECT_EQ(all.indices, (std::vector<std::size_t>{0, 1, 2, 3, 4, 6}));
  EXPECT_EQ(all.num_dropped_non_finite, 1u);
  EXPECT_EQ(range_filter(PointCloud{}).status, Status::kInsufficientData);
}

TEST(RangeFilterTest, InvalidSettingsThrow) {
  const PointCloud cloud = random_cloud(6, 10, -1.0, 1.0);
  auto with = [](double lo, double hi) {
    RangeFilterSettings s;
    s.min_range = lo;
    s.max_range = hi;
    return s;
  };
  EXPECT_THROW(range_filter(cloud, with(-0.1, 1.0)), Error);
  EXPECT_THROW(range_filter(cloud, with(2.0, 1.0)), Error);
  EXPECT_THROW(range_filter(cloud, with(std::nan(""), 1.0)), Error);
  EXPECT_THROW(range_filter(cloud, with(0.0, std::nan(""))), Error);
  RangeFilterSettings s;
  s.origin = Vector3d(0, std::numeric_limits<double>::infinity(), 0);
  EXPECT_THROW(range_filter(cloud, s), Error);
  PointCloud inconsistent = cloud;
  inconsistent.times.push_back(0.0f);
  EXPECT_THROW(range_filter(inconsistent), Error);
}

}  // namespace
}  // namespace plumb
