// SPDX-License-Identifier: BSD-3-Clause
// Global correlative scan matching: the branch-and-bound result against a brute-force evaluation of
// every heading and translation, on a synthetic floor plan.
#include "plumb/scan2d/correlative.hpp"

#include <cmath>
#include <cstdint>
#include <functional>
#include <vector>

#include <gtest/gtest.h>

#include "plumb/core/error.hpp"
#include "plumb/core/rng.hpp"

namespace {

using plumb::CorrelativeMap2D;
using plumb::CorrelativeMapSettings;
using plumb::CorrelativeSearchSettings;
using plumb::Pose2;
using plumb::Vector2d;

/// Walls of an irregular two-room plan (8 x 5 m, a partition with a door gap), every 2 cm, with
/// the normals of the faces looking into the rooms.
void floor_plan(std::vector<Vector2d>& pts, std::vector<Vector2d>& normals) {
  auto wall = [&](Vector2d a, Vector2d b, Vector2d n) {
    const int k = static_cast<int>((b - a).norm() / 0.02);
    for (int i = 0; i <= k; ++i) {
      pts.push_back(a + (b - a) * i / k);
      normals.push_back(n);
    }
  };
  wall({0, 0}, {8, 0}, {0, 1});
  wall({8, 0}, {8, 5}, {-1, 0});
  wall({8, 5}, {0, 5}, {0, -1});
  wall({0, 5}, {0, 0}, {1, 0});
  wall({5, 0}, {5, 2}, {-1, 0});
  wall({5.1, 0}, {5.1, 2}, {1, 0});
  wall({5, 3}, {5, 5}, {-1, 0});
  wall({5.1, 3}, {5.1, 5}, {1, 0});
  wall({1, 3.5}, {2.5, 3.5}, {0, -1});  // a cupboard
}

/// Translations at least 0.2 m inside the plan's outer walls.
bool inside_plan(const Vector2d& t) { return t.x() > 0.2 && t.x() < 7.8 && t.y() > 0.2 && t.y() < 4.8; }

/// The plan's map: 10 cm cells, windows up to 1.6 m.
CorrelativeMapSettings plan_settings() {
  CorrelativeMapSettings ms;
  ms.resolution = 0.1;
  ms.levels = 5;
  return ms;
}

/// What a robot at `pose` in the left room sees: the wall points of the left room within 6 m,
/// in the robot frame, with noise.
std::vector<Vector2d> scan_from(const std::vector<Vector2d>& pts, const Pose2& pose, plumb::Rng& rng) {
  std::vector<Vector2d> scan;
  const Pose2 inv = pose.ominus();
  for (std::size_t i = 0; i < pts.size(); i += 6) {
    if (pts[i].x() > 5.05 || (pts[i] - Vector2d(pose.x, pose.y)).norm() > 6.0) continue;
    scan.push_back(inv * pts[i] + Vector2d(rng.normal(0.0, 0.01), rng.normal(0.0, 0.01)));
  }
  return scan;
}

TEST(CorrelativeMatchTest, BranchAndBoundEqualsBruteForce) {
  std::vector<Vector2d> pts, normals;
  floor_plan(pts, normals);
  const CorrelativeMapSettings ms = plan_settings();
  const CorrelativeMap2D map(pts, ms, inside_plan);
  plumb::Rng rng(3);
  const Pose2 truth{2.33, 1.71, 0.6};
  const std::vector<Vector2d> scan = scan_from(pts, truth, rng);
  CorrelativeSearchSettings ss;
  ss.angular_step = 2.0 * M_PI / 90.0;  // coarse, so that brute force stays cheap
  ss.max_points = 100000;
  const plumb::CorrelativeResult r = map.match(scan, ss);
  ASSERT_EQ(r.status, plumb::Status::kOk);
  EXPECT_EQ(r.num_angles, 90u);

  // Brute force over the same headings and translations (cell corners).
  double best = -1.0, second = -1.0;
  Pose2 best_pose;
  std::vector<std::pair<double, Pose2>> all;
  for (int a = 0; a < 90; ++a) {
    const double theta = -M_PI + 2.0 * M_PI * a / 90.0;
    for (int jy = 0; jy < map.height(); ++jy) {
      for (int jx = 0; jx < map.width(); ++jx) {
        const Vector2d t = map.origin() + Vector2d(jx, jy) * ms.resolution;
        if (!inside_plan(t)) continue;
        const Pose2 p{t.x(), t.y(), theta};
        const double s = map.score(scan, p);
        all.emplace_back(s, p);
        if (s > best) {
          best = s;
          best_pose = p;
        }
      }
    }
  }
  for (const auto& [s, p] : all) {
    const bool near = (Vector2d(p.x, p.y) - Vector2d(best_pose.x, best_pose.y)).norm() < ss.second_distance &&
                      std::abs(plumb::wrap_angle(p.theta - best_pose.theta)) < ss.second_angle;
    if (!near) second = std::max(second, s);
  }
  EXPECT_NEAR(r.score, best, 1e-9);
  EXPECT_NEAR(r.second_score, second, 1e-9);
  EXPECT_LT(r.nodes_scored, all.size() / 5);  // the bound prunes most of the brute force
  // And the best pose is the truth, to the grid's steps.
  EXPECT_LT((Vector2d(r.pose.x, r.pose.y) - Vector2d(truth.x, truth.y)).norm(), 0.15);
  EXPECT_LT(std::abs(plumb::wrap_angle(r.pose.theta - truth.theta)), ss.angular_step);
}

// A pose the accept test turns down is skipped, the search goes on: the result equals the brute
// force over the accepted poses only (here: none within 0.6 m of the truth), for the best and the
// second pose; a test that accepts nothing ends at max_rejections with kRejected.
TEST(CorrelativeMatchTest, AcceptTestSkipsPosesAndEqualsBruteForceOverTheRest) {
  std::vector<Vector2d> pts, normals;
  floor_plan(pts, normals);
  const CorrelativeMapSettings ms = plan_settings();
  const CorrelativeMap2D map(pts, ms, inside_plan);
  plumb::Rng rng(5);
  const Pose2 truth{2.33, 1.71, 0.6};
  const std::vector<Vector2d> scan = scan_from(pts, truth, rng);
  CorrelativeSearchSettings ss;
  ss.angular_step = 2.0 * M_PI / 90.0;
  ss.max_points = 100000;
  auto far_from_truth = [&](const Pose2& p) { return (Vector2d(p.x, p.y) - Vector2d(truth.x, truth.y)).norm() >= 0.6; };
  std::size_t calls = 0;
  ss.accept = [&](const Pose2& p) {
    ++calls;
    return far_from_truth(p);
  };
  const plumb::CorrelativeResult r = map.match(scan, ss);
  ASSERT_EQ(r.status, plumb::Status::kOk);
  EXPECT_GT(r.rejected, 0u);
  EXPECT_FALSE(r.truncated);
  EXPECT_GE(calls, r.rejected);
  EXPECT_TRUE(far_from_truth(r.pose));

  double best = -1.0, second = -1.0;
  Pose2 best_pose;
  std::vector<std::pair<double, Pose2>> all;
  for (int a = 0; a < 90; ++a) {
    const double theta = -M_PI + 2.0 * M_PI * a / 90.0;
    for (int jy = 0; jy < map.height(); ++jy) {
      for (int jx = 0; jx < map.width(); ++jx) {
        const Vector2d t = map.origin() + Vector2d(jx, jy) * ms.resolution;
        const Pose2 p{t.x(), t.y(), theta};
        if (!inside_plan(t) || !far_from_truth(p)) continue;
        const double s = map.score(scan, p);
        all.emplace_back(s, p);
        if (s > best) {
          best = s;
          best_pose = p;
        }
      }
    }
  }
  for (const auto& [s, p] : all) {
    const bool near = (Vector2d(p.x, p.y) - Vector2d(best_pose.x, best_pose.y)).norm() < ss.second_distance &&
                      std::abs(plumb::wrap_angle(p.theta - best_pose.theta)) < ss.second_angle;
    if (!near) second = std::max(second, s);
  }
  EXPECT_NEAR(r.score, best, 1e-9);
  EXPECT_NEAR(r.second_score, second, 1e-9);
  // Without the test the truth wins, with a higher score than anything accepted.
  ss.accept = nullptr;
  const plumb::CorrelativeResult plain = map.match(scan, ss);
  EXPECT_GT(plain.score, r.score);
  EXPECT_LT((Vector2d(plain.pose.x, plain.pose.y) - Vector2d(truth.x, truth.y)).norm(), 0.15);

  // Nothing accepted: the search stops after max_rejections poses.
  ss.accept = [](const Pose2&) { return false; };
  ss.max_rejections = 50;
  const plumb::CorrelativeResult none = map.match(scan, ss);
  EXPECT_EQ(none.status, plumb::Status::kRejected);
  EXPECT_TRUE(none.truncated);
  EXPECT_EQ(none.rejected, 50u);
}

// With threads the roots are searched in parallel batches and replayed in order: the best and the
// second pose, the scores, the rejections and a stop at max_rejections are those of one thread.
TEST(CorrelativeMatchTest, ThreadsChangeNoResult) {
  std::vector<Vector2d> pts, normals;
  floor_plan(pts, normals);
  const CorrelativeMapSettings ms = plan_settings();
  const CorrelativeMap2D map(pts, ms, inside_plan, normals);
  plumb::Rng rng(9);
  const Pose2 truth{2.33, 1.71, 0.6};
  const std::vector<Vector2d> scan = scan_from(pts, truth, rng);
  // Pure tests that turn down a third, or nine in ten, of the poses, scattered (a hash of the cell
  // and heading).
  auto hash = [](const Pose2& p) {
    return static_cast<std::uint64_t>(std::llround(p.x * 10.0) * 73856093LL ^ std::llround(p.y * 10.0) * 19349663LL ^
                                      std::llround(p.theta * 100.0) * 83492791LL);
  };
  auto scattered = [&](const Pose2& p) { return hash(p) % 3 != 0; };
  auto mostly_not = [&](const Pose2& p) { return hash(p) % 10 == 0; };
  auto far_from_truth = [&](const Pose2& p) { return (Vector2d(p.x, p.y) - Vector2d(truth.x, truth.y)).norm() >= 0.6; };
  struct Variant {
    std::function<bool(const Pose2&)> accept;
    std::size_t max_rejections;
  };
  const std::vector<Variant> variants{{nullptr, 10000}, {far_from_truth, 10000}, {scattered, 10000}, {mostly_not, 10},
                                      {[](const Pose2&) { return false; }, 50}};
  for (std::size_t v = 0; v < variants.size(); ++v) {
    CorrelativeSearchSettings ss;
    ss.angular_step = 2.0 * M_PI / 90.0;
    ss.max_points = 100000;
    ss.accept = variants[v].accept;
    ss.max_rejections = variants[v].max_rejections;
    const plumb::CorrelativeResult one = map.match(scan, ss);
    if (v == 3) {
      EXPECT_TRUE(one.truncated) << "the stop at max_rejections is not exercised";
      EXPECT_EQ(one.status, plumb::Status::kOk) << "a pose accepted before the stop is not exercised";
    }
    for (const int threads : {2, 3, 8}) {
      ss.threads = threads;
      const plumb::CorrelativeResult r = map.match(scan, ss);
      EXPECT_EQ(r.status, one.status) << v << " " << threads;
      EXPECT_EQ(r.score, one.score) << v << " " << threads;
      EXPECT_EQ(r.pose.x, one.pose.x) << v << " " << threads;
      EXPECT_EQ(r.pose.y, one.pose.y) << v << " " << threads;
      EXPECT_EQ(r.pose.theta, one.pose.theta) << v << " " << threads;
      EXPECT_EQ(r.has_second, one.has_second) << v << " " << threads;
      EXPECT_EQ(r.second_score, one.second_score) << v << " " << threads;
      EXPECT_EQ(r.second_pose.x, one.second_pose.x) << v << " " << threads;
      EXPECT_EQ(r.second_pose.y, one.second_pose.y) << v << " " << threads;
      EXPECT_EQ(r.second_pose.theta, one.second_pose.theta) << v << " " << threads;
      EXPECT_EQ(r.rejected, one.rejected) << v << " " << threads;
      EXPECT_EQ(r.truncated, one.truncated) << v << " " << threads;
    }
  }
  CorrelativeSearchSettings bad;
  bad.threads = -1;
  EXPECT_THROW(map.match(scan, bad), plumb::Error);
}

TEST(CorrelativeMatchTest, NormalsKeepAWallsFarFaceFromExplainingItsNearFace) {
  // A scan of the partition's left face only, seen from the left room: without normals the right
  // face (10 cm away) explains it as well; with normals only the left face does.
  std::vector<Vector2d> pts, normals;
  floor_plan(pts, normals);
  CorrelativeMapSettings ms;
  ms.resolution = 0.02;
  ms.sigma = 0.02;
  ms.levels = 4;
  const CorrelativeMap2D with(pts, ms, {}, normals);
  const Pose2 pose{3.0, 1.0, 0.0};
  std::vector<Vector2d> scan, scan_normals;
  for (double y = 0.2; y < 1.8; y += 0.02) {
    scan.push_back(pose.ominus() * Vector2d(5.0, y));
    scan_normals.emplace_back(-1.0, 0.0);
  }
  const Pose2 shifted{3.1, 1.0, 0.0};  // puts the scan on the far face
  EXPECT_GT(with.score(scan, pose, scan_normals), 0.9);
  EXPECT_LT(with.score(scan, shifted, scan_normals), 0.1);
  EXPECT_GT(with.score(scan, shifted), 0.9);  // without scan normals: any face counts
}

TEST(CorrelativeMatchTest, HintRegionAndBadInput) {
  std::vector<Vector2d> pts, normals;
  floor_plan(pts, normals);
  CorrelativeMapSettings ms;
  ms.resolution = 0.1;
  const CorrelativeMap2D map(pts, ms);
  plumb::Rng rng(5);
  const Pose2 truth{6.5, 2.5, -1.0};
  std::vector<Vector2d> scan;
  for (const Vector2d& p : pts)
    if (p.x() > 5.0) scan.push_back(truth.ominus() * p);
  CorrelativeSearchSettings ss;
  ss.region_center = Vector2d(6.0, 2.0);
  ss.region_radius = 1.5;
  const plumb::CorrelativeResult r = map.match(scan, ss);
  ASSERT_EQ(r.status, plumb::Status::kOk);
  EXPECT_LT((Vector2d(r.pose.x, r.pose.y) - Vector2d(truth.x, truth.y)).norm(), 0.15);
  // A region off the map: nothing found.
  ss.region_center = Vector2d(100.0, 100.0);
  EXPECT_EQ(map.match(scan, ss).status, plumb::Status::kRejected);
  // Too few points, NaN points: status; bad settings: plumb::Error.
  EXPECT_EQ(map.match({Vector2d(1, 1)}).status, plumb::Status::kInsufficientData);
  std::vector<Vector2d> nan_scan(50, Vector2d::Constant(std::nan("")));
  EXPECT_EQ(map.match(nan_scan).status, plumb::Status::kInsufficientData);
  CorrelativeSearchSettings bad;
  bad.min_score = 2.0;
  EXPECT_THROW(map.match(scan, bad), plumb::Error);
  EXPECT_THROW(map.match(scan, {}, std::vector<Vector2d>(3)), plumb::Error);
  CorrelativeMapSettings huge;
  huge.resolution = 0.001;  // a plan in millimetres read as metres
  EXPECT_THROW(CorrelativeMap2D({Vector2d(0, 0), Vector2d(8000, 5000)}, huge), plumb::Error);
  EXPECT_THROW(CorrelativeMap2D({}), plumb::Error);
  CorrelativeMapSettings bins;
  bins.orientation_bins = 3;
  EXPECT_THROW(CorrelativeMap2D(pts, bins), plumb::Error);
  EXPECT_THROW(CorrelativeMap2D(pts, ms, {}, std::vector<Vector2d>(2)), plumb::Error);  // one normal per point
  EXPECT_THROW(map.score(scan, truth, std::vector<Vector2d>(1)), plumb::Error);
  EXPECT_THROW(map.see_through(scan, truth, Vector2d::Zero(), -1.0), plumb::Error);
}

TEST(CorrelativeMatchTest, BoundsReachPositionsFarFromEveryWall) {
  // One long wall; the robot stands 3 m in front of it, beyond the 1 m margin around the map points
  // (a terrace in front of a facade). Without bounds its position is off the grid and cannot be
  // found; with the free area as bounds it is.
  std::vector<Vector2d> pts;
  for (int i = 0; i <= 400; ++i) pts.emplace_back(0.02 * i, 0.0);
  for (int i = 1; i <= 50; ++i) pts.emplace_back(0.0, -0.02 * i);  // a corner, so x is fixed too
  const Pose2 truth{3.0, 3.0, 0.4};
  std::vector<Vector2d> scan;
  for (const Vector2d& p : pts) scan.push_back(truth.ominus() * p);
  CorrelativeMapSettings ms;
  ms.resolution = 0.1;
  ms.levels = 5;
  CorrelativeSearchSettings ss;
  ss.region_center = Vector2d(3.0, 3.0);
  ss.region_radius = 0.5;
  EXPECT_EQ(CorrelativeMap2D(pts, ms).match(scan, ss).status, plumb::Status::kRejected);
  ms.bounds.extend(Vector2d(-1.0, -1.0));
  ms.bounds.extend(Vector2d(9.0, 5.0));
  const CorrelativeMap2D map(pts, ms);
  const plumb::CorrelativeResult r = map.match(scan, ss);
  ASSERT_EQ(r.status, plumb::Status::kOk);
  EXPECT_LT((Vector2d(r.pose.x, r.pose.y) - Vector2d(truth.x, truth.y)).norm(), 0.15);
  EXPECT_LT(std::abs(std::remainder(r.pose.theta - truth.theta, 2.0 * M_PI)), 0.05);
  CorrelativeMapSettings bad = ms;
  bad.bounds = Eigen::AlignedBox2d(Vector2d(std::nan(""), 0.0), Vector2d(1.0, 1.0));
  EXPECT_THROW(CorrelativeMap2D(pts, bad), plumb::Error);
}

}  // namespace
