// SPDX-License-Identifier: BSD-3-Clause
// Synthetic tests of the odometry/laser calibration: simulated differential-drive motion with known
// wheel radii, axle and laser pose; the laser motion is made exactly as s = ⊖l ⊕ r ⊕ l (Liu et al.
// 2022, eq. 13-14) with the robot arc r computed here from its centre of rotation.

#include <cmath>
#include <vector>

#include <Eigen/Eigenvalues>
#include <gtest/gtest.h>

#include "plumb/calibration/odometry_laser.hpp"
#include "plumb/core/error.hpp"
#include "plumb/core/rng.hpp"

namespace {

using plumb::CalibrationTuple;
using plumb::kPi;
using plumb::OdometryLaserParams;
using plumb::Pose2;
using plumb::Status;


const OdometryLaserParams kTruth{0.0205, 0.0208, 0.088, Pose2{0.031, -0.012, -1.52}};

/// Robot motion over T with constant wheel speeds, written independently of the library: the
/// wheels' ground speeds give v and ω; the robot turns about the point (0, v/ω) by ωT.
Pose2 arc(const OdometryLaserParams& p, double T, double phi_l, double phi_r) {
  const double v_l = p.radius_left * phi_l, v_r = p.radius_right * phi_r;
  const double v = 0.5 * (v_l + v_r), w = (v_r - v_l) / p.axle;
  const double th = w * T;
  if (std::abs(w) < 1e-15) return {v * T, 0.0, 0.0};
  const double R = v / w;  // signed turning radius
  return {R * std::sin(th), R * (1.0 - std::cos(th)), th};
}

enum class Motion { kMixed, kStraight, kSpin };

/// Tuples of random wheel speeds; the laser motion is exact, plus Gaussian noise of the given std.
std::vector<CalibrationTuple> simulate(const OdometryLaserParams& p, int n, std::uint64_t seed,
                                       const plumb::Vector3d& noise_std, Motion motion = Motion::kMixed) {
  plumb::Rng rng(seed);
  std::vector<CalibrationTuple> tuples;
  for (int k = 0; k < n; ++k) {
    CalibrationTuple t;
    t.T = rng.uniform(0.5, 1.0);
    const double base = rng.uniform(-1.0, 1.0);
    switch (motion) {
      case Motion::kStraight:
        t.phi_left = t.phi_right = base;
        break;
      case Motion::kSpin:
        t.phi_left = base;
        t.phi_right = -base;
        break;
      case Motion::kMixed:
        // a third turn on the spot, a third go straight-ish, a third drive arcs
        if (k % 3 == 0) {
          t.phi_left = base;
          t.phi_right = -base + rng.uniform(-0.05, 0.05);
        } else if (k % 3 == 1) {
          t.phi_left = base;
          t.phi_right = base + rng.uniform(-0.05, 0.05);
        } else {
          t.phi_left = base;
          t.phi_right = rng.uniform(-1.0, 1.0);
        }
        break;
    }
    const Pose2 r = arc(p, t.T, t.phi_left, t.phi_right);
    const Pose2 s = p.laser.ominus().oplus(r).oplus(p.laser);
    t.laser_motion = Pose2{s.x + noise_std(0) * rng.normal(), s.y + noise_std(1) * rng.normal(),
                           s.theta + noise_std(2) * rng.normal()};
    tuples.push_back(t);
  }
  return tuples;
}

void expect_zero_result(const plumb::OdometryLaserCalibrationResult& r) {
  EXPECT_TRUE(r.params.vector().allFinite());
  EXPECT_TRUE(r.covariance.allFinite());
  EXPECT_EQ(r.params.vector(), plumb::Vector6d::Zero());
}

TEST(DifferentialDriveTest, ArcMatchesComposedSmallSteps) {
  // The closed-form arc equals the composition (⊕, Liu et al. 2022, eq. 13) of many short straight steps.
  for (const auto& [pl, pr] : {std::pair{0.7, 0.2}, std::pair{-0.4, 0.9}, std::pair{0.5, 0.5},
                               std::pair{0.8, -0.8}}) {
    const double T = 0.9;
    const Pose2 closed = plumb::differential_drive_motion(kTruth.radius_left, kTruth.radius_right,
                                                          kTruth.axle, T, pl, pr);
    const int n = 20000;
    const double dt = T / n;
    const double v = 0.5 * (kTruth.radius_left * pl + kTruth.radius_right * pr);
    const double w = (kTruth.radius_right * pr - kTruth.radius_left * pl) / kTruth.axle;
    Pose2 q;
    for (int i = 0; i < n; ++i) {
      // midpoint step: half turn, straight, half turn
      q = q.oplus(Pose2{0, 0, 0.5 * w * dt}).oplus(Pose2{v * dt, 0, 0}).oplus(Pose2{0, 0, 0.5 * w * dt});
    }
    EXPECT_NEAR(closed.x, q.x, 1e-9);
    EXPECT_NEAR(closed.y, q.y, 1e-9);
    EXPECT_NEAR(closed.theta, q.theta, 1e-12);
    const Pose2 indep = arc(kTruth, T, pl, pr);
    EXPECT_NEAR(closed.x, indep.x, 1e-15);
    EXPECT_NEAR(closed.y, indep.y, 1e-15);
  }
}

TEST(OdometryLaserCalibrationTest, RecoversExactParametersWithoutNoise) {
  for (const OdometryLaserParams& truth :
       {kTruth, OdometryLaserParams{0.1, 0.098, 0.45, Pose2{0.2, 0.05, 0.3}},
        OdometryLaserParams{0.03, 0.03, 0.2, Pose2{-0.1, 0.0, kPi}}}) {
    const auto tuples = simulate(truth, 60, 7, plumb::Vector3d::Zero());
    const auto est = plumb::calibrate_odometry_laser(tuples);
    ASSERT_EQ(est.status, Status::kOk);
    const plumb::Vector6d err = est.params.vector() - truth.vector();
    EXPECT_LT(std::abs(err(0)), 1e-9);
    EXPECT_LT(std::abs(err(1)), 1e-9);
    EXPECT_LT(std::abs(err(2)), 1e-9);
    EXPECT_LT(std::abs(err(3)), 1e-9);
    EXPECT_LT(std::abs(err(4)), 1e-9);
    EXPECT_LT(std::abs(plumb::wrap_angle(err(5))), 1e-9);
    EXPECT_NEAR(est.j21, -truth.radius_left / truth.axle, 1e-9);
    EXPECT_NEAR(est.j22, truth.radius_right / truth.axle, 1e-9);
    EXPECT_EQ(est.solves, 5);
    // The model reproduces every laser motion.
    for (const auto& t : tuples) {
      const Pose2 s = plumb::predicted_laser_motion(est.params, t);
      EXPECT_NEAR(s.x, t.laser_motion.x, 1e-9);
      EXPECT_NEAR(s.y, t.laser_motion.y, 1e-9);
    }
  }
}

TEST(OdometryLaserCalibrationTest, NoisyEstimateWithinThreeSigmaOfTruth) {
  const plumb::Vector3d noise(0.002, 0.002, 0.005);  // 2 mm, 2 mm, 0.3 deg
  const auto tuples = simulate(kTruth, 400, 11, noise);
  const auto est = plumb::calibrate_odometry_laser(tuples);
  ASSERT_EQ(est.status, Status::kOk);
  const plumb::Vector6d err = est.params.vector() - kTruth.vector();
  for (int j = 0; j < 6; ++j) {
    const double sigma = std::sqrt(est.covariance(j, j));
    ASSERT_GT(sigma, 0.0);
    EXPECT_LT(std::abs(err(j)), 3.0 * sigma) << "parameter " << j << " err " << err(j) << " sigma " << sigma;
  }
  // The estimated scan-matcher noise is the simulated one (within sampling error and trimming).
  for (int i = 0; i < 3; ++i) {
    EXPECT_GT(est.laser_noise_std(i), 0.85 * noise(i));
    EXPECT_LT(est.laser_noise_std(i), 1.15 * noise(i));
  }
  EXPECT_GT(est.num_inliers, 0.9 * tuples.size());
  EXPECT_LT(est.num_inliers, tuples.size());
  // Covariance is symmetric positive definite.
  EXPECT_LT((est.covariance - est.covariance.transpose()).norm(), 1e-12 * est.covariance.norm());
  EXPECT_GT(Eigen::SelfAdjointEigenSolver<plumb::Matrix6d>(est.covariance).eigenvalues()(0), 0.0);
}

TEST(OdometryLaserCalibrationTest, CovarianceMatchesMonteCarloSpread) {
  // Over independent noise draws the normalised errors (est - truth) / sigma should have RMS ~ 1:
  // the covariance is neither much too optimistic nor much too pessimistic.
  const plumb::Vector3d noise(0.002, 0.002, 0.005);
  const int runs = 40;
  plumb::Vector6d sum_sq = plumb::Vector6d::Zero();
  for (int run = 0; run < runs; ++run) {
    const auto tuples = simulate(kTruth, 200, 100 + run, noise);
    const auto est = plumb::calibrate_odometry_laser(tuples);
    ASSERT_EQ(est.status, Status::kOk);
    const plumb::Vector6d err = est.params.vector() - kTruth.vector();
    for (int j = 0; j < 6; ++j) sum_sq(j) += err(j) * err(j) / est.covariance(j, j);
  }
  for (int j = 0; j < 6; ++j) {
    const double rms = std::sqrt(sum_sq(j) / runs);
    EXPECT_GT(rms, 0.6) << "parameter " << j;
    EXPECT_LT(rms, 1.5) << "parameter " << j;
  }
}

TEST(OdometryLaserCalibrationTest, GrossOutliersAreRejected) {
  const plumb::Vector3d noise(0.001, 0.001, 0.002);
  auto tuples = simulate(kTruth, 300, 5, noise);
  // Corrupt 1 % of the tuples badly (a scan-matching failure): they must not spoil the estimate.
  for (std::size_t k = 0; k < tuples.size(); k += 100) {
    tuples[k].laser_motion.x += 0.3;
    tuples[k].laser_motion.theta += 0.5;
  }
  const auto est = plumb::calibrate_odometry_laser(tuples);
  ASSERT_EQ(est.status, Status::kOk);
  for (std::size_t k = 0; k < tuples.size(); k += 100) EXPECT_FALSE(est.inlier[k]) << k;
  const plumb::Vector6d err = est.params.vector() - kTruth.vector();
  for (int j = 0; j < 6; ++j) EXPECT_LT(std::abs(err(j)), 3.0 * std::sqrt(est.covariance(j, j))) << j;
  // Without rejection the same data gives a clearly worse laser position.
  plumb::OdometryLaserCalibrationSettings no_rejection;
  no_rejection.outlier_iterations = 0;
  const auto raw = plumb::calibrate_odometry_laser(tuples, no_rejection);
  ASSERT_EQ(raw.status, Status::kOk);
  EXPECT_GT((raw.params.vector() - kTruth.vector()).segment<2>(3).norm(), 3.0 * err.segment<2>(3).norm());
}

TEST(OdometryLaserCalibrationTest, StraightMotionOnlyIsDegenerate) {
  for (const double noise : {0.0, 0.001}) {
    const auto tuples = simulate(kTruth, 100, 3, plumb::Vector3d::Constant(noise), Motion::kStraight);
    const auto est = plumb::calibrate_odometry_laser(tuples);
    EXPECT_EQ(est.status, Status::kDegenerate);
    expect_zero_result(est);
  }
}

TEST(OdometryLaserCalibrationTest, SpinningOnlyIsDegenerate) {
  for (const double noise : {0.0, 0.001}) {
    const auto tuples = simulate(kTruth, 100, 3, plumb::Vector3d::Constant(noise), Motion::kSpin);
    const auto est = plumb::calibrate_odometry_laser(tuples);
    EXPECT_EQ(est.status, Status::kDegenerate);
    expect_zero_result(est);
  }
}

TEST(OdometryLaserCalibrationTest, StraightPlusSpinIsEnough) {
  // No arcs at all: straight runs fix the mean radius, spins fix the axle and the laser position.
  auto tuples = simulate(kTruth, 40, 21, plumb::Vector3d::Zero(), Motion::kStraight);
  const auto spins = simulate(kTruth, 40, 22, plumb::Vector3d::Zero(), Motion::kSpin);
  tuples.insert(tuples.end(), spins.begin(), spins.end());
  const auto est = plumb::calibrate_odometry_laser(tuples);
  ASSERT_EQ(est.status, Status::kOk);
  EXPECT_LT((est.params.vector() - kTruth.vector()).cwiseAbs().maxCoeff(), 1e-9);
}

TEST(OdometryLaserCalibrationTest, TooFewTuplesIsInsufficientData) {
  for (const int n : {0, 1, 5}) {
    const auto tuples = simulate(kTruth, n, 4, plumb::Vector3d::Zero());
    const auto est = plumb::calibrate_odometry_laser(tuples);
    EXPECT_EQ(est.status, Status::kInsufficientData) << n;
    expect_zero_result(est);
  }
  // Exactly the number of unknowns is enough for noise-free data when outlier rejection is off.
  plumb::OdometryLaserCalibrationSettings settings;
  settings.outlier_iterations = 0;
  const auto est = plumb::calibrate_odometry_laser(simulate(kTruth, 6, 4, plumb::Vector3d::Zero()), settings);
  EXPECT_EQ(est.status, Status::kOk);
}

TEST(OdometryLaserCalibrationTest, BadTuplesThrow) {
  auto tuples = simulate(kTruth, 20, 1, plumb::Vector3d::Zero());
  auto bad = tuples;
  bad[3].T = 0.0;
  EXPECT_THROW(plumb::calibrate_odometry_laser(bad), plumb::Error);
  bad = tuples;
  bad[4].laser_motion.y = std::nan("");
  try {
    plumb::calibrate_odometry_laser(bad);
    FAIL() << "expected plumb::Error";
  } catch (const plumb::Error& e) {
    EXPECT_NE(std::string(e.what()).find("tuple 4"), std::string::npos) << e.what();
  }
  plumb::OdometryLaserCalibrationSettings settings;
  settings.outlier_quantile = 0.0;
  EXPECT_THROW(plumb::calibrate_odometry_laser(tuples, settings), plumb::Error);
}

TEST(OdometryLaserCalibrationTest, InformationMatchesAnalyticRotationBlock) {
  // s_θ = T (-r_L φ_L + r_R φ_R) / b, so the θ rows of the Jacobian are known in closed form.
  CalibrationTuple t;
  t.T = 0.8;
  t.phi_left = 0.3;
  t.phi_right = 0.7;
  const plumb::Vector3d sigma(1.0, 1.0, 1e-3);  // make the θ row dominate
  const plumb::Matrix6d info = plumb::odometry_laser_information({t}, kTruth, sigma);
  const double b = kTruth.axle;
  plumb::Vector6d J_theta;
  J_theta << -t.T * t.phi_left / b, t.T * t.phi_right / b,
      -t.T * (-kTruth.radius_left * t.phi_left + kTruth.radius_right * t.phi_right) / (b * b), 0, 0, 0;
  const plumb::Matrix6d expected = J_theta * J_theta.transpose() / (sigma(2) * sigma(2));
  const plumb::Matrix3d got_block = info.topLeftCorner<3, 3>();
  const plumb::Matrix3d expected_block = expected.topLeftCorner<3, 3>();
  EXPECT_LT((got_block - expected_block).norm(), 1e-3 * expected_block.norm());
  EXPECT_THROW(plumb::odometry_laser_information({t}, kTruth, plumb::Vector3d(1, 0, 1)), plumb::Error);
}

}  // namespace
