// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/pipeline/pose_composer.hpp"

#include <cmath>
#include <cstdio>

#include <gtest/gtest.h>

#include "plumb/core/error.hpp"
#include "plumb/core/lie.hpp"
#include "plumb/core/rng.hpp"

namespace {

using Eigen::Isometry3d;
using plumb::AnchorDecision;
using plumb::Matrix6d;
using plumb::PoseComposer;
using plumb::Vector6d;

Isometry3d pose(double x, double y, double yaw, double z = 0.0) {
  Isometry3d T = Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(x, y, z);
  return T;
}

Matrix6d diag(double t, double r) {
  Vector6d d;
  d << t, t, t, r, r, r;
  return d.asDiagonal();
}

TEST(ChiSquareTest, QuantilesMatchTables) {
  // Standard table values (e.g. NIST/SEMATECH e-Handbook, table of chi-square critical values).
  EXPECT_NEAR(plumb::chi_square_quantile(0.95, 1), 3.841, 1e-3);
  EXPECT_NEAR(plumb::chi_square_quantile(0.99, 2), 9.210, 1e-3);
  EXPECT_NEAR(plumb::chi_square_quantile(0.999, 3), 16.266, 1e-3);
  EXPECT_NEAR(plumb::chi_square_quantile(0.999, 6), 22.458, 1e-3);
  EXPECT_NEAR(plumb::chi_square_quantile(0.5, 4), 3.357, 1e-3);
  EXPECT_NEAR(plumb::chi_square_quantile(0.05, 6), 1.635, 1e-3);
  EXPECT_THROW(plumb::chi_square_quantile(1.0, 3), plumb::Error);
  EXPECT_THROW(plumb::chi_square_quantile(0.9, 0), plumb::Error);
}

TEST(PoseComposerTest, WithoutAnchorsIsTheChainedProduct) {
  plumb::Rng rng(3);
  const Isometry3d T0 = pose(1, 2, 0.3, 0.5);
  PoseComposer composer(T0, diag(1e-4, 1e-5));
  Isometry3d expected = T0;
  Matrix6d P = diag(1e-4, 1e-5);
  for (int k = 0; k < 200; ++k) {
    Vector6d xi;
    for (int i = 0; i < 6; ++i) xi(i) = rng.uniform(-0.2, 0.2);
    const Isometry3d step = plumb::se3::exp(xi);
    const Matrix6d Q = diag(1e-4 * (k % 3 + 1), 1e-6);
    composer.add_motion(step, Q);
    expected = expected * step;
    const Matrix6d Ad = plumb::se3::adjoint(expected);
    P += Ad * Q * Ad.transpose();
  }
  EXPECT_LT((composer.pose().matrix() - expected.matrix()).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_LT((composer.covariance() - P).cwiseAbs().maxCoeff(), 1e-9 * P.cwiseAbs().maxCoeff());
  EXPECT_EQ(composer.num_accepted() + composer.num_rejected(), 0u);
}

TEST(PoseComposerTest, ScalarCaseIsTheKalmanUpdate) {
  // One translation axis: prior variance p, measurement variance m: x' = x + p/(p+m) (z - x).
  const double p = 0.04, m = 0.01;
  Matrix6d P0 = diag(1e-2, 1e-2);
  P0(0, 0) = p;
  PoseComposer composer(pose(0, 0, 0), P0);
  Matrix6d info = Matrix6d::Zero();
  info(0, 0) = 1.0 / m;
  const auto r = composer.add_anchor(pose(0.1, 0, 0), info);
  ASSERT_EQ(r.decision, AnchorDecision::kAccepted);
  EXPECT_EQ(r.dof, 1);
  EXPECT_NEAR(composer.pose().translation().x(), p / (p + m) * 0.1, 1e-12);
  EXPECT_NEAR(composer.covariance()(0, 0), p * m / (p + m), 1e-12);
  EXPECT_NEAR(r.mahalanobis_sq, 0.1 * 0.1 / (p + m), 1e-9);
  // Unconstrained directions keep their variance.
  EXPECT_NEAR(composer.covariance()(1, 1), 1e-2, 1e-15);
}

TEST(PoseComposerTest, StrongAnchorIsThePapersCorrection) {
  // Λ -> ∞: M <- M_e · M exactly (Liu et al. 2022, sec. 3.3, step (5)).
  PoseComposer composer(pose(0, 0, 0), diag(1.0, 0.1));
  composer.add_motion(pose(2.0, 0.3, 0.2), diag(1e-2, 1e-3));
  const Isometry3d before = composer.pose();
  const Isometry3d M_e = pose(0.05, -0.03, 0.01);
  const auto r = composer.add_correction(M_e, diag(1e12, 1e12));
  ASSERT_EQ(r.decision, AnchorDecision::kAccepted);
  EXPECT_LT(((M_e * before).matrix() - composer.pose().matrix()).cwiseAbs().maxCoeff(), 1e-9);
}

TEST(PoseComposerTest, CorridorAnchorLeavesTheAxisUncorrected) {
  // A corridor along world x: the BIM fixes y, z and the rotation, nothing along x.
  PoseComposer composer(pose(0, 0, 0), diag(0.01, 0.001));
  Matrix6d info = diag(1e4, 1e4);
  info(0, 0) = 0.0;
  const auto r = composer.add_anchor(pose(0.08, 0.06, 0.0), info);
  ASSERT_EQ(r.decision, AnchorDecision::kAccepted);
  EXPECT_EQ(r.dof, 5);
  EXPECT_NEAR(composer.pose().translation().x(), 0.0, 1e-12);
  EXPECT_NEAR(composer.pose().translation().y(), 0.06 * 0.01 / (0.01 + 1e-4), 1e-9);
  EXPECT_NEAR(composer.covariance()(0, 0), 0.01, 1e-12);
}

TEST(PoseComposerTest, GateRejectsInconsistentAnchorsThenRecovers) {
  plumb::PoseComposerSettings s;
  s.max_consecutive_rejections = 3;
  PoseComposer composer(pose(0, 0, 0), diag(1e-4, 1e-6), s);
  // 2 m off with a 1 cm prior and a 1 cm measurement: a wrong BIM match.
  const auto bad = composer.add_anchor(pose(2.0, 0, 0), diag(1e4, 1e6));
  EXPECT_EQ(bad.decision, AnchorDecision::kRejected);
  EXPECT_GT(bad.mahalanobis_sq, bad.gate);
  EXPECT_LT(composer.pose().translation().norm(), 1e-15);
  // A consistent one passes.
  const auto good = composer.add_anchor(pose(0.01, 0, 0), diag(1e4, 1e6));
  EXPECT_EQ(good.decision, AnchorDecision::kAccepted);
  // Wheels slipped 0.5 m unnoticed: the anchors agree with each other, not with the composer.
  for (int i = 0; i < 3; ++i) EXPECT_EQ(composer.add_anchor(pose(0.5, 0, 0), diag(1e4, 1e6)).decision, AnchorDecision::kRejected);
  const auto recovered = composer.add_anchor(pose(0.5, 0, 0), diag(1e4, 1e6));
  EXPECT_TRUE(recovered.inflated);
  EXPECT_EQ(recovered.decision, AnchorDecision::kAccepted);
  EXPECT_NEAR(composer.pose().translation().x(), 0.5, 0.01);
  EXPECT_EQ(composer.num_rejected(), 4u);
  EXPECT_EQ(composer.num_accepted(), 2u);
}

TEST(PoseComposerTest, ZeroInformationIsIgnored) {
  PoseComposer composer(pose(1, 1, 1), diag(1e-2, 1e-2));
  const auto r = composer.add_anchor(pose(5, 5, 0), Matrix6d::Zero());
  EXPECT_EQ(r.decision, AnchorDecision::kIgnored);
  EXPECT_LT((composer.pose().matrix() - pose(1, 1, 1).matrix()).cwiseAbs().maxCoeff(), 1e-15);
}

TEST(PoseComposerTest, AnchorsBoundTheDriftOfABiasedOdometry) {
  // The truth drives a square loop; the odometry over-reads distance by 1 % and turns 0.5 % too much;
  // every 10th frame a BIM anchor with 1 cm / 0.2° noise about the robot (body frame). Odometry alone
  // drifts, anchored stays close.
  plumb::Rng rng(11);
  Isometry3d truth = pose(0, 0, 0);
  PoseComposer anchored(truth, diag(1e-6, 1e-8)), odometry(truth, diag(1e-6, 1e-8));
  const Matrix6d Q = plumb::planar_covariance(Eigen::Vector3d(4e-4, 4e-4, 1e-4).asDiagonal());
  const double sigma_t = 0.01, sigma_r = 0.2 * M_PI / 180;
  Matrix6d info = Matrix6d::Zero();
  info.diagonal() << 1 / (sigma_t * sigma_t), 1 / (sigma_t * sigma_t), 1 / (sigma_t * sigma_t),
      1 / (sigma_r * sigma_r), 1 / (sigma_r * sigma_r), 1 / (sigma_r * sigma_r);
  double worst_anchored = 0.0, worst_odometry = 0.0, anchored_at_anchors = 0.0;
  for (int k = 1; k <= 400; ++k) {
    const bool turn = k % 50 == 0;
    const Isometry3d step = turn ? pose(0.1, 0, M_PI / 2) : pose(0.1, 0, 0);
    const Isometry3d measured = turn ? pose(0.101, 0, M_PI / 2 * 1.005) : pose(0.101, 0, 0);
    truth = truth * step;
    anchored.add_motion(measured, Q);
    odometry.add_motion(measured, Q);
    if (k % 10 == 0) {
      Vector6d noise;
      for (int i = 0; i < 3; ++i) noise(i) = sigma_t * rng.normal();
      for (int i = 3; i < 6; ++i) noise(i) = sigma_r * rng.normal();
      const auto r = anchored.add_anchor(truth * plumb::se3::exp(noise),
                                         plumb::body_to_world_information(truth, info));
      EXPECT_EQ(r.decision, AnchorDecision::kAccepted) << "frame " << k;
      anchored_at_anchors =
          std::max(anchored_at_anchors, (anchored.pose().translation() - truth.translation()).norm());
    }
    worst_anchored = std::max(worst_anchored, (anchored.pose().translation() - truth.translation()).norm());
    worst_odometry = std::max(worst_odometry, (odometry.pose().translation() - truth.translation()).norm());
  }
  EXPECT_GT(worst_odometry, 0.15);
  EXPECT_LT(worst_anchored, 0.05);
  EXPECT_LT(anchored_at_anchors, 0.035);  // anchor noise: 1 cm per axis, max of 40 draws
}

TEST(PoseComposerTest, BadInputThrows) {
  EXPECT_THROW(PoseComposer(pose(0, 0, 0), Matrix6d::Zero()), plumb::Error);  // not definite
  Isometry3d nan_pose = pose(0, 0, 0);
  nan_pose.translation().x() = NAN;
  EXPECT_THROW(PoseComposer(nan_pose, diag(1, 1)), plumb::Error);
  PoseComposer composer(pose(0, 0, 0), diag(1, 1));
  Matrix6d asym = diag(1, 1);
  asym(0, 1) = 0.5;
  EXPECT_THROW(composer.add_motion(pose(1, 0, 0), asym), plumb::Error);
  EXPECT_THROW(composer.add_motion(pose(1, 0, 0), -diag(1, 1)), plumb::Error);
  EXPECT_THROW(composer.add_anchor(nan_pose, diag(1, 1)), plumb::Error);
  Isometry3d scaled = pose(0, 0, 0);
  scaled.linear() *= 2.0;
  EXPECT_THROW(composer.add_motion(scaled, diag(1, 1)), plumb::Error);
  plumb::PoseComposerSettings s;
  s.gate_probability = 1.0;
  EXPECT_THROW(PoseComposer(pose(0, 0, 0), diag(1, 1), s), plumb::Error);
  // Nothing changed by the failed calls.
  EXPECT_LT(composer.pose().translation().norm(), 1e-15);
}

}  // namespace
