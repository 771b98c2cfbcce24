// SPDX-License-Identifier: BSD-3-Clause
// Pose2's operators against Liu et al. 2022, eq. 13, written out by hand, and against homogeneous matrices.
#include <cmath>

#include <gtest/gtest.h>

#include "plumb/core/pose2.hpp"
#include "plumb/core/rng.hpp"

namespace plumb {
namespace {


Pose2 random_pose(Rng& rng) {
  return {rng.uniform(-10, 10), rng.uniform(-10, 10), rng.uniform(-kPi, kPi)};
}

void expect_pose_near(const Pose2& a, const Pose2& b, double tol) {
  EXPECT_NEAR(a.x, b.x, tol);
  EXPECT_NEAR(a.y, b.y, tol);
  EXPECT_NEAR(wrap_angle(a.theta - b.theta), 0.0, tol);
}

TEST(Pose2Test, OplusIsEquation13) {
  const Pose2 a{1.5, -2.0, 0.7}, b{0.3, 0.9, -0.2};
  const Pose2 c = a.oplus(b);
  EXPECT_DOUBLE_EQ(c.x, 1.5 + 0.3 * std::cos(0.7) - 0.9 * std::sin(0.7));
  EXPECT_DOUBLE_EQ(c.y, -2.0 + 0.3 * std::sin(0.7) + 0.9 * std::cos(0.7));
  EXPECT_DOUBLE_EQ(c.theta, 0.5);
}

TEST(Pose2Test, OminusIsEquation13) {
  const Pose2 a{1.5, -2.0, 0.7};
  const Pose2 inv = a.ominus();
  EXPECT_DOUBLE_EQ(inv.x, -1.5 * std::cos(0.7) - (-2.0) * std::sin(0.7));
  EXPECT_DOUBLE_EQ(inv.y, 1.5 * std::sin(0.7) - (-2.0) * std::cos(0.7));
  EXPECT_DOUBLE_EQ(inv.theta, -0.7);
}

TEST(Pose2Test, OperatorsMatchHomogeneousMatrices) {
  Rng rng(1);
  for (int i = 0; i < 200; ++i) {
    const Pose2 a = random_pose(rng), b = random_pose(rng);
    EXPECT_LT((a.oplus(b).matrix() - a.matrix() * b.matrix()).norm(), 1e-12);
    EXPECT_LT((a.ominus().matrix() - a.matrix().inverse()).norm(), 1e-12);
  }
}

TEST(Pose2Test, GroupProperties) {
  Rng rng(2);
  for (int i = 0; i < 200; ++i) {
    const Pose2 a = random_pose(rng), b = random_pose(rng), c = random_pose(rng);
    expect_pose_near(a.oplus(a.ominus()), Pose2{}, 1e-12);
    expect_pose_near(a.ominus().oplus(a), Pose2{}, 1e-12);
    expect_pose_near(a.oplus(b).oplus(c), a.oplus(b.oplus(c)), 1e-12);
    expect_pose_near(a.oplus(b).ominus(), b.ominus().oplus(a.ominus()), 1e-12);
  }
}

TEST(Pose2Test, RelativeMotionRecoversSecondPose) {
  // r = ⊖q_k ⊕ q_k+1 (Liu et al. 2022, sec. 3.1), so q_k ⊕ r == q_k+1.
  Rng rng(3);
  for (int i = 0; i < 100; ++i) {
    const Pose2 qk = random_pose(rng), qk1 = random_pose(rng);
    const Pose2 r = qk.ominus().oplus(qk1);
    expect_pose_near(qk.oplus(r), qk1, 1e-12);
  }
}

TEST(Pose2Test, IsometryRoundTripAndPointAction) {
  Rng rng(4);
  for (int i = 0; i < 100; ++i) {
    const Pose2 a = random_pose(rng);
    expect_pose_near(Pose2::from_isometry(a.to_isometry()), a, 1e-12);
    const Vector2d p(rng.uniform(-5, 5), rng.uniform(-5, 5));
    const Vector3d p3 = a.to_isometry() * Vector3d(p.x(), p.y(), 0.0);
    EXPECT_NEAR((a * p - p3.head<2>()).norm(), 0.0, 1e-12);
  }
}

TEST(Pose2Test, WrapAngle) {
  EXPECT_NEAR(wrap_angle(3 * kPi), kPi, 1e-12);
  EXPECT_NEAR(wrap_angle(-kPi), kPi, 1e-12);
  EXPECT_NEAR(wrap_angle(kPi + 0.1), -kPi + 0.1, 1e-12);
  EXPECT_NEAR(wrap_angle(-7.0), -7.0 + 2 * kPi, 1e-12);
  EXPECT_DOUBLE_EQ(wrap_angle(0.25), 0.25);
  // In range: returned bit for bit (fmod's round trip would change the last bits of some).
  for (double a : {0.1, -0.3, 1e-17, kPi, -kPi + 1e-12, 2.9999999999999996}) EXPECT_EQ(wrap_angle(a), a) << a;
}

}  // namespace
}  // namespace plumb
