// SPDX-License-Identifier: BSD-3-Clause
// Horn's closed form, the overlap ratio and ICP on synthetic data with known answers.

#include <cmath>
#include <cstdint>
#include <utility>
#include <vector>

#include <Eigen/Eigenvalues>
#include <gtest/gtest.h>

#include "plumb/core/error.hpp"
#include "plumb/core/lie.hpp"
#include "plumb/core/rng.hpp"
#include "plumb/registration/horn.hpp"
#include "plumb/registration/icp.hpp"
#include "plumb/registration/overlap.hpp"

#include "registration/icp_detail.hpp"

namespace plumb {
namespace {

// ---- helpers: random poses, pose errors and a synthetic room with clutter ----------------------

Eigen::Isometry3d random_pose(Rng& rng, double max_translation, double max_angle) {
  Vector3d axis(rng.normal(), rng.normal(), rng.normal());
  axis.normalize();
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(rng.uniform(-max_angle, max_angle), axis).toRotationMatrix();
  T.translation() = Vector3d(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1)) * max_translation;
  return T;
}

/// (translation error [m], rotation error [rad]) of a against b.
std::pair<double, double> pose_error(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  const Eigen::Isometry3d d = b.inverse() * a;
  return {d.translation().norm(), Eigen::AngleAxisd(d.linear()).angle()};
}

/// Random samples (about one per spacing^2) of a 6 x 4 x 3 m room with a pillar, a cabinet and a
/// step, so that no symmetry leaves the pose ambiguous; normals are the face normals.
PointCloud room_cloud(double spacing, std::uint64_t seed) {
  Rng rng(seed);
  PointCloud c;
  auto rect = [&](Vector3d o, Vector3d u, Vector3d v) {
    const Vector3d n = u.cross(v).normalized();
    const int num = static_cast<int>(u.norm() * v.norm() / (spacing * spacing));
    for (int i = 0; i < num; ++i) {
      c.points.push_back((o + rng.uniform() * u + rng.uniform() * v).cast<float>());
      c.normals.push_back(n.cast<float>());
    }
  };
  auto box = [&](Vector3d lo, Vector3d hi) {  // the five faces other than the bottom
    const Vector3d e = hi - lo;
    rect(lo, Vector3d(e.x(), 0, 0), Vector3d(0, 0, e.z()));
    rect(lo + Vector3d(0, e.y(), 0), Vector3d(e.x(), 0, 0), Vector3d(0, 0, e.z()));
    rect(lo, Vector3d(0, e.y(), 0), Vector3d(0, 0, e.z()));
    rect(lo + Vector3d(e.x(), 0, 0), Vector3d(0, e.y(), 0), Vector3d(0, 0, e.z()));
    rect(lo + Vector3d(0, 0, e.z()), Vector3d(e.x(), 0, 0), Vector3d(0, e.y(), 0));
  };
  rect({0, 0, 0}, {6, 0, 0}, {0, 4, 0});  // floor
  rect({0, 0, 3}, {6, 0, 0}, {0, 4, 0});  // ceiling
  rect({0, 0, 0}, {6, 0, 0}, {0, 0, 3});
  rect({0, 4, 0}, {6, 0, 0}, {0, 0, 3});
  rect({0, 0, 0}, {0, 4, 0}, {0, 0, 3});
  rect({6, 0, 0}, {0, 4, 0}, {0, 0, 3});
  box({1.0, 1.0, 0.0}, {1.4, 1.3, 3.0});   // pillar
  box({4.0, 3.0, 0.0}, {5.5, 3.6, 1.2});   // cabinet
  box({2.5, 0.0, 0.0}, {3.5, 0.8, 0.4});   // step
  return c;
}

TEST(HornTest, RecoversKnownTransform) {
  Rng rng(1);
  for (int trial = 0; trial < 20; ++trial) {
    const Eigen::Isometry3d T = random_pose(rng, 10.0, M_PI);
    std::vector<Vector3d> p, q;
    for (int i = 0; i < 3 + trial; ++i) {
      p.emplace_back(rng.uniform(-5, 5), rng.uniform(-5, 5), rng.uniform(-5, 5));
      q.push_back(T * p.back());
    }
    const HornResult h = horn_align(p, q);
    ASSERT_TRUE(h.valid);
    EXPECT_EQ(h.num_pairs, p.size());
    EXPECT_LT((h.T_target_source.matrix() - T.matrix()).cwiseAbs().maxCoeff(), 1e-9);
    EXPECT_LT(h.rmse, 1e-6);
  }
}

TEST(HornTest, MatchesLeastSquaresOptimumUnderNoise) {
  // Noisy pairs: the closed form must be a stationary point of the squared error, so no small
  // perturbation of it does better; its reported rmse must equal the one recomputed.
  Rng rng(2);
  const Eigen::Isometry3d T = random_pose(rng, 3.0, 1.0);
  std::vector<Vector3d> p, q;
  for (int i = 0; i < 200; ++i) {
    p.emplace_back(rng.uniform(-5, 5), rng.uniform(-5, 5), rng.uniform(-1, 1));
    q.push_back(T * p.back() + Vector3d(rng.normal(0, 0.05), rng.normal(0, 0.05), rng.normal(0, 0.05)));
  }
  const HornResult h = horn_align(p, q);
  ASSERT_TRUE(h.valid);
  auto sse = [&](const Eigen::Isometry3d& X) {
    double s = 0;
    for (std::size_t i = 0; i < p.size(); ++i) s += (X * p[i] - q[i]).squaredNorm();
    return s;
  };
  const double best = sse(h.T_target_source);
  EXPECT_NEAR(h.rmse, std::sqrt(best / 200.0), 1e-9);
  for (int k = 0; k < 6; ++k) {
    for (double eps : {1e-3, -1e-3}) {
      Vector6d xi = Vector6d::Zero();
      xi(k) = eps;
      Eigen::Isometry3d D = Eigen::Isometry3d::Identity();
      D.linear() = so3::exp(xi.tail<3>());
      D.translation() = xi.head<3>();
      EXPECT_GT(sse(D * h.T_target_source), best);
    }
  }
}

TEST(HornTest, ZeroWeightIgnoresOutlier) {
  Rng rng(3);
  const Eigen::Isometry3d T = random_pose(rng, 2.0, 2.0);
  std::vector<Vector3d> p, q;
  std::vector<double> w;
  for (int i = 0; i < 10; ++i) {
    p.emplace_back(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1));
    q.push_back(T * p.back());
    w.push_back(1.0);
  }
  q[4] += Vector3d(5, 5, 5);
  w[4] = 0.0;
  const HornResult h = horn_align(p, q, &w);
  ASSERT_TRUE(h.valid);
  EXPECT_EQ(h.num_pairs, 9u);
  EXPECT_LT((h.T_target_source.matrix() - T.matrix()).cwiseAbs().maxCoeff(), 1e-9);
}

TEST(HornTest, DegenerateInputIsInvalid) {
  std::vector<Vector3d> p = {{0, 0, 0}, {1, 0, 0}};
  EXPECT_FALSE(horn_align(p, p).valid);  // < 3 pairs
  p = {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}, {3, 0, 0}};
  EXPECT_FALSE(horn_align(p, p).valid);  // collinear
  p = {{1, 1, 1}, {1, 1, 1}, {1, 1, 1}};
  EXPECT_FALSE(horn_align(p, p).valid);  // coincident
  const std::vector<Vector3d> q = {{0, 0, 0}};
  EXPECT_THROW(horn_align(p, q), Error);
  std::vector<Vector3d> bad = p;
  bad[1].x() = std::nan("");
  EXPECT_THROW(horn_align(bad, p), Error);
}

TEST(OverlapTest, CountsPointsWithinBeta) {
  PointCloud target;
  for (int i = 0; i < 10; ++i)
    for (int j = 0; j < 10; ++j) target.points.emplace_back(0.5f * i, 0.5f * j, 0.0f);
  const KdTree3f tree(target);
  PointCloud source;
  // 30 points 0.05 above grid points, 10 points 1 m above, 1 NaN point (not counted).
  for (int k = 0; k < 30; ++k) source.points.emplace_back(0.5f * (k % 10), 0.5f * (k / 10), 0.05f);
  for (int k = 0; k < 10; ++k) source.points.emplace_back(0.5f * k, 0.0f, 1.0f);
  source.points.emplace_back(std::nanf(""), 0.0f, 0.0f);
  OverlapResult r = overlap_ratio(source, tree, Eigen::Isometry3d::Identity(), 0.1);
  EXPECT_EQ(r.num_valid, 40u);
  EXPECT_EQ(r.num_inliers, 30u);
  EXPECT_DOUBLE_EQ(r.overlap, 0.75);
  EXPECT_NEAR(r.rmse, 0.05, 1e-6);
  // Shifting the source down by 1 m moves the other ten onto the grid instead.
  Eigen::Isometry3d down = Eigen::Isometry3d::Identity();
  down.translation() = Vector3d(0, 0, -1);
  r = overlap_ratio(source, tree, down, 0.1);
  EXPECT_EQ(r.num_inliers, 10u);
  EXPECT_THROW(overlap_ratio(source, tree, down, 0.0), Error);
}

// ---------------------------------------------------------------------------------------------

class IcpSyntheticTest : public ::testing::TestWithParam<IcpMethod> {};

TEST_P(IcpSyntheticTest, RecoversKnownTransformFromSeveralStarts) {
  const PointCloud target = room_cloud(0.08, 7);
  Rng rng(11);
  IcpSettings s;
  s.method = GetParam();
  s.max_correspondence_distance = 1.0;
  s.min_overlap = 0.9;
  s.overlap_distance = 0.1;
  s.max_iterations = 100;
  const KdTree3f tree(target);
  for (int trial = 0; trial < 6; ++trial) {
    // The source is the same room sampled differently, moved by T_source_target.
    const Eigen::Isometry3d T_target_source = random_pose(rng, 0.3, 0.12);
    const PointCloud source = transformed(room_cloud(0.15, 100 + trial), T_target_source.inverse());
    const IcpResult r = align_icp(source, target, tree, Eigen::Isometry3d::Identity(), s);
    ASSERT_EQ(r.status, Status::kOk) << trial;
    EXPECT_TRUE(r.converged);
    const auto e = pose_error(r.T_target_source, T_target_source);
    EXPECT_LT(e.first, 0.01) << trial;
    EXPECT_LT(e.second, 0.2 * M_PI / 180) << trial;
    EXPECT_GE(r.overlap, 0.9);
    EXPECT_GT(r.num_inliers, source.size() / 2);
    EXPECT_GT(r.degeneracy, 1e-3);
    // Inverse direction: aligning target to source gives the inverse.
    const KdTree3f stree(source);
    IcpSettings si = s;
    si.min_overlap = 0.5;  // the denser target has points between the sparse source's
    const IcpResult ri = align_icp(target, source, stree, Eigen::Isometry3d::Identity(), si);
    ASSERT_NE(ri.status, Status::kInsufficientData);
    const auto ei = pose_error(ri.T_target_source.inverse(), T_target_source);
    EXPECT_LT(ei.first, 0.02) << trial;
    EXPECT_LT(ei.second, 0.3 * M_PI / 180) << trial;
  }
}

INSTANTIATE_TEST_SUITE_P(Methods, IcpSyntheticTest,
                         ::testing::Values(IcpMethod::kPointToPoint, IcpMethod::kPointToPlane));

TEST(IcpTest, OverlapGateShrinksDistanceAndRejects) {
  const PointCloud target = room_cloud(0.1, 3);
  PointCloud source = room_cloud(0.2, 4);
  // Add a clutter block that is not in the target: the overlap cannot reach 0.99.
  Rng rng(5);
  for (int i = 0; i < static_cast<int>(source.size() / 4); ++i)
    source.points.emplace_back(rng.uniform(1.0, 2.0), rng.uniform(1.0, 2.0), rng.uniform(0.5, 1.5));
  source.normals.clear();
  IcpSettings s;
  s.min_overlap = 0.99;
  s.max_correspondence_distance = 0.5;
  s.distance_step = 0.1;
  s.min_correspondence_distance = 0.2;
  const IcpResult r = align_icp(source, target, Eigen::Isometry3d::Identity(), s);
  EXPECT_EQ(r.status, Status::kRejected);
  EXPECT_EQ(r.rounds, 4);  // d = 0.5, 0.4, 0.3, 0.2
  EXPECT_NEAR(r.final_correspondence_distance, 0.2, 1e-9);
  EXPECT_LT(r.overlap, 0.99);
  EXPECT_GT(r.overlap, 0.6);
  s.min_overlap = 0.7;
  const IcpResult ok = align_icp(source, target, Eigen::Isometry3d::Identity(), s);
  EXPECT_EQ(ok.status, Status::kOk);
  EXPECT_GE(ok.overlap, 0.7);
  EXPECT_LT(ok.rounds, 4);
}

TEST(IcpTest, RobustKernelResistsOutliers) {
  const PointCloud target = room_cloud(0.08, 21);
  Rng rng(22);
  const Eigen::Isometry3d T_target_source = random_pose(rng, 0.2, 0.05);
  PointCloud source = transformed(room_cloud(0.15, 23), T_target_source.inverse());
  // Gross outliers close to surfaces (inside the correspondence distance).
  const std::size_t n = source.size();
  for (std::size_t i = 0; i < n; i += 4) source.points[i] += Vector3f(0.25f, -0.25f, 0.2f);
  source.normals.clear();
  IcpSettings s;
  s.max_correspondence_distance = 0.6;
  s.min_overlap = 0.0;
  s.max_iterations = 100;
  s.kernel = RobustKernel::kTukey;
  s.kernel_scale = 0.1;
  const auto robust = pose_error(align_icp(source, target, Eigen::Isometry3d::Identity(), s).T_target_source, T_target_source);
  s.kernel = RobustKernel::kNone;
  const auto plain = pose_error(align_icp(source, target, Eigen::Isometry3d::Identity(), s).T_target_source, T_target_source);
  EXPECT_LT(robust.first, 0.02);
  EXPECT_LT(robust.first, plain.first);
}

/// An n x n grid of points 0.1 m apart on the plane z = 0, normals up.
PointCloud flat_plane(int n) {
  PointCloud plane;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) plane.points.emplace_back(0.1f * i, 0.1f * j, 0.0f);
  plane.normals.assign(plane.points.size(), Vector3f(0, 0, 1));
  return plane;
}

TEST(IcpTest, DegeneracyIndicatorFlagsSinglePlane) {
  const PointCloud plane = flat_plane(40);
  IcpSettings s;
  s.method = IcpMethod::kPointToPlane;
  s.min_overlap = 0.0;
  s.degeneracy_threshold = 1e-4;
  const IcpResult r = align_icp(plane, plane, Eigen::Isometry3d::Identity(), s);
  EXPECT_LT(r.degeneracy, 1e-9);
  EXPECT_EQ(r.status, Status::kDegenerate);
  const PointCloud room = room_cloud(0.1, 1);
  const IcpResult rr = align_icp(room, room, Eigen::Isometry3d::Identity(), s);
  EXPECT_GT(rr.degeneracy, 1e-2);
  EXPECT_EQ(rr.status, Status::kOk);
}

// The normal matrix is J^T J of the metric's residuals at the final pairs, J by central
// differences of each residual under the documented motion about the documented pivot; the
// degeneracy is its smallest eigenvalue per pair. A single plane leaves it rank 3.
TEST(IcpTest, NormalMatrixIsTheResidualsJacobianProduct) {
  const PointCloud target = room_cloud(0.1, 3);
  Rng rng(5);
  const Eigen::Isometry3d T_target_source = random_pose(rng, 0.1, 0.05);
  const PointCloud source = transformed(room_cloud(0.2, 4), T_target_source.inverse());
  for (IcpMethod method : {IcpMethod::kPointToPlane, IcpMethod::kPointToPoint}) {
    IcpSettings s;
    s.method = method;
    s.keep_correspondences = true;
    s.min_overlap = 0.5;
    const IcpResult r = align_icp(source, target, Eigen::Isometry3d::Identity(), s);
    ASSERT_NE(r.status, Status::kInsufficientData);
    ASSERT_EQ(r.correspondences.size(), r.num_inliers);
    Vector3d centroid = Vector3d::Zero();
    for (const IcpCorrespondence& c : r.correspondences) centroid += c.x;
    centroid /= static_cast<double>(r.correspondences.size());
    EXPECT_LT((r.normal_matrix_pivot - centroid).norm(), 1e-9);
    const Vector3d m = r.normal_matrix_pivot;
    Matrix6d H = Matrix6d::Zero();
    const double h = 1e-6;
    for (const IcpCorrespondence& c : r.correspondences) {
      auto residual = [&](const Vector6d& d) -> Vector3d {
        const Vector3d x = c.x + d.head<3>().cross(c.x - m) + d.tail<3>();
        if (method == IcpMethod::kPointToPlane) return Vector3d(c.n.dot(x - c.q), 0.0, 0.0);
        return x - c.q;
      };
      Eigen::Matrix<double, 3, 6> J;
      for (int k = 0; k < 6; ++k) {
        const Vector6d e = Vector6d::Unit(k) * h;
        J.col(k) = (residual(e) - residual(-e)) / (2.0 * h);
      }
      H += J.transpose() * J;
    }
    EXPECT_LT((r.normal_matrix - H).norm(), 1e-6 * H.norm()) << static_cast<int>(method);
    const Eigen::SelfAdjointEigenSolver<Matrix6d> es(H / static_cast<double>(r.num_inliers));
    EXPECT_NEAR(r.degeneracy, es.eigenvalues()(0), 1e-9);
  }
  const PointCloud plane = flat_plane(30);
  IcpSettings s;
  s.method = IcpMethod::kPointToPlane;
  s.min_overlap = 0.0;
  const IcpResult r = align_icp(plane, plane, Eigen::Isometry3d::Identity(), s);
  const Eigen::SelfAdjointEigenSolver<Matrix6d> es(r.normal_matrix);
  EXPECT_LT(es.eigenvalues()(2), 1e-9 * es.eigenvalues()(5));  // x, y and yaw unconstrained
  EXPECT_GT(es.eigenvalues()(3), 1e-3 * es.eigenvalues()(5));
}

TEST(IcpTest, BadInput) {
  const PointCloud room = room_cloud(0.2, 1);
  const KdTree3f tree(room);
  PointCloud empty;
  EXPECT_EQ(align_icp(empty, room, tree, Eigen::Isometry3d::Identity()).status, Status::kInsufficientData);
  PointCloud two;
  two.points = {Vector3f(0, 0, 0), Vector3f(1, 0, 0)};
  EXPECT_EQ(align_icp(two, room, tree, Eigen::Isometry3d::Identity()).status, Status::kInsufficientData);
  EXPECT_EQ(align_icp(room, empty, Eigen::Isometry3d::Identity()).status, Status::kInsufficientData);
  // Collinear source: Horn cannot fix the rotation about the line.
  PointCloud line;
  for (int i = 0; i < 50; ++i) line.points.emplace_back(0.1f * i, 0.0f, 0.0f);
  const IcpResult rl = align_icp(line, line, Eigen::Isometry3d::Identity());
  EXPECT_NE(rl.status, Status::kOk);
  EXPECT_TRUE(rl.T_target_source.matrix().allFinite());
  // NaN points are skipped.
  PointCloud with_nan = room;
  with_nan.points[3].x() = std::nanf("");
  with_nan.normals.clear();
  IcpSettings loose;
  loose.min_overlap = 0.5;
  EXPECT_EQ(align_icp(with_nan, room, tree, Eigen::Isometry3d::Identity(), loose).status, Status::kOk);
  // Misuse throws.
  PointCloud no_normals = room;
  no_normals.normals.clear();
  IcpSettings p2pl;
  p2pl.method = IcpMethod::kPointToPlane;
  EXPECT_THROW(align_icp(room, no_normals, Eigen::Isometry3d::Identity(), p2pl), Error);
  const KdTree3f small_tree(two);
  EXPECT_THROW(align_icp(room, room, small_tree, Eigen::Isometry3d::Identity()), Error);
  Eigen::Isometry3d bad = Eigen::Isometry3d::Identity();
  bad(0, 3) = std::nan("");
  EXPECT_THROW(align_icp(room, room, tree, bad), Error);
  IcpSettings neg;
  neg.max_correspondence_distance = -1.0;
  EXPECT_THROW(align_icp(room, room, tree, Eigen::Isometry3d::Identity(), neg), Error);
  neg = IcpSettings{};
  neg.min_overlap = 1.5;
  EXPECT_THROW(align_icp(room, room, tree, Eigen::Isometry3d::Identity(), neg), Error);
}

TEST(IcpTest, Deterministic) {
  const PointCloud target = room_cloud(0.1, 1);
  Rng rng(9);
  const PointCloud source = transformed(room_cloud(0.12, 2), random_pose(rng, 0.2, 0.1));
  IcpSettings s;
  s.method = IcpMethod::kPointToPlane;
  s.kernel = RobustKernel::kHuber;
  const IcpResult a = align_icp(source, target, Eigen::Isometry3d::Identity(), s);
  const IcpResult b = align_icp(source, target, Eigen::Isometry3d::Identity(), s);
  EXPECT_EQ(a.T_target_source.matrix(), b.T_target_source.matrix());
  EXPECT_EQ(a.iterations, b.iterations);
  EXPECT_EQ(a.rmse, b.rmse);
}

// The correspondence search split over threads changes nothing: the same pose, iterations,
// inliers, RMSE, overlap and normal matrix bit for bit as on one thread, for both metrics and a
// robust kernel, on clouds of many chunks.
TEST(IcpTest, ThreadCountDoesNotChangeTheResult) {
  const PointCloud target = room_cloud(0.08, 1);
  Rng rng(9);
  const PointCloud source = transformed(room_cloud(0.1, 2), random_pose(rng, 0.2, 0.1));
  ASSERT_GT(source.size(), 5 * detail::kIcpGrain);
  for (const IcpMethod method : {IcpMethod::kPointToPoint, IcpMethod::kPointToPlane}) {
    IcpSettings s;
    s.method = method;
    s.kernel = RobustKernel::kHuber;
    s.keep_correspondences = true;
    const IcpResult one = align_icp(source, target, Eigen::Isometry3d::Identity(), s);
    ASSERT_GT(one.iterations, 2);
    for (const int threads : {2, 3, 8, 0}) {
      s.threads = threads;
      const IcpResult r = align_icp(source, target, Eigen::Isometry3d::Identity(), s);
      EXPECT_EQ(r.T_target_source.matrix(), one.T_target_source.matrix()) << threads;
      EXPECT_EQ(r.iterations, one.iterations) << threads;
      EXPECT_EQ(r.rounds, one.rounds) << threads;
      EXPECT_EQ(r.num_inliers, one.num_inliers) << threads;
      EXPECT_EQ(r.rmse, one.rmse) << threads;
      EXPECT_EQ(r.overlap, one.overlap) << threads;
      EXPECT_EQ(r.normal_matrix, one.normal_matrix) << threads;
      ASSERT_EQ(r.correspondences.size(), one.correspondences.size()) << threads;
      for (std::size_t k = 0; k < r.correspondences.size(); ++k) {
        EXPECT_EQ(r.correspondences[k].source_index, one.correspondences[k].source_index) << k;
        EXPECT_EQ(r.correspondences[k].target_index, one.correspondences[k].target_index) << k;
      }
    }
  }
  IcpSettings bad;
  bad.threads = -1;
  EXPECT_THROW(align_icp(source, target, Eigen::Isometry3d::Identity(), bad), Error);
}

// The per-point query cache of align_icp (bounded searches, skipped far points) only prunes: the
// iterates must equal a plain ICP written here with brute-force nearest neighbours, also when
// most of the source lies outside the correspondence distance (clutter beyond the room).
TEST(IcpTest, MatchesBruteForceIcpWithFarPoints) {
  const PointCloud target = room_cloud(0.15, 3);
  Rng rng(11);
  PointCloud source = room_cloud(0.2, 4);
  for (int i = 0; i < 600; ++i)  // far clutter: 2-5 m outside the room
    source.points.emplace_back(static_cast<float>(rng.uniform(8, 11)), static_cast<float>(rng.uniform(-3, 7)),
                               static_cast<float>(rng.uniform(0, 3)));
  source.normals.clear();
  const Eigen::Isometry3d T_init = random_pose(rng, 0.15, 0.05);
  IcpSettings s;
  s.max_correspondence_distance = 0.5;
  s.min_correspondence_distance = 0.5;
  s.max_iterations = 12;
  s.tolerance = 0.0;  // run all iterations
  s.min_step = 0.0;
  s.min_overlap = 0.0;
  const IcpResult r = align_icp(source, target, T_init, s);
  ASSERT_EQ(r.iterations, 12);

  Eigen::Isometry3d T = T_init;
  for (int it = 0; it < 12; ++it) {
    const Eigen::Matrix3f R = T.linear().cast<float>();
    const Eigen::Vector3f t = T.translation().cast<float>();
    std::vector<Vector3d> ps, qs;
    for (const Vector3f& p : source.points) {
      const Vector3f x = R * p + t;
      float best = 0.25f;  // d^2
      int best_j = -1;
      for (std::size_t j = 0; j < target.size(); ++j) {
        const float dd = (target.points[j] - x).squaredNorm();
        if (dd <= best) {
          best = dd;
          best_j = static_cast<int>(j);
        }
      }
      if (best_j < 0) continue;
      ps.push_back(x.cast<double>());
      qs.push_back(target.points[static_cast<std::size_t>(best_j)].cast<double>());
    }
    const HornResult h = horn_align(ps, qs);
    ASSERT_TRUE(h.valid);
    T = h.T_target_source * T;
    T.linear() = Eigen::Quaterniond(T.linear()).normalized().toRotationMatrix();
  }
  const auto e = pose_error(r.T_target_source, T);
  EXPECT_LT(e.first, 1e-6);
  EXPECT_LT(e.second, 1e-6);
}

// ---- the neighbour cache of align_icp against brute force, bit for bit -------------------------

/// Nearest target point of x within d (d^2 in float), by brute force with the kd-tree's float
/// distance (detail::dist_sq); the first of equally distant points wins. -1: none.
int brute_nearest(const PointCloud& target, const Vector3f& x, float d_sq, float& best) {
  best = d_sq;
  int best_j = -1;
  for (std::size_t j = 0; j < target.size(); ++j) {
    const float dd = detail::dist_sq<3>(target.points[j].data(), x.data());
    if (dd < best || (best_j < 0 && dd == best)) {
      best = dd;
      best_j = static_cast<int>(j);
    }
  }
  return best_j;
}

/// detail::icp_pairs' pairs without any cache: brute-force nearest neighbours within d.
std::vector<detail::IcpPair> brute_pairs(const PointCloud& source, const PointCloud& target,
                                         const Eigen::Isometry3d& T, double d, double& mse) {
  const Eigen::Matrix3f R = T.linear().cast<float>();
  const Eigen::Vector3f t = T.translation().cast<float>();
  std::vector<detail::IcpPair> out;
  double sum_sq = 0.0;
  for (const Vector3f& p : source.points) {
    const Vector3f x = R * p + t;
    float best = 0.0f;
    const int j = brute_nearest(target, x, static_cast<float>(d * d), best);
    if (j < 0) continue;
    detail::IcpPair pr;
    pr.x = x.cast<double>();
    pr.q = target.points[static_cast<std::size_t>(j)].cast<double>();
    pr.n.setZero();
    out.push_back(pr);
    sum_sq += static_cast<double>(best);
  }
  mse = out.empty() ? 0.0 : sum_sq / static_cast<double>(out.size());
  return out;
}

/// A target like the benchmark's room_scan1, which holds every point twice (ties in every query),
/// and a sparser source with clutter 2-5 m outside the room (points without any neighbour).
std::pair<PointCloud, PointCloud> cache_test_clouds() {
  PointCloud target = room_cloud(0.15, 5);
  target.normals.clear();
  const std::size_t n = target.size();
  for (std::size_t i = 0; i < n; ++i) target.points.push_back(target.points[i]);
  Rng rng(13);
  PointCloud source = room_cloud(0.3, 6);
  source.normals.clear();
  for (int i = 0; i < 150; ++i)
    source.points.emplace_back(static_cast<float>(rng.uniform(8, 11)), static_cast<float>(rng.uniform(-3, 7)),
                               static_cast<float>(rng.uniform(0, 3)));
  return {target, source};
}

/// What the neighbour-cache tests share: the clouds above, the target's kd-tree, one cache that
/// lives through the whole pose sequence, the pair buffer and default settings.
class IcpCacheTest : public ::testing::Test {
 protected:
  IcpCacheTest() : clouds_(cache_test_clouds()), tree(clouds_.first), cache(clouds_.second.size()) {}

  std::pair<PointCloud, PointCloud> clouds_;
  const PointCloud& target = clouds_.first;
  const PointCloud& source = clouds_.second;
  KdTree3f tree;
  detail::IcpNnCache cache;
  std::vector<detail::IcpPair> pairs;
  IcpSettings s;
};

// One cache through a sequence of poses whose steps shrink from 0.3 m to 1e-6 m (as in ICP), then
// jump, with d changing between calls: every call's pairs (and their order) and mean squared
// residual equal brute force exactly. Equally distant target points are exact duplicates here, so
// the tie that the cache may break differently cannot show.
TEST_F(IcpCacheTest, NeighbourCacheGivesBruteForcePairs) {
  Rng rng(17);
  Eigen::Isometry3d T = random_pose(rng, 0.3, 0.1);
  const double ds[] = {1.0, 0.5, 0.2, 0.35};
  int call = 0;
  std::size_t total_pairs = 0;
  for (double step : {0.3, 0.1, 0.03, 0.01, 3e-3, 1e-3, 1e-4, 1e-5, 1e-6, 0.0, 0.5, 0.02, 1e-3, 0.0}) {
    T = random_pose(rng, step, step / 3) * T;
    const double d = ds[call++ % 4];
    const double mse = detail::icp_pairs(source, target, tree, T, d, s, pairs, cache);
    double mse_ref = 0.0;
    const std::vector<detail::IcpPair> ref = brute_pairs(source, target, T, d, mse_ref);
    ASSERT_EQ(pairs.size(), ref.size()) << "call " << call;
    for (std::size_t k = 0; k < ref.size(); ++k) {
      ASSERT_EQ(pairs[k].x, ref[k].x) << "call " << call << " pair " << k;
      ASSERT_EQ(pairs[k].q, ref[k].q) << "call " << call << " pair " << k;
    }
    EXPECT_EQ(mse, mse_ref) << "call " << call;
    total_pairs += ref.size();
  }
  EXPECT_GT(total_pairs, 14 * source.size() / 2);  // the test is not vacuous
}

// The overlap ratio through the same cache (align_icp's gate, once per round) equals brute force
// and overlap_ratio() exactly, interleaved with pair queries at other distances as in align_icp.
TEST_F(IcpCacheTest, CachedOverlapEqualsBruteForce) {
  Rng rng(23);
  Eigen::Isometry3d T = random_pose(rng, 0.3, 0.1);
  const double betas[] = {0.1, 0.05, 0.3};
  int call = 0;
  double sum_overlap = 0.0;
  for (double step : {0.3, 0.03, 3e-3, 1e-4, 1e-6, 0.0, 0.5, 1e-3, 0.0}) {
    T = random_pose(rng, step, step / 3) * T;
    detail::icp_pairs(source, target, tree, T, 0.6, s, pairs, cache);
    const double beta = betas[call++ % 3];
    const OverlapResult o = detail::icp_overlap(source, target, tree, T, beta, cache);
    const OverlapResult ref = overlap_ratio(source, tree, T, beta);
    double mse_ref = 0.0;
    const std::size_t brute_inliers = brute_pairs(source, target, T, beta, mse_ref).size();
    EXPECT_EQ(o.num_valid, source.size()) << "call " << call;
    EXPECT_EQ(o.num_inliers, brute_inliers) << "call " << call;
    EXPECT_EQ(o.num_inliers, ref.num_inliers) << "call " << call;
    EXPECT_EQ(o.overlap, ref.overlap) << "call " << call;
    EXPECT_EQ(o.rmse, ref.rmse) << "call " << call;
    sum_overlap += o.overlap;
  }
  EXPECT_GT(sum_overlap, 0.3 * call);  // not vacuous: most calls find most points
}

// align_icp over several rounds (the overlap gate never passes, so d shrinks from 0.6 to 0.2 m and
// the cache lives through all of them) equals plain ICP written here on brute-force pairs: the
// same pose bit for bit, the same iterations, inliers and RMSE.
TEST(IcpTest, CachedIcpEqualsBruteForceIcpBitForBit) {
  const auto [target, source] = cache_test_clouds();
  Rng rng(19);
  const Eigen::Isometry3d T_init = random_pose(rng, 0.2, 0.08);
  IcpSettings s;
  s.max_correspondence_distance = 0.6;
  s.distance_step = 0.2;
  s.min_correspondence_distance = 0.2;
  s.max_iterations = 10;
  s.tolerance = 0.0;  // every round runs all of its iterations
  s.min_step = 0.0;
  s.min_overlap = 1.0;  // the clutter keeps the overlap below 1: every round runs
  const IcpResult r = align_icp(source, target, T_init, s);
  EXPECT_EQ(r.rounds, 3);
  EXPECT_EQ(r.iterations, 30);

  Eigen::Isometry3d T = T_init;
  double d = s.max_correspondence_distance;
  double mse = 0.0;
  for (int round = 0; round < 3; ++round) {
    if (round > 0) d -= s.distance_step;  // as align_icp steps it
    for (int it = 0; it < s.max_iterations; ++it) {
      const std::vector<detail::IcpPair> pairs = brute_pairs(source, target, T, d, mse);
      Eigen::Isometry3d delta;
      ASSERT_TRUE(detail::icp_step(pairs, s, delta));
      T = delta * T;
      T.linear() = Eigen::Quaterniond(T.linear()).normalized().toRotationMatrix();
    }
  }
  const std::vector<detail::IcpPair> pairs = brute_pairs(source, target, T, d, mse);
  double sum_sq = 0.0;
  for (const detail::IcpPair& pr : pairs) sum_sq += (pr.x - pr.q).squaredNorm();
  EXPECT_EQ(r.T_target_source.matrix(), T.matrix());
  EXPECT_EQ(r.num_inliers, pairs.size());
  EXPECT_GT(r.num_inliers, source.size() / 2);
  EXPECT_DOUBLE_EQ(r.rmse, std::sqrt(sum_sq / static_cast<double>(pairs.size())));
  EXPECT_TRUE(r.correspondences.empty());  // not asked for
  // The gate's overlap (through the cache) is overlap_ratio() at the result.
  EXPECT_EQ(r.overlap, overlap_ratio(source, KdTree3f(target), r.T_target_source, s.overlap_distance).overlap);

  // keep_correspondences: the same run, and its final pairs are the brute-force ones.
  s.keep_correspondences = true;
  const IcpResult kept = align_icp(source, target, T_init, s);
  EXPECT_EQ(kept.T_target_source.matrix(), r.T_target_source.matrix());
  ASSERT_EQ(kept.correspondences.size(), pairs.size());
  for (std::size_t k = 0; k < pairs.size(); ++k) {
    const IcpCorrespondence& c = kept.correspondences[k];
    EXPECT_EQ(c.x, pairs[k].x) << k;
    EXPECT_EQ(c.q, pairs[k].q) << k;
    ASSERT_LT(c.source_index, source.size());
    ASSERT_LT(c.target_index, target.size());
    EXPECT_EQ(c.q, target.points[c.target_index].cast<double>()) << k;
    const Vector3f moved = T.linear().cast<float>() * source.points[c.source_index] + T.translation().cast<float>();
    EXPECT_EQ(c.x, moved.cast<double>()) << k;
    EXPECT_LE((c.x - c.q).norm(), d + 1e-6) << k;
  }
}

}  // namespace
}  // namespace plumb
