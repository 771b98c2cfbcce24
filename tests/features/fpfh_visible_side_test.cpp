// SPDX-License-Identifier: BSD-3-Clause
// FPFH on the visible side only: a model sampled on both faces of a thin wall (and in the room
// behind it) must describe the front face exactly as a cloud that holds only what a sensor in front
// of the wall sees.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <random>
#include <utility>
#include <vector>

#include "plumb/core/error.hpp"
#include "plumb/features/fpfh.hpp"

namespace plumb {
namespace {

/// Room side: a wall face at y = 0 (normal +y), a floor at z = 0 for y > 0 (normal +z), a side wall
/// at x = 0 for y > 0 (normal +x). Behind the wall: its back face at y = -thickness (normal -y) and
/// the neighbouring room's floor (y < -thickness).
struct ThinWallScene {
  PointCloud front;  ///< what a sensor at y > 0 sees
  PointCloud all;    ///< front + the back face and the room behind
};

ThinWallScene make_scene(float thickness, bool next_room) {
  std::mt19937 gen(3);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  ThinWallScene s;
  auto add = [&](PointCloud& c, const Vector3f& p, const Vector3f& n) {
    c.points.push_back(p);
    c.normals.push_back(n);
  };
  for (int i = 0; i < 600; ++i) {
    add(s.front, {2.0f * u(gen), 0.0f, 1.5f * u(gen)}, {0, 1, 0});                 // wall face
    add(s.front, {2.0f * u(gen), 0.05f + 1.5f * u(gen), 0.0f}, {0, 0, 1});         // floor
    add(s.front, {0.0f, 0.05f + 1.5f * u(gen), 0.05f + 1.4f * u(gen)}, {1, 0, 0});  // side wall
  }
  s.all = s.front;
  for (int i = 0; i < 600; ++i) {
    add(s.all, {2.0f * u(gen), -thickness, 1.5f * u(gen)}, {0, -1, 0});                      // back face
    if (next_room) add(s.all, {2.0f * u(gen), -thickness - 0.05f - 1.5f * u(gen), 0.0f}, {0, 0, 1});  // its floor
  }
  return s;
}

/// Every neighbour within 0.6 m; visible side only when tolerance >= 0.
FpfhSettings thin_wall_settings(float tolerance) {
  FpfhSettings s;
  s.radius = 0.6f;
  s.max_neighbors = 0;
  s.visible_side_tolerance = tolerance;
  return s;
}

/// Mean and largest L1 distance between the descriptors of the front points in `model` and `scan`.
std::pair<double, double> front_distance(const FpfhResult& model, const FpfhResult& scan) {
  double sum = 0.0, largest = 0.0;
  for (std::size_t i = 0; i < scan.features.size(); ++i) {
    double d = 0.0;
    for (int b = 0; b < kFpfhBins; ++b) d += std::abs(static_cast<double>(model.features[i][b]) - scan.features[i][b]);
    sum += d;
    largest = std::max(largest, d);
  }
  return {sum / static_cast<double>(scan.features.size()), largest};
}

TEST(FpfhVisibleSideTest, ThinWallBackFaceIsLeftOutExactly) {
  // Only the back face behind the wall: every front point's neighbourhood, and its neighbours',
  // is exactly what the sensor sees.
  const ThinWallScene scene = make_scene(0.12f, false);
  const FpfhSettings plain = thin_wall_settings(-1.0f);
  const FpfhSettings visible = thin_wall_settings(0.05f);
  const FpfhResult scan = compute_fpfh(scene.front, plain);  // nothing hidden in it to drop
  EXPECT_LT(front_distance(compute_fpfh(scene.all, visible), scan).second, 1e-3);
  // Plain FPFH of the model differs: the back face changes the front descriptors.
  EXPECT_GT(front_distance(compute_fpfh(scene.all, plain), scan).first, 5.0);
}

TEST(FpfhVisibleSideTest, RoomBehindTheWallMostlyLeftOut) {
  // With the next room's floor coplanar with this one, floor points near the wall still pair with
  // it (no occlusion test), so the descriptors are close, not equal.
  const ThinWallScene scene = make_scene(0.12f, true);
  const FpfhSettings plain = thin_wall_settings(-1.0f);
  const FpfhSettings visible = thin_wall_settings(0.05f);
  const FpfhResult scan = compute_fpfh(scene.front, plain);
  const double d_visible = front_distance(compute_fpfh(scene.all, visible), scan).first;
  const double d_plain = front_distance(compute_fpfh(scene.all, plain), scan).first;
  EXPECT_LT(d_visible, 0.25 * d_plain);
}

TEST(FpfhVisibleSideTest, NegativeToleranceIsPlainFpfhAndNanIsRejected) {
  const ThinWallScene scene = make_scene(0.12f, true);
  FpfhSettings plain;
  plain.radius = 0.5f;
  FpfhSettings off = plain;
  off.visible_side_tolerance = -1.0f;
  const FpfhResult a = compute_fpfh(scene.all, plain), b = compute_fpfh(scene.all, off);
  ASSERT_EQ(a.features.size(), b.features.size());
  for (std::size_t i = 0; i < a.features.size(); ++i) EXPECT_EQ(a.features[i], b.features[i]);
  FpfhSettings bad = plain;
  bad.visible_side_tolerance = std::numeric_limits<float>::quiet_NaN();
  EXPECT_THROW(compute_fpfh(scene.all, bad), Error);
}

}  // namespace
}  // namespace plumb
