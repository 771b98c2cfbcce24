// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/scan2d/plicp.hpp"

#include <cmath>
#include <limits>

#include <gtest/gtest.h>

#include "plumb/core/error.hpp"
#include "plumb/core/rng.hpp"
#include "scan2d/scan_sim.hpp"
#include "test_data.hpp"

namespace plumb {
namespace {

using test::kPi;

double cost(const std::vector<PointToLinePair>& pairs, const Pose2& T) {
  double J = 0.0;
  for (const auto& pr : pairs) {
    const double e = pr.normal.dot(T * pr.p - pr.q);
    J += pr.weight * e * e;
  }
  return J;
}

/// Oracle: for each θ on a fine grid, the best translation by 2x2 least squares; then refine.
Pose2 brute_force_minimum(const std::vector<PointToLinePair>& pairs) {
  auto best_at = [&](double th) {
    Eigen::Matrix2d A = Eigen::Matrix2d::Zero();
    Vector2d b = Vector2d::Zero();
    for (const auto& pr : pairs) {
      const Pose2 R{0, 0, th};
      const double r = pr.normal.dot(R * pr.p - pr.q);
      A += pr.weight * pr.normal * pr.normal.transpose();
      b -= pr.weight * r * pr.normal;
    }
    const Vector2d t = A.ldlt().solve(b);
    return Pose2{t.x(), t.y(), th};
  };
  Pose2 best = best_at(0.0);
  double best_cost = cost(pairs, best);
  const int n = 720;  // 0.5 deg grid, then local refinement
  for (int i = 0; i < n; ++i) {
    const Pose2 T = best_at(-kPi + 2 * kPi * i / n);
    const double c = cost(pairs, T);
    if (c < best_cost) best_cost = c, best = T;
  }
  double step = 2 * kPi / n;  // golden-free local refinement by shrinking steps
  for (int k = 0; k < 60; ++k) {
    for (double d : {-step, step}) {
      const Pose2 T = best_at(best.theta + d);
      const double c = cost(pairs, T);
      if (c < best_cost) best_cost = c, best = T;
    }
    step *= 0.7;
  }
  return best;
}

TEST(PlicpSolverTest, ExactOnNoiseFreePairs) {
  Rng rng(7);
  for (int trial = 0; trial < 50; ++trial) {
    const Pose2 T_true{rng.uniform(-2, 2), rng.uniform(-2, 2), rng.uniform(-3.1, 3.1)};
    std::vector<PointToLinePair> pairs;
    for (int i = 0; i < 20; ++i) {
      PointToLinePair pr;
      pr.p = Vector2d(rng.uniform(-5, 5), rng.uniform(-5, 5));
      const double a = rng.uniform(-kPi, kPi);
      pr.normal = Vector2d(std::cos(a), std::sin(a));
      // q anywhere on the line through T p with that normal.
      pr.q = T_true * pr.p + rng.uniform(-1, 1) * Vector2d(-pr.normal.y(), pr.normal.x());
      pairs.push_back(pr);
    }
    Pose2 T;  // start far away: the solve is global, not a local step
    ASSERT_TRUE(solve_point_to_line(pairs, T));
    EXPECT_NEAR(T.x, T_true.x, 1e-9);
    EXPECT_NEAR(T.y, T_true.y, 1e-9);
    EXPECT_NEAR(wrap_angle(T.theta - T_true.theta), 0.0, 1e-9);
  }
}

TEST(PlicpSolverTest, GlobalMinimumMatchesBruteForceOnNoisyPairs) {
  Rng rng(11);
  for (int trial = 0; trial < 30; ++trial) {
    std::vector<PointToLinePair> pairs;
    const int n = 3 + trial;  // from the minimum count upwards, large noise: several local minima
    for (int i = 0; i < n; ++i) {
      PointToLinePair pr;
      pr.p = Vector2d(rng.uniform(-3, 3), rng.uniform(-3, 3));
      const double a = rng.uniform(-kPi, kPi);
      pr.normal = Vector2d(std::cos(a), std::sin(a));
      pr.q = Vector2d(rng.uniform(-3, 3), rng.uniform(-3, 3));
      pr.weight = rng.uniform(0.5, 2.0);
      pairs.push_back(pr);
    }
    Pose2 T;
    ASSERT_TRUE(solve_point_to_line(pairs, T));
    const Pose2 ref = brute_force_minimum(pairs);
    EXPECT_LE(cost(pairs, T), cost(pairs, ref) * (1 + 1e-9) + 1e-12) << "trial " << trial;
  }
}

TEST(PlicpSolverTest, TooFewPairsFail) {
  std::vector<PointToLinePair> pairs(2);
  pairs[0].normal = pairs[1].normal = Vector2d(1, 0);
  Pose2 T{1, 2, 3};
  EXPECT_FALSE(solve_point_to_line(pairs, T));
  EXPECT_EQ(T.x, 1.0);
}

struct Case {
  Pose2 T_world_ref, T_world_cur;
};

void expect_recovers(const std::vector<test::Segment>& world, const Case& c, const Pose2& offset,
                     double noise, double tol_xy, double tol_th) {
  Rng rng(3);
  const LaserScan ref = test::cast_scan(world, c.T_world_ref, 361, kPi, 30.0, noise, &rng);
  const LaserScan cur = test::cast_scan(world, c.T_world_cur, 361, kPi, 30.0, noise, &rng);
  const Pose2 truth = c.T_world_ref.ominus().oplus(c.T_world_cur);
  const Pose2 guess = truth.oplus(offset);
  const PlicpResult r = plicp(cur, ref, guess);
  ASSERT_EQ(r.status, Status::kOk) << "offset " << offset;
  EXPECT_TRUE(r.converged);
  EXPECT_NEAR(r.T_ref_cur.x, truth.x, tol_xy) << "offset " << offset;
  EXPECT_NEAR(r.T_ref_cur.y, truth.y, tol_xy) << "offset " << offset;
  EXPECT_NEAR(wrap_angle(r.T_ref_cur.theta - truth.theta), 0.0, tol_th) << "offset " << offset;
  EXPECT_FALSE(r.degenerate);
  EXPECT_GT(r.valid_fraction, 0.5);
  EXPECT_LT(r.iterations, 40);
}

TEST(PlicpTest, RecoversKnownTransformInRoomFromSeveralStarts) {
  const auto world = test::room_world();
  const std::vector<Case> cases = {
      {{0.0, 0.0, 0.0}, {0.3, 0.1, 0.1}},
      {{0.5, -1.0, 0.8}, {0.2, -0.8, 0.6}},    // moving backwards
      {{-1.0, 1.0, 2.5}, {-1.3, 1.4, 2.8}},
      {{2.0, 0.0, -1.2}, {2.1, 0.25, -1.0}},
  };
  const std::vector<Pose2> offsets = {
      {0, 0, 0}, {0.15, 0, 0}, {0, -0.15, 0}, {0.1, 0.1, 0.1}, {-0.1, 0.05, -0.1}, {0, 0, 0.15}};
  for (const Case& c : cases) {
    for (const Pose2& o : offsets) {
      expect_recovers(world, c, o, 0.0, 0.005, 0.002);
      // The inverse problem (roles swapped) too.
      expect_recovers(world, {c.T_world_cur, c.T_world_ref}, o, 0.0, 0.005, 0.002);
    }
  }
}

// The densest scan a CARMEN log may carry (1,000,000 beams, io::read_carmen's limit) is matched
// like a sparse one: each normal's chord walks to its baseline in strides that grow with the way
// walked, so the cost does not grow with the square of the density (seconds, not minutes).
TEST(PlicpTest, DensestLegalScanIsMatchedAsASparseOne) {
#if defined(__SANITIZE_ADDRESS__)
  constexpr int kBeams = 250000;  // sanitizers run ~10x slower; the strides are exercised all the same
#else
  constexpr int kBeams = 1000000;
#endif
  const auto world = test::room_world();
  const Case c{{0.0, 0.0, 0.0}, {0.2, 0.1, 0.05}};
  const LaserScan ref = test::cast_scan(world, c.T_world_ref, kBeams, kPi);
  const LaserScan cur = test::cast_scan(world, c.T_world_cur, kBeams, kPi);
  const Pose2 truth = c.T_world_ref.ominus().oplus(c.T_world_cur);
  const PlicpResult r = plicp(cur, ref, truth.oplus(Pose2{0.05, -0.05, 0.03}));
  ASSERT_EQ(r.status, Status::kOk);
  EXPECT_NEAR(r.T_ref_cur.x, truth.x, 0.005);
  EXPECT_NEAR(r.T_ref_cur.y, truth.y, 0.005);
  EXPECT_NEAR(wrap_angle(r.T_ref_cur.theta - truth.theta), 0.0, 0.002);
}

// A wall far away seen at grazing incidence with 1 deg beams: its points lie farther apart than
// max_neighbor_distance, but within grazing_factor x range x beam angle, so they stay one surface
// (a corridor's walls keep their segments); a jump in depth between two walls is still a break.
TEST(PlicpTest, GrazingWallsStayLinkedDepthJumpsDoNot) {
  // A wall along y = 8 m from x = 0 to 60 m, and a near wall (y = 4 m) ending at x = 4 m in front of it.
  const std::vector<test::Segment> world = {{{0.0, 8.0}, {60.0, 8.0}}, {{-2.0, 4.0}, {4.0, 4.0}}};
  const LaserScan scan = test::cast_scan(world, Pose2{}, 181, kPi, 80.0);
  const std::vector<Vector2d> pts = scan.to_points();
  PlicpReferenceSettings off;
  off.grazing_factor = 0.0;
  const PlicpReference linked(scan), unlinked(scan, off);
  ASSERT_EQ(linked.size(), pts.size());
  int grazing = 0, gained = 0, jumps = 0;
  for (std::size_t i = 0; i + 1 < pts.size(); ++i) {
    const double gap = (pts[i + 1] - pts[i]).norm();
    const bool same_wall = std::abs(pts[i].y() - pts[i + 1].y()) < 0.05;
    if (!same_wall) {
      ++jumps;
      EXPECT_EQ(linked.next(i), -1) << "beam " << i << ": a depth jump of " << gap << " m";
      continue;
    }
    if (gap < 0.5) {
      EXPECT_EQ(linked.next(i), static_cast<int>(i) + 1);
      continue;
    }
    ++grazing;
    EXPECT_EQ(unlinked.next(i), -1);
    // Linked exactly when the gap is within 3x the spacing of beams 1 deg apart at that range.
    const double allowed = 3.0 * std::min(pts[i].norm(), pts[i + 1].norm()) * (kPi / 180.0);
    if (gap < 0.99 * allowed) {
      ++gained;
      EXPECT_EQ(linked.next(i), static_cast<int>(i) + 1) << "beam " << i;
    } else if (gap > 1.01 * allowed) {
      EXPECT_EQ(linked.next(i), -1) << "beam " << i;
    }
  }
  EXPECT_GE(jumps, 1);
  EXPECT_GE(grazing, 5);
  EXPECT_GE(gained, 3);
}

// Dense beams with range noise: the chord between neighbouring reference points is shorter than
// the noise can bend, so the line through a matched point is its smoothed normal's; the match is
// as good as on the same scan without noise within the noise's reach.
TEST(PlicpTest, DenseNoisyScansMatchThroughSmoothedNormals) {
  const auto world = test::room_world();
  const Pose2 a{0.0, 0.0, 0.2}, b{0.15, 0.05, 0.24};
  const Pose2 truth = a.ominus().oplus(b);
  double err_xy = 0.0, err_th = 0.0, chord_xy = 0.0;
  Rng rng(17);
  const int trials = 4;
  for (int t = 0; t < trials; ++t) {
    const LaserScan ref = test::cast_scan(world, a, 2881, kPi, 30.0, 0.01, &rng);  // 1/16 deg
    const LaserScan cur = test::cast_scan(world, b, 2881, kPi, 30.0, 0.01, &rng);
    const PlicpResult r = plicp(cur, ref, truth.oplus(Pose2{0.05, -0.04, 0.02}));
    ASSERT_EQ(r.status, Status::kOk);
    err_xy += std::hypot(r.T_ref_cur.x - truth.x, r.T_ref_cur.y - truth.y) / trials;
    err_th += std::abs(wrap_angle(r.T_ref_cur.theta - truth.theta)) / trials;
    // The same match with lines from the raw chords (a baseline so short no chord is below it).
    PlicpReferenceSettings raw;
    raw.normal_baseline = 1e-6;
    PlicpSettings raw_cur;
    raw_cur.normal_baseline = 1e-6;
    const PlicpResult c = plicp(cur, PlicpReference(ref, raw), truth.oplus(Pose2{0.05, -0.04, 0.02}), raw_cur);
    chord_xy += std::hypot(c.T_ref_cur.x - truth.x, c.T_ref_cur.y - truth.y) / trials;
  }
  EXPECT_LT(err_xy, 0.003);
  EXPECT_LT(err_th, 0.001);
  EXPECT_LT(err_xy, chord_xy);
}

TEST(PlicpTest, RecoversKnownTransformWithRangeNoise) {
  const auto world = test::room_world();
  for (const Pose2& o : {Pose2{0.1, -0.1, 0.05}, Pose2{-0.1, 0.1, -0.08}}) {
    expect_recovers(world, {{0.0, 0.0, 0.3}, {0.25, 0.1, 0.4}}, o, 0.01, 0.02, 0.005);
  }
}

TEST(PlicpTest, CovarianceGrowsWithNoise) {
  const auto world = test::room_world();
  Rng rng(5);
  const Pose2 a{0.0, 0.0, 0.3}, b{0.2, 0.1, 0.35};
  const Pose2 truth = a.ominus().oplus(b);
  double var_low = 0, var_high = 0;
  for (double noise : {0.005, 0.05}) {
    const auto ref = test::cast_scan(world, a, 361, kPi, 30.0, noise, &rng);
    const auto cur = test::cast_scan(world, b, 361, kPi, 30.0, noise, &rng);
    PlicpSettings settings;
    settings.sigma = 1e-4;  // let the residuals, not the floor, set the scale
    const PlicpResult r = plicp(cur, ref, truth, settings);
    ASSERT_NE(r.status, Status::kInvalidInput);
    EXPECT_GT(r.covariance.determinant(), 0.0);
    (noise < 0.01 ? var_low : var_high) = r.covariance(0, 0);
  }
  EXPECT_GT(var_high, 10.0 * var_low);
}

TEST(PlicpTest, CorridorIsFlaggedDegenerate) {
  const auto corridor = test::corridor_world();
  const Pose2 a{0.0, 0.0, 0.0}, b{0.5, 0.05, 0.05};
  const auto ref = test::cast_scan(corridor, a, 361, kPi, 30.0);
  const auto cur = test::cast_scan(corridor, b, 361, kPi, 30.0);
  const Pose2 truth = a.ominus().oplus(b);
  const PlicpResult r = plicp(cur, ref, truth.oplus(Pose2{0.0, 0.05, 0.02}));
  EXPECT_TRUE(r.degenerate) << r.min_normalized_eigenvalue;
  // The weak direction is the corridor axis (x), the constrained ones are still recovered.
  EXPECT_GT(std::abs(r.weakest_direction.x()), 0.9);
  EXPECT_NEAR(wrap_angle(r.T_ref_cur.theta - truth.theta), 0.0, 1e-3);
  // A room is not degenerate.
  const auto room = test::room_world();
  const PlicpResult rr = plicp(test::cast_scan(room, b, 361, kPi), test::cast_scan(room, a, 361, kPi), truth);
  EXPECT_FALSE(rr.degenerate) << rr.min_normalized_eigenvalue;
  EXPECT_GT(rr.min_normalized_eigenvalue, 10 * r.min_normalized_eigenvalue);
}

TEST(PlicpTest, CsmFailure2RecoversTruePose) {
  PLUMB_REQUIRE_DATA(path, "laser2d/csm/failure2.json");
  const auto scans = test::read_csm_json(path);
  ASSERT_EQ(scans.size(), 2u);
  ASSERT_TRUE(scans[0].has_true_pose && scans[1].has_true_pose);
  const Pose2 truth = scans[0].true_pose.ominus().oplus(scans[1].true_pose);
  const Pose2 guess = scans[0].odometry.ominus().oplus(scans[1].odometry);
  // 30 rays over 180 deg at ~5 m: neighbouring points are ~0.55 m apart.
  PlicpSettings s;
  s.max_neighbor_distance = 1.0;
  PlicpReferenceSettings rs;
  rs.max_neighbor_distance = 1.0;
  const PlicpResult r = plicp(scans[1].scan, PlicpReference(scans[0].scan, rs), guess, s);
  EXPECT_EQ(r.status, Status::kOk);
  EXPECT_NEAR(r.T_ref_cur.x, truth.x, 0.02) << r.T_ref_cur;
  EXPECT_NEAR(r.T_ref_cur.y, truth.y, 0.02) << r.T_ref_cur;
  EXPECT_NEAR(wrap_angle(r.T_ref_cur.theta - truth.theta), 0.0, 0.01) << r.T_ref_cur;
}

TEST(PlicpTest, CsmStallo2IsConsistentForwardAndBackward) {
  PLUMB_REQUIRE_DATA(path, "laser2d/csm/stallo2.log");
  const auto scans = test::read_csm_json(path);
  ASSERT_EQ(scans.size(), 2u);
  const Pose2 guess = scans[0].odometry.ominus().oplus(scans[1].odometry);
  const PlicpSettings s;
  const PlicpResult fwd = plicp(scans[1].scan, scans[0].scan, guess, s);
  const PlicpResult bwd = plicp(scans[0].scan, scans[1].scan, guess.ominus(), s);
  ASSERT_EQ(fwd.status, Status::kOk);
  ASSERT_EQ(bwd.status, Status::kOk);
  EXPECT_GT(fwd.valid_fraction, 0.4);  // dense noisy ranges: many pairs fail the normal check
  EXPECT_LT(std::sqrt(fwd.mse), 0.005);
  // Forward and backward agree: T_01 ⊕ T_10 ≈ identity.
  const Pose2 loop = fwd.T_ref_cur.oplus(bwd.T_ref_cur);
  EXPECT_LT(std::hypot(loop.x, loop.y), 0.002) << fwd.T_ref_cur << " " << bwd.T_ref_cur;
  EXPECT_LT(std::abs(wrap_angle(loop.theta)), 0.005);
  // Starting from perturbed guesses converges to the same answer.
  for (const Pose2& o : {Pose2{0.03, 0.0, 0.0}, Pose2{0.0, -0.03, 0.03}, Pose2{-0.02, 0.02, -0.04}}) {
    const PlicpResult r = plicp(scans[1].scan, scans[0].scan, guess.oplus(o), s);
    EXPECT_NEAR(r.T_ref_cur.x, fwd.T_ref_cur.x, 0.003) << o;
    EXPECT_NEAR(r.T_ref_cur.y, fwd.T_ref_cur.y, 0.003) << o;
    EXPECT_NEAR(wrap_angle(r.T_ref_cur.theta - fwd.T_ref_cur.theta), 0.0, 0.003) << o;
  }
}

TEST(PlicpTest, LocalMapReferenceFromSeveralScans) {
  const auto world = test::room_world();
  const Pose2 k0{0.0, 0.0, 0.0}, k1{0.3, 0.2, 0.3}, cur{0.5, 0.3, 0.5};
  const auto s0 = test::cast_scan(world, k0, 181, kPi);
  const auto s1 = test::cast_scan(world, k1, 181, kPi);
  const auto sc = test::cast_scan(world, cur, 181, kPi);
  // Map in k1's frame.
  const PlicpReference map({&s0, &s1}, {k1.ominus().oplus(k0), Pose2{}});
  EXPECT_EQ(map.size(), s0.num_valid() + s1.num_valid());
  const Pose2 truth = k1.ominus().oplus(cur);
  const PlicpResult r = plicp(sc, map, truth.oplus(Pose2{0.1, -0.1, 0.05}));
  ASSERT_EQ(r.status, Status::kOk);
  EXPECT_NEAR(r.T_ref_cur.x, truth.x, 0.005);
  EXPECT_NEAR(r.T_ref_cur.y, truth.y, 0.005);
  EXPECT_NEAR(wrap_angle(r.T_ref_cur.theta - truth.theta), 0.0, 0.002);
  EXPECT_THROW(PlicpReference({&s0}, {}), Error);
}

TEST(PlicpTest, LaserMotionFromBaseMotion) {
  // A laser mounted 0.2 m ahead, rotated 90 deg; the robot turns in place by 90 deg.
  const Pose2 l{0.2, 0.0, kPi / 2}, r{0.0, 0.0, kPi / 2};
  const Pose2 s = laser_motion(r, l);
  // Laser pose before: l; after: r ⊕ l = (0, 0.2, pi). Motion in the first laser frame.
  const Pose2 expected = l.ominus().oplus(r.oplus(l));
  EXPECT_NEAR(s.x, expected.x, 1e-12);
  EXPECT_NEAR(s.y, expected.y, 1e-12);
  // By hand: the laser goes from (0.2, 0) facing +y to (0, 0.2) facing -x; the world
  // displacement (-0.2, 0.2) in the first laser frame (x = world +y, y = world -x) is (0.2, 0.2).
  EXPECT_NEAR(s.x, 0.2, 1e-12);
  EXPECT_NEAR(s.y, 0.2, 1e-12);
  EXPECT_NEAR(s.theta, kPi / 2, 1e-12);
}

TEST(PlicpTest, BadInputGivesStatusNotCrash) {
  const auto world = test::room_world();
  const auto good = test::cast_scan(world, Pose2{}, 181, kPi);
  LaserScan empty;
  EXPECT_EQ(plicp(empty, good, Pose2{}).status, Status::kInvalidInput);
  EXPECT_EQ(plicp(good, empty, Pose2{}).status, Status::kInvalidInput);
  LaserScan maxed = good;
  for (auto& r : maxed.ranges) r = static_cast<float>(maxed.range_max);
  EXPECT_EQ(plicp(maxed, good, Pose2{}).status, Status::kInvalidInput);
  EXPECT_EQ(plicp(good, maxed, Pose2{}).status, Status::kInvalidInput);
  LaserScan nans = good;
  for (auto& r : nans.ranges) r = std::numeric_limits<float>::quiet_NaN();
  EXPECT_EQ(plicp(nans, good, Pose2{}).status, Status::kInvalidInput);
  LaserScan few = good;
  for (std::size_t i = 5; i < few.ranges.size(); ++i) few.ranges[i] = std::numeric_limits<float>::infinity();
  EXPECT_EQ(plicp(few, good, Pose2{}).status, Status::kInsufficientData);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const PlicpResult r = plicp(good, good, Pose2{nan, 0, 0});
  EXPECT_EQ(r.status, Status::kInvalidInput);
  // Far off guess: no pairs within the gate.
  EXPECT_EQ(plicp(good, good, Pose2{100, 100, 0}).status, Status::kInsufficientData);
  // Angles not one per beam is misuse.
  LaserScan bad = good;
  bad.angles.assign(3, 0.0f);
  EXPECT_THROW(plicp(bad, good, Pose2{}), Error);
  PlicpSettings s;
  s.max_iterations = 0;
  EXPECT_THROW(plicp(good, good, Pose2{}, s), Error);
}

}  // namespace
}  // namespace plumb
