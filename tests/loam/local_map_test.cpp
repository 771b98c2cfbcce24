// SPDX-License-Identifier: BSD-3-Clause
// The bounded voxel hash map of the LiDAR/IMU odometry, and the map association's rejection of
// collinear "planes".
#include "plumb/loam/local_map.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <tuple>

#include <gtest/gtest.h>

#include "plumb/core/error.hpp"
#include "plumb/core/rng.hpp"
#include "plumb/loam/odometry.hpp"

namespace plumb {
namespace {

TEST(VoxelHashMapTest, CapsPointsPerVoxelLikeABruteForceCount) {
  VoxelHashMapSettings s;
  s.voxel_size = 0.5;
  s.max_points_per_voxel = 3;
  VoxelHashMap map(s);
  Rng rng(7);
  std::vector<Vector3f> pts;
  for (int i = 0; i < 2000; ++i) {
    pts.emplace_back(static_cast<float>(rng.uniform(-2.0, 2.0)), static_cast<float>(rng.uniform(-2.0, 2.0)),
                     static_cast<float>(rng.uniform(-0.5, 0.5)));
  }
  pts.emplace_back(std::numeric_limits<float>::quiet_NaN(), 0.f, 0.f);
  map.insert(pts);
  // Oracle: the first 3 points of every voxel, counted independently.
  std::map<std::tuple<int, int, int>, int> count;
  std::size_t expected = 0;
  for (const Vector3f& p : pts) {
    if (!p.allFinite()) continue;
    const auto k = std::make_tuple(static_cast<int>(std::floor(p.x() / 0.5)), static_cast<int>(std::floor(p.y() / 0.5)),
                                   static_cast<int>(std::floor(p.z() / 0.5)));
    if (count[k]++ < 3) ++expected;
  }
  EXPECT_EQ(map.num_voxels(), count.size());
  EXPECT_EQ(map.num_points(), expected);
  EXPECT_EQ(map.points().size(), expected);
  // Inserting the same points again adds nothing: every voxel is full or keeps its first points.
  const std::vector<Vector3f> before = map.points();
  map.insert(pts);
  EXPECT_EQ(map.points(), before);
}

TEST(VoxelHashMapTest, PruneDropsFarVoxelsAndKeepsTheNearestWithinTheCap) {
  VoxelHashMapSettings s;
  s.voxel_size = 1.0;
  s.max_points_per_voxel = 1;
  s.max_distance = 10.0;
  s.max_voxels = 5;
  VoxelHashMap map(s);
  std::vector<Vector3f> line;
  for (int i = 0; i < 30; ++i) line.emplace_back(static_cast<float>(i) + 0.5f, 0.5f, 0.5f);
  map.insert(line);
  EXPECT_EQ(map.num_voxels(), 30u);
  map.prune(Vector3d(0.5, 0.5, 0.5));
  ASSERT_EQ(map.num_voxels(), 5u);  // 11 voxels within 10 m, the 5 nearest kept
  const std::vector<Vector3f> kept = map.points();
  for (std::size_t i = 0; i < kept.size(); ++i) EXPECT_FLOAT_EQ(kept[i].x(), static_cast<float>(i) + 0.5f);
  // Far away: everything goes.
  map.prune(Vector3d(100.0, 0.0, 0.0));
  EXPECT_TRUE(map.empty());
  EXPECT_EQ(map.num_voxels(), 0u);
}

// max_age: a window of frames moving along x, each inserted then pruned; the map equals an
// independent model of "voxels that got a point in the last max_age prunes, with their points"
// after every frame. Full voxels age too and are refilled afresh once dropped.
TEST(VoxelHashMapTest, MaxAgeKeepsWhatRecentFramesFilled) {
  VoxelHashMapSettings s;
  s.voxel_size = 1.0;
  s.max_points_per_voxel = 2;
  s.max_distance = 1e6;
  s.max_age = 3;
  VoxelHashMap map(s);
  struct Model {
    std::vector<Vector3f> points;
    int last = 0;
  };
  std::map<std::tuple<int, int, int>, Model> model;
  Rng rng(11);
  std::size_t dropped_full = 0;
  for (int frame = 0; frame < 40; ++frame) {
    // Frames overlap: each covers x in [0.5 f, 0.5 f + 4) and revisits the origin every 10 frames.
    const double x0 = frame % 10 == 9 ? 0.0 : 0.5 * frame;
    std::vector<Vector3f> pts;
    for (int i = 0; i < 60; ++i)
      pts.emplace_back(static_cast<float>(rng.uniform(x0, x0 + 4.0)), static_cast<float>(rng.uniform(0.0, 2.0)), 0.5f);
    map.insert(pts);
    for (const Vector3f& p : pts) {
      const auto k = std::make_tuple(static_cast<int>(std::floor(p.x())), static_cast<int>(std::floor(p.y())), 0);
      Model& m = model[k];
      if (m.points.size() < 2) {
        m.points.push_back(p);
        m.last = frame;
      }
    }
    map.prune(Vector3d::Zero());
    for (auto it = model.begin(); it != model.end();) {
      if (frame - it->second.last >= 3) {
        dropped_full += it->second.points.size() == 2 ? 1 : 0;
        it = model.erase(it);
      } else {
        ++it;
      }
    }
    std::size_t n = 0;
    for (const auto& kv : model) n += kv.second.points.size();
    ASSERT_EQ(map.num_voxels(), model.size()) << "frame " << frame;
    ASSERT_EQ(map.num_points(), n) << "frame " << frame;
    std::vector<Vector3f> got = map.points(), want;
    for (const auto& kv : model) want.insert(want.end(), kv.second.points.begin(), kv.second.points.end());
    auto less = [](const Vector3f& a, const Vector3f& b) {
      return std::make_tuple(a.x(), a.y(), a.z()) < std::make_tuple(b.x(), b.y(), b.z());
    };
    std::sort(got.begin(), got.end(), less);
    std::sort(want.begin(), want.end(), less);
    ASSERT_EQ(got, want) << "frame " << frame;
  }
  EXPECT_GT(dropped_full, 10u);  // full voxels did age out (and the revisits refilled some)
  // No age limit: nothing is ever dropped near the centre.
  s.max_age = 0;
  VoxelHashMap keep(s);
  keep.insert({Vector3f(0.5f, 0.5f, 0.5f)});
  for (int i = 0; i < 100; ++i) keep.prune(Vector3d::Zero());
  EXPECT_EQ(keep.num_points(), 1u);
}

TEST(VoxelHashMapTest, BadSettingsThrow) {
  VoxelHashMapSettings s;
  s.voxel_size = 0.0;
  EXPECT_THROW(VoxelHashMap{s}, Error);
  s = {};
  s.max_points_per_voxel = 0;
  EXPECT_THROW(VoxelHashMap{s}, Error);
  s = {};
  s.max_distance = -1.0;
  EXPECT_THROW(VoxelHashMap{s}, Error);
}

TEST(LoamAssociateMapTest, PlanesNeedTwoDirectionsOfSpread) {
  // Map plane points on one straight line with noise across it (a single scan ring of the road):
  // no normal is defined, so no plane residual may come out. On a grid they give z-normals.
  PointCloud line, grid, none;
  for (int i = 0; i < 200; ++i) {  // a thin helix: 1 cm around the x axis, 5 points per turn
    const double a = 2.0 * 3.14159265358979323846 * i / 5.0;
    line.points.emplace_back(0.02f * static_cast<float>(i), static_cast<float>(0.01 * std::cos(a)),
                             static_cast<float>(0.01 * std::sin(a)));
  }
  for (int i = 0; i < 20; ++i) {
    for (int k = 0; k < 20; ++k) grid.points.emplace_back(0.2f * static_cast<float>(i), 0.2f * static_cast<float>(k), 0.f);
  }
  LoamFeatures cur;
  for (int i = 0; i < 30; ++i) cur.planes.points.emplace_back(0.1f * static_cast<float>(i) + 0.05f, 0.01f, 0.01f);
  LoamSettings s;
  std::vector<LoamCorrespondence> out;
  loam_associate_map(LoamMap(none, line), cur, Eigen::Isometry3d::Identity(), s, out);
  EXPECT_TRUE(out.empty());
  s.map_plane_ratio = 1.0;  // the check off: rounding decides the "normal"
  loam_associate_map(LoamMap(none, line), cur, Eigen::Isometry3d::Identity(), s, out);
  EXPECT_FALSE(out.empty());
  out.clear();
  s = {};
  loam_associate_map(LoamMap(none, grid), cur, Eigen::Isometry3d::Identity(), s, out);
  ASSERT_EQ(out.size(), cur.planes.size());
  for (const LoamCorrespondence& c : out) {
    EXPECT_EQ(c.kind, LoamCorrespondence::Kind::kPlane);
    EXPECT_NEAR(std::abs(c.dir.z()), 1.0, 1e-9);
  }
}

}  // namespace
}  // namespace plumb
