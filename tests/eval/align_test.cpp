// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/eval/align.hpp"

#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "plumb/core/error.hpp"
#include "plumb/core/lie.hpp"
#include "plumb/core/rng.hpp"

namespace plumb::eval {
namespace {

std::vector<Vector3d> random_points(std::size_t n, std::uint64_t seed) {
  Rng rng(seed);
  std::vector<Vector3d> points;
  for (std::size_t i = 0; i < n; ++i) {
    points.emplace_back(rng.uniform(-20, 20), rng.uniform(-20, 20), rng.uniform(-3, 3));
  }
  return points;
}

std::vector<Vector3d> transformed(const std::vector<Vector3d>& points, const Eigen::Isometry3d& T, double s) {
  std::vector<Vector3d> out;
  for (const Vector3d& p : points) out.push_back(s * (T.linear() * p) + T.translation());
  return out;
}

TEST(UmeyamaTest, RecoversKnownRigidTransform) {
  for (std::uint64_t seed = 1; seed <= 5; ++seed) {
    Rng rng(100 + seed);
    const Eigen::Isometry3d T = se3::make(
        so3::exp(Vector3d(rng.uniform(-3, 3), rng.uniform(-3, 3), rng.uniform(-3, 3)).normalized() *
                 rng.uniform(0.1, 3.1)),
        Vector3d(rng.uniform(-100, 100), rng.uniform(-100, 100), rng.uniform(-100, 100)));
    const auto source = random_points(50, seed);
    const auto target = transformed(source, T, 1.0);
    const UmeyamaResult r = umeyama(source, target, false);
    EXPECT_EQ(r.status, Status::kOk);
    EXPECT_EQ(r.scale, 1.0);
    EXPECT_LT((r.T_ref_est.matrix() - T.matrix()).cwiseAbs().maxCoeff(), 1e-11) << seed;
    EXPECT_LT(r.rmse, 1e-11);
    // And the inverse direction.
    const UmeyamaResult inv = umeyama(target, source, false);
    EXPECT_LT((inv.T_ref_est.matrix() - T.inverse().matrix()).cwiseAbs().maxCoeff(), 1e-11) << seed;
  }
}

TEST(UmeyamaTest, RecoversKnownSimilarity) {
  const Eigen::Isometry3d T = se3::make(so3::exp(Vector3d(0.3, -1.2, 2.0)), Vector3d(5, -7, 2));
  const auto source = random_points(40, 9);
  for (double s : {0.01, 0.8, 2.5, 40.0}) {
    const auto target = transformed(source, T, s);
    const UmeyamaResult r = umeyama(source, target, true);
    EXPECT_NEAR(r.scale, s, 1e-12 * s);
    EXPECT_LT((r.T_ref_est.linear() - T.linear()).cwiseAbs().maxCoeff(), 1e-12);
    EXPECT_LT((r.T_ref_est.translation() - T.translation()).norm(), 1e-10);
    // Without scale, the fit leaves a residual but keeps a proper rotation.
    const UmeyamaResult rigid = umeyama(source, target, false);
    EXPECT_EQ(rigid.scale, 1.0);
    if (s != 1.0) {
      EXPECT_GT(rigid.rmse, 1e-3);
    }
  }
}

TEST(UmeyamaTest, ScaleFitIsLeastSquaresUnderNoise) {
  // With noise the answer is no longer exact, but it is the least-squares optimum: perturbing it
  // in any direction does not lower the residual.
  Rng rng(5);
  const Eigen::Isometry3d T = se3::make(so3::exp(Vector3d(0.1, 0.2, -0.3)), Vector3d(1, 2, 3));
  const auto source = random_points(200, 3);
  auto target = transformed(source, T, 1.7);
  for (Vector3d& p : target) p += 0.05 * Vector3d(rng.normal(), rng.normal(), rng.normal());
  const UmeyamaResult r = umeyama(source, target, true);
  auto sse = [&](const Matrix3d& R, const Vector3d& t, double s) {
    double e = 0;
    for (std::size_t i = 0; i < source.size(); ++i) e += (target[i] - (s * (R * source[i]) + t)).squaredNorm();
    return e;
  };
  const double best = sse(r.T_ref_est.linear(), r.T_ref_est.translation(), r.scale);
  EXPECT_NEAR(std::sqrt(best / 200.0), r.rmse, 1e-12);
  for (int k = 0; k < 6; ++k) {
    Vector3d d = Vector3d::Zero();
    d(k % 3) = (k < 3 ? 1e-4 : -1e-4);
    EXPECT_GT(sse(so3::exp(d) * r.T_ref_est.linear(), r.T_ref_est.translation(), r.scale), best);
    EXPECT_GT(sse(r.T_ref_est.linear(), r.T_ref_est.translation() + 100 * d, r.scale), best);
  }
  EXPECT_GT(sse(r.T_ref_est.linear(), r.T_ref_est.translation(), r.scale * 1.001), best);
  EXPECT_GT(sse(r.T_ref_est.linear(), r.T_ref_est.translation(), r.scale * 0.999), best);
}

TEST(UmeyamaTest, MirroredTargetStillGivesRotation) {
  // The best orthogonal map to a mirror image is a reflection; Umeyama's sign fix returns the
  // best proper rotation instead.
  const auto source = random_points(30, 4);
  std::vector<Vector3d> target;
  for (const Vector3d& p : source) target.emplace_back(p.x(), p.y(), -p.z());
  const UmeyamaResult r = umeyama(source, target, true);
  EXPECT_NEAR(r.T_ref_est.linear().determinant(), 1.0, 1e-12);
  EXPECT_LT((r.T_ref_est.linear().transpose() * r.T_ref_est.linear() - Matrix3d::Identity()).norm(), 1e-12);
  EXPECT_GT(r.rmse, 0.1);
  EXPECT_GT(r.scale, 0.0);
}

TEST(UmeyamaTest, CollinearPointsAreDegenerate) {
  std::vector<Vector3d> source, target;
  for (int i = 0; i < 10; ++i) {
    source.emplace_back(i, 0, 0);
    target.emplace_back(0, i, 5);
  }
  const UmeyamaResult r = umeyama(source, target, false);
  EXPECT_EQ(r.status, Status::kDegenerate);
  // The line itself is still mapped exactly.
  EXPECT_LT(r.rmse, 1e-12);
  EXPECT_NEAR(r.T_ref_est.linear().determinant(), 1.0, 1e-12);
}

TEST(UmeyamaTest, BadInputThrows) {
  EXPECT_THROW(umeyama({}, {}, false), Error);
  EXPECT_THROW(umeyama({Vector3d::Zero()}, {Vector3d::Zero(), Vector3d::Ones()}, false), Error);
  EXPECT_THROW(umeyama({Vector3d::Ones(), Vector3d::Ones()}, {Vector3d::Zero(), Vector3d::Ones()}, true), Error);
}

TEST(AlignTrajectoryTest, AlignsPosesAndOrientations) {
  Trajectory ref;
  Rng rng(8);
  for (int i = 0; i < 30; ++i) {
    ref.push_back(i, se3::make(so3::exp(Vector3d(0, 0, 0.1 * i)),
                               Vector3d(10 * std::cos(0.2 * i), 10 * std::sin(0.2 * i), 0.1 * i)));
  }
  const Eigen::Isometry3d T_est_ref = se3::make(so3::exp(Vector3d(0.4, -0.2, 1.0)), Vector3d(3, 4, 5));
  const double s = 0.5;  // the estimate is at half scale
  Trajectory est = ref;
  for (auto& P : est.poses) {
    const Eigen::Isometry3d Q = P;
    P.linear() = T_est_ref.linear() * Q.linear();
    P.translation() = s * (T_est_ref.linear() * Q.translation()) + T_est_ref.translation();
  }
  const AlignResult sim3 = align_trajectory(est, ref, AlignMode::kSim3);
  EXPECT_NEAR(sim3.transform.scale, 1.0 / s, 1e-12);
  for (std::size_t i = 0; i < ref.size(); ++i) {
    EXPECT_LT((sim3.aligned.poses[i].matrix() - ref.poses[i].matrix()).cwiseAbs().maxCoeff(), 1e-11) << i;
  }
  EXPECT_EQ(sim3.aligned.stamps, ref.stamps);
  const AlignResult none = align_trajectory(est, ref, AlignMode::kNone);
  EXPECT_EQ(none.aligned.poses[3].matrix(), est.poses[3].matrix());
  EXPECT_THROW(align_trajectory(est, Trajectory{}, AlignMode::kSE3), Error);
}

}  // namespace
}  // namespace plumb::eval
