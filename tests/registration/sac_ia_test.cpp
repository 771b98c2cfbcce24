// SPDX-License-Identifier: BSD-3-Clause
// Feature-space kNN, SAC-IA and localize_coarse_to_fine(): oracle, determinism and bad input.

#include <algorithm>
#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "plumb/core/error.hpp"
#include "plumb/core/rng.hpp"
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
  for (std::size_t a = 0; a < q.size(); ++a) {
    std::vector<std::pair<float, std::size_t>> all;
    for (std::size_t j : di) {
      float s = 0;
      for (int b = 0; b < kFpfhBins; ++b) s += (q[a][b] - d[j][b]) * (q[a][b] - d[j][b]);
      all.push_back({s, j});
    }
    std::sort(all.begin(), all.end());
    for (std::size_t m = 0; m < k; ++m) ASSERT_EQ(got[a * k + m], all[m].second) << a << " " << m;
  }
  EXPECT_EQ(got[0], 12u);  // tie at distance 0: smaller index first
  EXPECT_EQ(got[1], 13u);
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
    total += huber_penalty(std::min(std::sqrt(static_cast<double>(nn->dist_sq)), s.max_correspondence_distance),
                           s.huber_threshold);
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
