// SPDX-License-Identifier: BSD-3-Clause
// SAC-IA's rough-position hint (region) and excluded poses, on a target holding the same object
// twice: both copies explain the source exactly, and only the hint or the exclusion tells which.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <utility>
#include <limits>
#include <vector>

#include "plumb/core/error.hpp"
#include "plumb/features/fpfh.hpp"
#include "plumb/features/normals.hpp"
#include "plumb/io/cloud_io.hpp"
#include "plumb/registration/localize.hpp"
#include "plumb/registration/sac_ia.hpp"
#include "test_data.hpp"

namespace plumb {
namespace {

struct TwinCase {
  PointCloud source, target;
  std::vector<FpfhSignature> fs, ft;
  Eigen::Isometry3d T_first, T_second;  ///< source onto the first / second copy
};

TwinCase twin_case() {
  const PointCloud bunny = io::read_cloud(test::data_path("cloud3d/pcl_test/bun4.pcd"));
  TwinCase c;
  Eigen::Isometry3d shift = Eigen::Isometry3d::Identity();
  shift.translation() = Vector3d(1.0, 0.0, 0.0);  // far beyond the 5 cm FPFH radius: identical signatures
  c.target = bunny;
  for (const Vector3f& p : bunny.points) c.target.points.push_back((shift * p.cast<double>()).cast<float>());
  Eigen::Isometry3d T_source_first = Eigen::Isometry3d::Identity();
  T_source_first.linear() = Eigen::AngleAxisd(1.2, Vector3d(0.1, 0.2, 1.0).normalized()).toRotationMatrix();
  T_source_first.translation() = Vector3d(0.4, -0.3, 0.1);
  c.source = bunny;
  for (Vector3f& p : c.source.points) p = (T_source_first * p.cast<double>()).cast<float>();
  c.T_first = T_source_first.inverse();
  c.T_second = shift * c.T_first;
  NormalSettings ns;
  ns.k = 30;
  ns.radius = 0.02f;
  compute_normals(c.source, ns);
  compute_normals(c.target, ns);
  FpfhSettings f;
  f.radius = 0.05f;
  c.fs = compute_fpfh(c.source, f).features;
  c.ft = compute_fpfh(c.target, f).features;
  return c;
}

SacIaSettings twin_settings() {
  SacIaSettings s;
  s.min_sample_distance = 0.05;
  s.max_correspondence_distance = 0.1;
  s.huber_threshold = 0.01;
  s.max_iterations = 3000;
  s.k_correspondences = 10;  // each source point's twins in both copies are candidates
  return s;
}

double pose_distance(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return (a.translation() - b.translation()).norm();
}

TEST(SacIaRegionTest, HintOrExclusionPicksTheCopy) {
  const TwinCase c = twin_case();
  const KdTree3f tree(c.target);
  for (int copy = 0; copy < 2; ++copy) {
    const Eigen::Isometry3d& want = copy == 0 ? c.T_first : c.T_second;
    const Eigen::Isometry3d& other = copy == 0 ? c.T_second : c.T_first;
    SacIaSettings s = twin_settings();
    s.region_center = want.translation() + Vector3d(0.1, 0.05, 0.0);
    s.region_radius = 0.4;
    const SacIaResult hinted = align_sac_ia(c.source, c.fs, c.target, c.ft, tree, s);
    ASSERT_NE(hinted.status, Status::kInsufficientData) << "copy " << copy;
    // A coarse alignment (centimetres off), on the wanted copy and not the other one 1 m away.
    EXPECT_LT(pose_distance(hinted.T_target_source, want), 0.1) << "copy " << copy;
    EXPECT_GT(pose_distance(hinted.T_target_source, other), 0.9) << "copy " << copy;
    SacIaSettings e = twin_settings();
    e.excluded = {other};
    e.exclude_distance = 0.3;
    const SacIaResult excluded = align_sac_ia(c.source, c.fs, c.target, c.ft, tree, e);
    ASSERT_NE(excluded.status, Status::kInsufficientData) << "copy " << copy;
    EXPECT_LT(pose_distance(excluded.T_target_source, want), 0.1) << "copy " << copy;
    EXPECT_GT(pose_distance(excluded.T_target_source, other), 0.9) << "copy " << copy;
  }
}

TEST(SacIaRegionTest, BadHintSettingsThrow) {
  const TwinCase c = twin_case();
  const KdTree3f tree(c.target);
  SacIaSettings s = twin_settings();
  s.region_radius = -1.0;
  EXPECT_THROW(align_sac_ia(c.source, c.fs, c.target, c.ft, tree, s), Error);
  s = twin_settings();
  s.region_center.x() = std::numeric_limits<double>::quiet_NaN();
  s.region_radius = 1.0;
  EXPECT_THROW(align_sac_ia(c.source, c.fs, c.target, c.ft, tree, s), Error);
  s = twin_settings();
  s.exclude_distance = std::numeric_limits<double>::infinity();
  EXPECT_THROW(align_sac_ia(c.source, c.fs, c.target, c.ft, tree, s), Error);
}

TEST(LocalizeAmbiguityTest, TwoCopiesAreAmbiguousUnlessHinted) {
  const TwinCase c = twin_case();
  LocalizeSettings s = localize_settings_for_voxel(0.005);
  s.ambiguity_margin = 0.1;
  s.ambiguity_distance = 0.3;
  PointCloud source = c.source, target = c.target;
  source.normals.clear();
  target.normals.clear();
  const LocalizeResult both = localize_coarse_to_fine(source, target, s);
  EXPECT_TRUE(both.ambiguous);
  EXPECT_EQ(both.status, Status::kRejected);
  EXPECT_GT(both.second_overlap, 0.9 * both.overlap);
  // The hint leaves one copy: the same search is then unambiguous and lands on it.
  s.sac_ia.region_center = c.T_second.translation();
  s.sac_ia.region_radius = 0.3;
  const LocalizeResult hinted = localize_coarse_to_fine(source, target, s);
  EXPECT_FALSE(hinted.ambiguous);
  EXPECT_EQ(hinted.status, Status::kOk);
  EXPECT_LT(pose_distance(hinted.T_target_source, c.T_second), 0.01);
  // Bad ambiguity settings are an error, not a silent test.
  LocalizeSettings bad = s;
  bad.ambiguity_margin = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(localize_coarse_to_fine(source, target, bad), Error);
  bad = s;
  bad.ambiguity_distance = -1.0;
  EXPECT_THROW(localize_coarse_to_fine(source, target, bad), Error);
}

TEST(LocalizeTargetTest, SplitByNormalKeepsBothFacesOfAThinWall) {
  // A 4 cm thick wall sampled on both faces, voxel 0.1 m: one voxel holds points of both faces.
  PointCloud wall;
  for (int i = 0; i < 40; ++i) {
    for (int k = 0; k < 40; ++k) {
      for (float y : {0.0f, 0.04f}) {
        wall.points.emplace_back(0.025f * i, y, 0.025f * k);
        wall.normals.emplace_back(0.0f, y > 0.0f ? 1.0f : -1.0f, 0.0f);
      }
    }
  }
  auto faces = [](const PointCloud& c) {
    std::size_t plus = 0, minus = 0;
    for (const Vector3f& n : c.normals) (n.y() > 0 ? plus : minus) += 1;
    return std::make_pair(plus, minus);
  };
  LocalizeSettings s;
  s.voxel_size = 0.1;
  s.fine_voxel_size = 0.05;
  s.split_target_by_normal = true;
  const LocalizeTarget split = prepare_localize_target(wall, s);
  const auto [plus, minus] = faces(split.coarse);
  EXPECT_EQ(plus, minus);        // every voxel of the wall once per face
  EXPECT_EQ(plus, 10u * 10u);    // 1 m x 1 m at 0.1 m
  s.split_target_by_normal = false;
  const LocalizeTarget merged = prepare_localize_target(wall, s);
  EXPECT_EQ(merged.coarse.size(), 100u);  // one point per voxel, whichever face it came from
}

}  // namespace
}  // namespace plumb
