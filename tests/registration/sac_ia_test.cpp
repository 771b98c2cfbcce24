// SPDX-License-Identifier: BSD-3-Clause
// Feature-space kNN, SAC-IA and localize_coarse_to_fine(): oracle, determinism and bad input.

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "plumb/core/error.hpp"
#include "plumb/core/rng.hpp"
#include "plumb/core/robust_kernel.hpp"
#include "plumb/features/fpfh.hpp"
#include "plumb/features/normals.hpp"
#include "plumb/io/cloud_io.hpp"
#include "plumb/registration/feature_index.hpp"
#include "plumb/registration/localize.hpp"
#include "plumb/registration/sac_ia.hpp"
#include "test_data.hpp"

namespace plumb {
namespace {

TEST(FeatureKnnTest, MatchesBruteForce) {
  Rng rng(5);
  // Clustered 33-D vectors (like FPFH: few modes), plus exact duplicates for ties.
  std::vector<FpfhSignature> q(300), d(700);
  auto draw = [&](FpfhSignature& f) {
    const int mode = static_cast<int>(rng.uniform_index(5));
    for (int b = 0; b < kFpfhBins; ++b) f[b] = static_cast<float>(10.0 * ((b + mode) % 7) + rng.uniform(0, 20));
  };
  for (auto& f : q) draw(f);
  for (auto& f : d) draw(f);
  d[12] = d[13];
  q[0] = d[12];
  std::vector<std::size_t> qi, di;
  for (std::size_t i = 0; i < q.size(); ++i) qi.push_back(i);
  for (std::size_t i = 0; i < d.size(); ++i) {
    if (i % 7 != 3) di.push_back(i);  // a subset (12 and 13 are in it)
  }
  const std::size_t k = 6;
  const std::vector<std::uint32_t> got = feature_knn(q, qi, d, di, k);
  ASSERT_EQ(got.size(), q.size() * k);
  // Oracle: brute force in double. The tree works on rotated vectors (float rounding differs by
  // ~1e-6 relative), so the m-th distance must match, and the index too unless two distances are
  // that close.
  auto dist = [&](const FpfhSignature& a, const FpfhSignature& b) {
    double sum = 0.0;
    for (int t = 0; t < kFpfhBins; ++t) sum += (double(a[t]) - double(b[t])) * (double(a[t]) - double(b[t]));
    return sum;
  };
  for (std::size_t a = 0; a < q.size(); ++a) {
    std::vector<std::pair<double, std::size_t>> all;
    for (std::size_t j : di) all.push_back({dist(q[a], d[j]), j});
    std::sort(all.begin(), all.end());
    for (std::size_t m = 0; m < k; ++m) {
      const double got_d = dist(q[a], d[got[a * k + m]]);
      ASSERT_NEAR(got_d, all[m].first, 1e-5 * (1.0 + all[m].first)) << a << " " << m;
      const bool near_tie = (m > 0 && all[m].first - all[m - 1].first < 1e-4 * (1.0 + all[m].first)) ||
                            (m + 1 < all.size() && all[m + 1].first - all[m].first < 1e-4 * (1.0 + all[m].first));
      if (!near_tie) {
        ASSERT_EQ(got[a * k + m], all[m].second) << a << " " << m;
      }
    }
  }
  const std::vector<std::size_t> bad = {5000};
  EXPECT_THROW(feature_knn(q, qi, d, bad, k), Error);
}

struct Bunny {
  PointCloud source, target;
  std::vector<FpfhSignature> fs, ft;
};

Bunny load_bunny() {
  Bunny b;
  b.source = io::read_cloud(test::data_path("cloud3d/pcl_test/bun0.pcd"));
  b.target = io::read_cloud(test::data_path("cloud3d/pcl_test/bun4.pcd"));
  NormalSettings ns;
  ns.k = 30;
  ns.radius = 0.02f;
  compute_normals(b.source, ns);
  compute_normals(b.target, ns);
  FpfhSettings f;
  f.radius = 0.05f;
  b.fs = compute_fpfh(b.source, f).features;
  b.ft = compute_fpfh(b.target, f).features;
  return b;
}

SacIaSettings bunny_settings() {
  SacIaSettings s;
  s.min_sample_distance = 0.05;
  s.max_correspondence_distance = 0.1;
  s.huber_threshold = 0.01;
  s.max_iterations = 500;
  return s;
}

TEST(SacIaTest, SameSeedBitIdenticalOtherSeedRuns) {
  PLUMB_REQUIRE_DATA(p0, "cloud3d/pcl_test/bun0.pcd");
  PLUMB_REQUIRE_DATA(p4, "cloud3d/pcl_test/bun4.pcd");
  const Bunny b = load_bunny();
  const KdTree3f tree(b.target);
  SacIaSettings s = bunny_settings();
  const SacIaResult r1 = align_sac_ia(b.source, b.fs, b.target, b.ft, tree, s);
  const SacIaResult r2 = align_sac_ia(b.source, b.fs, b.target, b.ft, tree, s);
  ASSERT_NE(r1.status, Status::kInsufficientData);
  EXPECT_EQ(r1.T_target_source.matrix(), r2.T_target_source.matrix());
  EXPECT_EQ(r1.score, r2.score);
  EXPECT_EQ(r1.iterations, r2.iterations);
  EXPECT_EQ(r1.num_scored, r2.num_scored);
  s.seed = 43;
  const SacIaResult r3 = align_sac_ia(b.source, b.fs, b.target, b.ft, tree, s);
  EXPECT_NE(r3.status, Status::kInsufficientData);
  EXPECT_GT(r1.overlap, 0.5);
  // The score is the Huber total of the returned transform (recomputed independently).
  double total = 0.0;
  for (const Vector3f& p : b.source.points) {
    const auto nn = tree.nearest((r1.T_target_source * p.cast<double>()).cast<float>());
    total += RobustLoss::huber(s.huber_threshold)
                 .loss(std::min(std::sqrt(static_cast<double>(nn->dist_sq)), s.max_correspondence_distance));
  }
  EXPECT_NEAR(r1.score, total, 1e-6 * total);
}

TEST(SacIaTest, BadInput) {
  PLUMB_REQUIRE_DATA(p0, "cloud3d/pcl_test/bun0.pcd");
  PLUMB_REQUIRE_DATA(p4, "cloud3d/pcl_test/bun4.pcd");
  const Bunny b = load_bunny();
  const KdTree3f tree(b.target);
  const SacIaSettings s = bunny_settings();
  // Too few usable points / all-zero features: a status, no throw.
  PointCloud two;
  two.points = {Vector3f(0, 0, 0), Vector3f(1, 0, 0)};
  std::vector<FpfhSignature> f2(2, b.fs[0]);
  EXPECT_EQ(align_sac_ia(two, f2, b.target, b.ft, tree, s).status, Status::kInsufficientData);
  std::vector<FpfhSignature> zeros(b.fs.size(), FpfhSignature{});
  EXPECT_EQ(align_sac_ia(b.source, zeros, b.target, b.ft, tree, s).status, Status::kInsufficientData);
  // NaN points are skipped.
  PointCloud with_nan = b.source;
  with_nan.points[0] = Vector3f::Constant(std::nanf(""));
  EXPECT_NE(align_sac_ia(with_nan, b.fs, b.target, b.ft, tree, s).status, Status::kInsufficientData);
  // Misuse throws.
  std::vector<FpfhSignature> short_f(b.fs.begin(), b.fs.begin() + 10);
  EXPECT_THROW(align_sac_ia(b.source, short_f, b.target, b.ft, tree, s), Error);
  const KdTree3f other(b.source);
  EXPECT_THROW(align_sac_ia(b.source, b.fs, b.target, b.ft, other, s), Error);
  SacIaSettings bad = s;
  bad.num_samples = 2;
  EXPECT_THROW(align_sac_ia(b.source, b.fs, b.target, b.ft, tree, bad), Error);
  bad = s;
  bad.max_correspondence_distance = 0.001;  // below the Huber threshold
  EXPECT_THROW(align_sac_ia(b.source, b.fs, b.target, b.ft, tree, bad), Error);
  bad = s;
  bad.prescore_slack = -0.1;
  EXPECT_THROW(align_sac_ia(b.source, b.fs, b.target, b.ft, tree, bad), Error);
  bad = s;
  bad.confidence = 0.0;
  EXPECT_THROW(align_sac_ia(b.source, b.fs, b.target, b.ft, tree, bad), Error);
  // Mutual filter on features that match nothing mutually still returns, never throws.
  bad = s;
  bad.mutual_filter = true;
  EXPECT_NO_THROW(align_sac_ia(two, f2, b.target, b.ft, tree, bad));
}

TEST(FeatureKdTreeTest, ExactOnRealFpfhAndTiesToSmallerIndex) {
  PLUMB_REQUIRE_DATA(p0, "cloud3d/pcl_test/bun0.pcd");
  const Bunny b = load_bunny();
  // Exact duplicates of a query: both at distance 0, smaller index first.
  std::vector<FpfhSignature> data = b.ft;
  data[20] = b.fs[7];
  data[3] = b.fs[7];
  std::vector<std::size_t> ids(data.size());
  for (std::size_t i = 0; i < ids.size(); ++i) ids[i] = i;
  const FeatureKdTree<kFpfhBins> tree(data, ids);
  ASSERT_EQ(tree.size(), data.size());
  std::uint32_t idx[8];
  float d2[8];
  ASSERT_EQ(tree.knn(b.fs[7].data(), 8, idx, d2), 8u);
  EXPECT_EQ(idx[0], 3u);
  EXPECT_EQ(idx[1], 20u);
  // Every 25th source signature against a brute force of the real target signatures.
  for (std::size_t a = 0; a < b.fs.size(); a += 25) {
    tree.knn(b.fs[a].data(), 8, idx, d2);
    std::vector<float> all;
    for (const auto& f : data) all.push_back(feature_distance_sq<kFpfhBins>(b.fs[a].data(), f.data()));
    std::sort(all.begin(), all.end());
    for (int m = 0; m < 8; ++m) {
      ASSERT_NEAR(d2[m], all[static_cast<std::size_t>(m)], 1e-4f * (1.0f + all[static_cast<std::size_t>(m)])) << a;
    }
  }
  std::vector<FpfhSignature> bad = data;
  bad[5][2] = std::nanf("");
  EXPECT_THROW(FeatureKdTree<kFpfhBins>(bad, ids), Error);
  EXPECT_THROW(FeatureKdTree<kFpfhBins>(data, {data.size()}), Error);
}

/// The bunny against itself moved by a large transform: every signature has its exact twin.
struct EasyCase {
  PointCloud source, target;
  std::vector<FpfhSignature> features;
  Eigen::Isometry3d T_target_source;
};

/// RMS displacement [m] of the target points between two estimates (a coarse-stage error measure
/// that does not depend on where the frame's origin is).
double rms_offset(const PointCloud& cloud, const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  double sum = 0.0;
  for (const Vector3f& p : cloud.points) sum += (a * p.cast<double>() - b * p.cast<double>()).squaredNorm();
  return std::sqrt(sum / static_cast<double>(cloud.size()));
}

EasyCase easy_case() {
  EasyCase e;
  e.target = io::read_cloud(test::data_path("cloud3d/pcl_test/bun4.pcd"));
  NormalSettings ns;
  ns.k = 30;
  ns.radius = 0.02f;
  compute_normals(e.target, ns);
  FpfhSettings f;
  f.radius = 0.05f;
  e.features = compute_fpfh(e.target, f).features;
  Eigen::Isometry3d T_source_target = Eigen::Isometry3d::Identity();
  T_source_target.linear() = Eigen::AngleAxisd(2.0, Vector3d(0.2, 0.3, 1.0).normalized()).toRotationMatrix();
  T_source_target.translation() = Vector3d(3.0, -2.0, 0.5);
  e.source = transformed(e.target, T_source_target);
  e.T_target_source = T_source_target.inverse();
  return e;
}

TEST(SacIaTest, EarlyTerminationStopsSoonerOnEasyCase) {
  PLUMB_REQUIRE_DATA(p4, "cloud3d/pcl_test/bun4.pcd");
  const EasyCase e = easy_case();
  const KdTree3f tree(e.target);
  SacIaSettings s = bunny_settings();
  s.max_iterations = 3000;
  const SacIaResult fast = align_sac_ia(e.source, e.features, e.target, e.features, tree, s);
  s.confidence = 1.0;
  const SacIaResult full = align_sac_ia(e.source, e.features, e.target, e.features, tree, s);
  EXPECT_TRUE(fast.converged);
  EXPECT_EQ(fast.status, Status::kOk);
  EXPECT_LT(fast.iterations, full.iterations / 5);
  EXPECT_EQ(full.iterations, 3000);
  EXPECT_FALSE(full.converged);
  EXPECT_EQ(full.status, Status::kNotConverged);
  EXPECT_LT(fast.num_feature_queries, e.source.size() / 2);  // candidates only for sampled points
  // Both find the motion (a few samples' noise is left for ICP).
  for (const SacIaResult* r : {&fast, &full}) EXPECT_LT(rms_offset(e.source, r->T_target_source, e.T_target_source), 0.01);
  // The full run scored at least as well (it saw every hypothesis the fast one saw, and more).
  EXPECT_LE(full.score, fast.score);
}

// The similarity-weighted draw (default) against the paper's uniform draw (Liu et al. 2022, sec. 1.2) among the k candidates.
// With exact twins the closest candidate is always right: the weighted draw finds an all-correct
// sample at once. With noisy signatures the closest one is often wrong: both still find the
// motion. The winner's inlier statistics (gathered while scoring) equal a recount.
TEST(SacIaTest, SimilarityWeightedDrawFindsTheMotionSooner) {
  PLUMB_REQUIRE_DATA(p4, "cloud3d/pcl_test/bun4.pcd");
  const EasyCase e = easy_case();
  const KdTree3f tree(e.target);
  Rng noise(7);
  std::vector<FpfhSignature> noisy = e.features;
  for (FpfhSignature& f : noisy)
    for (float& v : f) v = std::max(0.0f, v * static_cast<float>(1.0 + 0.3 * noise.normal()));
  for (bool exact : {true, false}) {
    const std::vector<FpfhSignature>& target_features = exact ? e.features : noisy;
    SacIaSettings s = bunny_settings();
    s.max_iterations = 5000;
    s.similarity_weighted = false;
    const SacIaResult uniform = align_sac_ia(e.source, e.features, e.target, target_features, tree, s);
    s.similarity_weighted = true;
    const SacIaResult weighted = align_sac_ia(e.source, e.features, e.target, target_features, tree, s);
    for (const SacIaResult* r : {&uniform, &weighted}) {
      EXPECT_EQ(r->status, Status::kOk) << exact;
      EXPECT_LT(rms_offset(e.source, r->T_target_source, e.T_target_source), 0.01) << exact;
      // Inliers and rmse recounted from scratch at the returned pose.
      std::size_t inliers = 0;
      double sum_sq = 0.0;
      const float m1_sq = static_cast<float>(s.huber_threshold * s.huber_threshold);
      for (const Vector3f& p : e.source.points) {
        const auto nn = tree.nearest((r->T_target_source * p.cast<double>()).cast<float>(), m1_sq);
        if (nn && nn->dist_sq < m1_sq) {
          ++inliers;
          sum_sq += nn->dist_sq;
        }
      }
      EXPECT_NEAR(static_cast<double>(r->num_inliers), static_cast<double>(inliers), 0.001 * inliers + 1) << exact;
      EXPECT_NEAR(r->rmse, std::sqrt(sum_sq / static_cast<double>(inliers)), 1e-4) << exact;
    }
    if (exact) {
      EXPECT_LE(weighted.iterations, 3);
      EXPECT_GT(uniform.iterations, 10 * weighted.iterations);
    } else {
      EXPECT_LT(weighted.iterations, uniform.iterations);
    }
  }
}

TEST(SacIaTest, PrescoringAndMutualFilterKeepResultAndDeterminism) {
  PLUMB_REQUIRE_DATA(p4, "cloud3d/pcl_test/bun4.pcd");
  const EasyCase e = easy_case();
  const KdTree3f tree(e.target);
  for (bool mutual : {false, true}) {
    for (std::size_t pre : {std::size_t{0}, std::size_t{50}}) {
      SacIaSettings s = bunny_settings();
      s.mutual_filter = mutual;
      s.num_prescore_points = pre;
      const SacIaResult a = align_sac_ia(e.source, e.features, e.target, e.features, tree, s);
      const SacIaResult b = align_sac_ia(e.source, e.features, e.target, e.features, tree, s);
      EXPECT_EQ(a.T_target_source.matrix(), b.T_target_source.matrix()) << mutual << " " << pre;
      EXPECT_EQ(a.iterations, b.iterations);
      EXPECT_EQ(a.num_fully_scored, b.num_fully_scored);
      if (pre == 0) {
        EXPECT_EQ(a.num_fully_scored, a.num_scored);
      } else {
        EXPECT_LE(a.num_fully_scored, a.num_scored);
      }
      EXPECT_LT(rms_offset(e.source, a.T_target_source, e.T_target_source), 0.01) << mutual << " " << pre;
      EXPECT_GT(a.overlap, 0.9);
    }
  }
}

TEST(LocalizeTest, BadInputGivesStatusNotCrash) {
  PLUMB_REQUIRE_DATA(p4, "cloud3d/pcl_test/bun4.pcd");
  const PointCloud target = io::read_cloud(p4);
  const LocalizeSettings s = localize_settings_for_voxel(0.005);
  const LocalizeTarget prepared = prepare_localize_target(target, s);
  PointCloud empty;
  EXPECT_EQ(localize_coarse_to_fine(empty, prepared, s).status, Status::kInsufficientData);
  PointCloud two;
  two.points = {Vector3f(0, 0, 0), Vector3f(0.1f, 0, 0)};
  EXPECT_EQ(localize_coarse_to_fine(two, prepared, s).status, Status::kInsufficientData);
  PointCloud line;
  for (int i = 0; i < 100; ++i) line.points.emplace_back(0.002f * i, 0.0f, 0.0f);
  const LocalizeResult rl = localize_coarse_to_fine(line, prepared, s);
  EXPECT_NE(rl.status, Status::kOk);
  EXPECT_TRUE(rl.T_target_source.matrix().allFinite());
  PointCloud nan_cloud;
  nan_cloud.points.assign(50, Vector3f::Constant(std::nanf("")));
  EXPECT_EQ(localize_coarse_to_fine(nan_cloud, prepared, s).status, Status::kInsufficientData);
  EXPECT_EQ(localize_coarse_to_fine(target, empty, s).status, Status::kInsufficientData);
  LocalizeSettings bad = s;
  bad.voxel_size = 0.0;
  EXPECT_THROW(localize_coarse_to_fine(target, prepared, bad), Error);
  EXPECT_THROW(localize_settings_for_voxel(-1.0), Error);
  PointCloud inconsistent = target;
  inconsistent.normals.resize(3);
  EXPECT_THROW(localize_coarse_to_fine(inconsistent, prepared, s), Error);
}

}  // namespace
}  // namespace plumb
