// SPDX-License-Identifier: BSD-3-Clause
// BimOdometry: the front end's step covariance against the wheels, and input it refuses.
#include "plumb/pipeline/bim_odometry.hpp"

#include <cmath>
#include <cstdint>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

#include <gtest/gtest.h>

#include "plumb/core/error.hpp"

namespace {

TEST(FrontEndStepCovarianceTest, MatchesWithinTheWheelBudgetKeepTheirCovariance) {
  const plumb::BimOdometrySettings s;
  const plumb::Pose2 front{0.08, 0.01, 0.02};
  plumb::Matrix3d plicp = plumb::Matrix3d::Zero();
  plicp(0, 0) = 4e-6;
  plicp(0, 2) = plicp(2, 0) = 1e-7;
  // The motion noise alone, written out: sigma per metre times the distance (+ turn for theta).
  const double dist = std::hypot(0.08, 0.01);
  const double sxy = s.motion_sigma_xy * dist + 1e-4, sth = s.motion_sigma_theta * (0.02 + dist) + 1e-5;
  plumb::Matrix3d expected = plumb::Vector3d(sxy * sxy, sxy * sxy, sth * sth).asDiagonal();
  expected += plicp;
  // The wheels 0.9 of the budget away (wheel_tolerance_* + wheel_tolerance_ratio x the step): nothing added.
  const double bxy = s.wheel_tolerance_xy + s.wheel_tolerance_ratio * dist;
  const double bth = s.wheel_tolerance_theta + s.wheel_tolerance_ratio * 0.02;
  const plumb::Pose2 wheel{0.08 - 0.9 * bxy, 0.01, 0.02 + 0.9 * bth};
  EXPECT_TRUE(plumb::front_end_step_covariance(s, front, wheel, true, plicp).isApprox(expected, 1e-12));
  EXPECT_TRUE(plumb::front_end_step_covariance(s, front, front, true, plicp).isApprox(expected, 1e-12));
  // Not a match (fallback to the wheels): the fallback noise, no PLICP covariance, no wheel test.
  const double fxy = s.fallback_sigma_xy * dist + 1e-4, fth = s.fallback_sigma_theta * (0.02 + dist) + 1e-5;
  const plumb::Matrix3d fallback = plumb::Vector3d(fxy * fxy, fxy * fxy, fth * fth).asDiagonal();
  EXPECT_TRUE(plumb::front_end_step_covariance(s, front, wheel, false, plicp).isApprox(fallback, 1e-12));
  // A step across +-pi (the front end wraps its poses; Pose2's operators do not): the same as the
  // small turn it is, not a turn of 2 pi.
  const plumb::Pose2 across{0.08, 0.01, 0.02 - 2.0 * M_PI};
  EXPECT_TRUE(plumb::front_end_step_covariance(s, across, front, true, plicp).isApprox(expected, 1e-9));
}

TEST(FrontEndStepCovarianceTest, AGlitchIsAsUncertainAsItsExcessOverTheWheels) {
  const plumb::BimOdometrySettings s;
  const plumb::Pose2 wheel{0.047, 0.0, 0.0};
  const plumb::Pose2 glitch{0.089, -0.005, 0.05};  // PLICP jumped 4 cm and 0.05 rad where the wheels did not
  const plumb::Matrix3d zero = plumb::Matrix3d::Zero();
  const plumb::Matrix3d base = plumb::front_end_step_covariance(s, glitch, glitch, true, zero);
  const plumb::Matrix3d c = plumb::front_end_step_covariance(s, glitch, wheel, true, zero);
  const double dist = std::hypot(0.089, 0.005);
  const double exy = std::hypot(0.089 - 0.047, 0.005) - s.wheel_tolerance_xy - s.wheel_tolerance_ratio * dist;
  const double eth = 0.05 - s.wheel_tolerance_theta - s.wheel_tolerance_ratio * 0.05;
  EXPECT_NEAR(c(0, 0) - base(0, 0), exy * exy, 1e-12);
  EXPECT_NEAR(c(1, 1) - base(1, 1), exy * exy, 1e-12);
  EXPECT_NEAR(c(2, 2) - base(2, 2), eth * eth, 1e-12);
  EXPECT_NEAR(c(0, 1), 0.0, 1e-15);
  // Bad tolerances are misuse.
  plumb::BimOdometrySettings bad;
  bad.use_bim = false;
  bad.wheel_tolerance_ratio = -0.1;
  EXPECT_THROW(plumb::BimOdometry(nullptr, Eigen::Isometry3d::Identity(), bad), plumb::Error);
}

TEST(FrontEndStepTest, AGlitchIsBlendedWithTheWheelsAndAnAgreeingMatchIsKept) {
  const plumb::BimOdometrySettings s;
  const plumb::Matrix3d zero = plumb::Matrix3d::Zero();
  // Within the wheels' budget the match's step is taken as it is.
  const plumb::Pose2 front{0.08, 0.01, 0.02};
  const plumb::Pose2 near{0.08 - 0.001, 0.01, 0.02};
  const plumb::Matrix3d c_near = plumb::front_end_step_covariance(s, front, near, true, zero);
  const plumb::Pose2 kept = plumb::front_end_step(s, front, near, true, c_near);
  EXPECT_EQ(kept.x, front.x);
  EXPECT_EQ(kept.y, front.y);
  EXPECT_EQ(kept.theta, front.theta);
  // A match 3 cm and 0.03 rad off where the wheels are exact: the step lands far closer to the wheels
  // (the match's variance has grown by the excess over the budget, the wheels' is the budget).
  const plumb::Pose2 wheel{0.05, 0.0, 0.0};
  const plumb::Pose2 glitch{0.08, 0.0, 0.03};
  const plumb::Matrix3d c = plumb::front_end_step_covariance(s, glitch, wheel, true, zero);
  const plumb::Pose2 step = plumb::front_end_step(s, glitch, wheel, true, c);
  EXPECT_LT(std::abs(step.x - wheel.x), 0.2 * 0.03);
  EXPECT_GT(std::abs(step.x - wheel.x), 0.0);  // a blend, not a switch
  EXPECT_LT(std::abs(step.theta - wheel.theta), 0.3 * 0.03);
  // Each component between the two.
  EXPECT_GE(step.x, wheel.x);
  EXPECT_LE(step.x, glitch.x);
  // Not a match (the front end fell back to the wheels): its step as it is.
  const plumb::Pose2 fallback = plumb::front_end_step(s, glitch, wheel, false, c);
  EXPECT_EQ(fallback.x, glitch.x);
  EXPECT_EQ(fallback.theta, glitch.theta);
  // Across +-pi the blend stays near the two headings, not half a turn away.
  const plumb::Pose2 a{0.05, 0.0, M_PI - 0.01};
  const plumb::Pose2 w{0.05, 0.0, -M_PI + 0.02};
  const plumb::Pose2 blended = plumb::front_end_step(s, a, w, true, plumb::front_end_step_covariance(s, a, w, true, zero));
  EXPECT_LT(std::abs(plumb::wrap_angle(blended.theta - M_PI)), 0.05);
}

TEST(FrontEndStepCovarianceTest, TheNextAnchorRemovesAGlitchInsteadOfBeingRejected) {
  // A robot driving 5 cm per frame along x, anchored every frame by key points registered to the BIM
  // (4 mm, the size of BimOdometry's anchors). At frame 10 the scan match jumps 4.6 cm ahead, the wheels
  // do not (a PLICP glitch measured on an AC20-FZK-Haus run). With the wheel test the first anchor after
  // the glitch passes the gate and removes it; without it (tolerance off) the composer, confident in its
  // chain, rejects the anchors and carries the error on.
  auto run = [](double wheel_tolerance) {
    plumb::BimOdometrySettings s;
    s.wheel_tolerance_xy = wheel_tolerance;
    plumb::PoseComposer composer(Eigen::Isometry3d::Identity(), s.initial_covariance, s.composer);
    plumb::Matrix6d info = plumb::Matrix6d::Zero();
    info(0, 0) = info(1, 1) = 1.0 / (0.004 * 0.004);
    info(5, 5) = 1.0 / (0.001 * 0.001);
    std::vector<double> errors;
    const plumb::Pose2 wheel{0.05, 0.0, 0.0};
    for (int k = 1; k <= 20; ++k) {
      const plumb::Pose2 front = k == 10 ? plumb::Pose2{0.096, 0.0, 0.0} : wheel;
      const plumb::Matrix3d c = plumb::front_end_step_covariance(s, front, wheel, true, plumb::Matrix3d::Zero());
      composer.add_motion(front.to_isometry(), plumb::planar_covariance(c, 1e-8, 1e-8));
      Eigen::Isometry3d truth = Eigen::Isometry3d::Identity();
      truth.translation().x() = 0.05 * k;
      composer.add_anchor(truth, info);
      errors.push_back(std::abs(composer.pose().translation().x() - truth.translation().x()));
    }
    return errors;
  };
  const std::vector<double> with = run(0.01), without = run(1e9);
  for (int k = 1; k <= 9; ++k) EXPECT_NEAR(with[k - 1], without[k - 1], 1e-12) << "frame " << k;
  EXPECT_LT(with[9], 0.005);     // frame 10: corrected by its own anchor
  EXPECT_GT(without[9], 0.04);   // rejected: the whole jump stays
  EXPECT_GT(without[11], 0.04);  // and two frames later it still does
}

/// Key points on the walls and floor of a room seen from `c`: target points q with normals, one label
/// per element, the source points exactly on them.
struct RoomPairs {
  std::vector<plumb::IcpCorrespondence> pairs;
  std::vector<std::int32_t> labels;
  std::vector<plumb::Vector3d> pivots;
};

RoomPairs room_pairs(bool corridor) {
  RoomPairs r;
  // (point on the plane, normal, extent along two in-plane axes); a corridor lacks the end walls.
  struct Plane {
    plumb::Vector3d o, n, u, v;
  };
  std::vector<Plane> planes = {{{0, -2, 1.2}, {0, 1, 0}, {1, 0, 0}, {0, 0, 1}},
                               {{0, 2, 1.2}, {0, -1, 0}, {1, 0, 0}, {0, 0, 1}},
                               {{0, 0, 0}, {0, 0, 1}, {1, 0, 0}, {0, 1, 0}}};
  if (!corridor) {
    planes.push_back({{-4, 0, 1.2}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}});
    planes.push_back({{5, 0, 1.2}, {-1, 0, 0}, {0, 1, 0}, {0, 0, 1}});
  }
  std::size_t index = 0;
  for (std::size_t e = 0; e < planes.size(); ++e) {
    const Plane& p = planes[e];
    plumb::Vector3d pivot = plumb::Vector3d::Zero();
    int count = 0;
    for (int i = -6; i <= 6; ++i) {
      for (int j = -3; j <= 3; ++j) {
        plumb::IcpCorrespondence c;
        c.source_index = c.target_index = index++;
        c.q = p.o + 0.3 * i * p.u + 0.3 * j * p.v;
        c.x = c.q;
        c.n = p.n;
        r.pairs.push_back(c);
        r.labels.push_back(static_cast<std::int32_t>(e));
        pivot += c.q;
        ++count;
      }
    }
    r.pivots.push_back(pivot / count);
  }
  return r;
}

TEST(ElementAnchorInformationTest, MatchesTheSpreadOfPosesRegisteredToDisplacedElements) {
  // Brute force: displace every element by a draw from its covariance, add noise to every pair,
  // solve the linearised point-to-plane least squares for the pose, and compare the spread of the
  // poses with the inverse of the information.
  const RoomPairs room = room_pairs(false);
  const plumb::Vector3d c(0.5, 0.3, 0.4);
  std::vector<plumb::Matrix6d> cov;
  for (std::size_t e = 0; e < room.pivots.size(); ++e) {
    plumb::Vector6d d;
    const double st = 0.004 + 0.003 * static_cast<double>(e), sr = (0.1 + 0.05 * static_cast<double>(e)) * M_PI / 180.0;
    d << st * st, st * st, st * st, sr * sr, sr * sr, sr * sr;
    cov.push_back(d.asDiagonal());
  }
  const double point_sigma = 0.02;
  const plumb::Matrix6d info =
      plumb::element_anchor_information(room.pairs, room.labels, room.pivots, cov, point_sigma, c);

  std::mt19937 rng(7);
  std::normal_distribution<double> g(0.0, 1.0);
  plumb::Matrix6d Hp = plumb::Matrix6d::Zero();
  std::vector<plumb::Vector6d> rows;
  for (const auto& p : room.pairs) {
    plumb::Vector6d a;
    a << p.n, (p.x - c).cross(p.n);
    rows.push_back(a);
    Hp += a * a.transpose();
  }
  const Eigen::LDLT<plumb::Matrix6d> solve(Hp);
  const int draws = 4000;
  plumb::Matrix6d spread = plumb::Matrix6d::Zero();
  for (int k = 0; k < draws; ++k) {
    std::vector<plumb::Vector6d> eps;
    for (const auto& C : cov) {
      plumb::Vector6d z;
      for (int i = 0; i < 6; ++i) z(i) = g(rng);
      eps.push_back(C.llt().matrixL() * z);
    }
    plumb::Vector6d rhs = plumb::Vector6d::Zero();
    for (std::size_t i = 0; i < room.pairs.size(); ++i) {
      const auto& p = room.pairs[i];
      const auto e = static_cast<std::size_t>(room.labels[i]);
      // The element moved by eps: its point q moves by t + w x (q - pivot); the residual n.(x - q').
      const plumb::Vector3d moved = eps[e].head<3>() + eps[e].tail<3>().cross(p.q - room.pivots[e]);
      const double r = -p.n.dot(moved) + point_sigma * g(rng);
      rhs -= rows[i] * r;
    }
    const plumb::Vector6d delta = solve.solve(rhs);
    spread += delta * delta.transpose() / draws;
  }
  const plumb::Matrix6d predicted = info.inverse();
  // Each variance within 10 % (4000 draws: a standard error of about 2 %).
  for (int i = 0; i < 6; ++i) EXPECT_NEAR(spread(i, i) / predicted(i, i), 1.0, 0.1) << "axis " << i;
  // The elements dominate: the points' noise alone would claim a far tighter pose.
  const plumb::Matrix6d noise_only = Hp / (point_sigma * point_sigma);
  EXPECT_GT(noise_only(0, 0), 10.0 * info(0, 0));
}

TEST(ElementAnchorInformationTest, ACorridorGivesNoneAlongItsAxis) {
  const RoomPairs room = room_pairs(true);
  plumb::Vector6d d;
  d << 1e-4, 1e-4, 1e-4, 1.2e-5, 1.2e-5, 1.2e-5;
  const std::vector<plumb::Matrix6d> cov(room.pivots.size(), plumb::Matrix6d(d.asDiagonal()));
  const plumb::Matrix6d info =
      plumb::element_anchor_information(room.pairs, room.labels, room.pivots, cov, 0.02, plumb::Vector3d(0.5, 0.3, 0.4));
  EXPECT_NEAR(info(0, 0), 0.0, 1e-6 * info(1, 1));  // along the corridor: nothing
  EXPECT_GT(info(1, 1), 1e3);                        // across it: the walls' tolerance, about 1 cm
  // Better-known elements (an as-built estimate) give a tighter anchor, in proportion.
  const std::vector<plumb::Matrix6d> tight(room.pivots.size(), plumb::Matrix6d(0.01 * d.asDiagonal()));
  const plumb::Matrix6d info_tight =
      plumb::element_anchor_information(room.pairs, room.labels, room.pivots, tight, 0.002, plumb::Vector3d(0.5, 0.3, 0.4));
  EXPECT_NEAR(info_tight(1, 1) / info(1, 1), 100.0, 1.0);
  // Pairs with no element are skipped; a size mismatch is misuse.
  std::vector<std::int32_t> none(room.labels.size(), -1);
  EXPECT_TRUE(plumb::element_anchor_information(room.pairs, none, room.pivots, cov, 0.02, plumb::Vector3d::Zero()).isZero());
  EXPECT_THROW(plumb::element_anchor_information(room.pairs, room.labels, room.pivots, {}, 0.02, plumb::Vector3d::Zero()),
               plumb::Error);
}

TEST(BimOdometryTest, BadInputThrows) {
  auto empty = std::make_shared<plumb::PointCloud>();
  EXPECT_THROW(plumb::BimOdometry(empty, Eigen::Isometry3d::Identity()), plumb::Error);
  auto no_normals = std::make_shared<plumb::PointCloud>();
  for (int i = 0; i < 200; ++i) no_normals->points.emplace_back(float(i % 20), float(i / 20), 0.0f);
  EXPECT_THROW(plumb::BimOdometry(no_normals, Eigen::Isometry3d::Identity()), plumb::Error);
  // Anchors weighed by their elements need positive tolerances (a zero one would claim an exact model).
  auto labelled = std::make_shared<plumb::PointCloud>(*no_normals);
  labelled->normals.assign(labelled->size(), Eigen::Vector3f::UnitZ());
  labelled->labels.assign(labelled->size(), 0);
  for (int which = 0; which < 3; ++which) {
    plumb::BimOdometrySettings s;
    (which == 0 ? s.as_built.sigma_translation : which == 1 ? s.as_built.sigma_rotation : s.as_built.point_sigma) = 0.0;
    EXPECT_THROW(plumb::BimOdometry(labelled, Eigen::Isometry3d::Identity(), s), plumb::Error);
    s.anchor_from_elements = false;
    EXPECT_NO_THROW(plumb::BimOdometry(labelled, Eigen::Isometry3d::Identity(), s));
  }
  // A negative thread count for the target's refresh is refused when the odometry is made, not at
  // its first refresh.
  plumb::BimOdometrySettings negative_threads;
  negative_threads.refresh_threads = -1;
  try {
    plumb::BimOdometry(labelled, Eigen::Isometry3d::Identity(), negative_threads);
    ADD_FAILURE() << "expected plumb::Error";
  } catch (const plumb::Error& e) {
    EXPECT_NE(std::string(e.what()).find("refresh_threads"), std::string::npos) << e.what();
  }
  plumb::BimOdometrySettings plain;
  plain.use_bim = false;
  // The as-built is estimated from the BIM registrations: asking for it without them is misuse, not
  // a run that silently reports nothing.
  plumb::BimOdometrySettings no_registrations = plain;
  no_registrations.estimate_as_built = true;
  EXPECT_THROW(plumb::BimOdometry(nullptr, Eigen::Isometry3d::Identity(), no_registrations), plumb::Error);
  plumb::BimOdometry odometry(nullptr, Eigen::Isometry3d::Identity(), plain);
  // An empty frame: no scan, the front end falls back to the wheel prior; never a crash.
  const auto r0 = odometry.process(plumb::PointCloud{}, 0.0, plumb::Pose2{});
  const auto r1 = odometry.process(plumb::PointCloud{}, 0.1, plumb::Pose2{0.1, 0, 0});
  EXPECT_EQ(r1.scan_status, plumb::Status::kInsufficientData);
  EXPECT_NEAR(r1.T_world_base.translation().x(), 0.1, 1e-9);
  EXPECT_FALSE(r0.anchor_attempted);
}

}  // namespace
