// SPDX-License-Identifier: BSD-3-Clause
// SAC-IA, ICP and the coarse-to-fine localisation on real clouds (shared/data, see SOURCES.md).

#include <cmath>
#include <cstdio>
#include <fstream>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "plumb/core/error.hpp"
#include "plumb/core/rng.hpp"
#include "plumb/features/fpfh.hpp"
#include "plumb/features/normals.hpp"
#include "plumb/filters/voxel_grid.hpp"
#include "plumb/io/cloud_io.hpp"
#include "plumb/registration/icp.hpp"
#include "plumb/registration/localize.hpp"
#include "plumb/registration/sac_ia.hpp"
#include "test_data.hpp"

namespace plumb {
namespace {

// Sanitizer builds run ~20-100x slower: the random-start test runs fewer starts there.
#if defined(__SANITIZE_ADDRESS__)
constexpr int kNumStarts = 3;
#else
constexpr int kNumStarts = 20;
#endif

constexpr double kDeg = M_PI / 180.0;

/// (translation error [m], rotation error [rad]) of a against b.
std::pair<double, double> pose_error_of(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  const Eigen::Isometry3d d = b.inverse() * a;
  return {d.translation().norm(), Eigen::AngleAxisd(d.linear()).angle()};
}

Eigen::Isometry3d make_pose(double yaw, const Vector3d& t, double roll = 0.0, double pitch = 0.0) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = (Eigen::AngleAxisd(yaw, Vector3d::UnitZ()) * Eigen::AngleAxisd(pitch, Vector3d::UnitY()) *
                Eigen::AngleAxisd(roll, Vector3d::UnitX()))
                   .toRotationMatrix();
  T.translation() = t;
  return T;
}

/// PCL's getFitnessScore: mean squared nearest distance of the transformed source points [m^2].
double fitness(const PointCloud& source, const PointCloud& target, const Eigen::Isometry3d& T) {
  const KdTree3f tree(target);
  double sum = 0.0;
  for (const Vector3f& p : source.points) sum += tree.nearest((T * p.cast<double>()).cast<float>())->dist_sq;
  return sum / static_cast<double>(source.size());
}

PointCloud voxel(const PointCloud& c, double leaf) {
  VoxelGridSettings vs;
  vs.leaf_size = leaf;
  return voxel_grid(c, vs).cloud;
}

// PCL's test_sac_ia: bun0 moved by 90 deg yaw and 100 m, FPFH radius 0.05, min sample distance
// 0.05, max correspondence distance 0.1, 1000 iterations, fitness score < 5e-4.
TEST(SacIaRealTest, BunnyAsStrictAsPcl) {
  PLUMB_REQUIRE_DATA(src_path, "cloud3d/pcl_test/bun0.pcd");
  PLUMB_REQUIRE_DATA(tgt_path, "cloud3d/pcl_test/bun4.pcd");
  PointCloud source = io::read_cloud(src_path);
  PointCloud target = io::read_cloud(tgt_path);
  NormalSettings ns;
  ns.k = 30;
  ns.radius = 0.02f;
  compute_normals(source, ns);  // in the scans' common frame, oriented to the same viewpoint
  compute_normals(target, ns);
  const Eigen::Isometry3d T_moved_source = make_pose(M_PI / 2, Vector3d(100, 0, 0));
  const PointCloud moved = transformed(source, T_moved_source);
  FpfhSettings fs;
  fs.radius = 0.05f;
  const auto fsrc = compute_fpfh(moved, fs).features;
  const auto ftgt = compute_fpfh(target, fs).features;
  SacIaSettings s;
  s.min_sample_distance = 0.05;
  s.max_correspondence_distance = 0.1;
  s.huber_threshold = 0.01;
  s.max_iterations = 1000;
  s.confidence = 1.0;  // like PCL: all 1000 iterations
  const KdTree3f tree(target);
  const SacIaResult r = align_sac_ia(moved, fsrc, target, ftgt, tree, s);
  ASSERT_NE(r.status, Status::kInsufficientData);
  const double fit = fitness(moved, target, r.T_target_source);
  EXPECT_LT(fit, 5e-4);
  // ICP from there tightens it further.
  IcpSettings is;
  is.max_correspondence_distance = 0.05;
  is.min_correspondence_distance = 0.01;
  is.distance_step = 0.01;
  is.overlap_distance = 0.005;
  is.min_overlap = 0.5;
  const IcpResult icp = align_icp(moved, target, tree, r.T_target_source, is);
  const double fit_icp = fitness(moved, target, icp.T_target_source);
  EXPECT_LE(fit_icp, fit);
  EXPECT_LT(fit_icp, 1e-4);
}

struct RoomScans {
  PointCloud scan1, scan2;
  Eigen::Isometry3d T_ref;  // T_scan1_scan2
};

// Reference alignment of room_scan2 into room_scan1: fine ICP from the NDT tutorial's guess,
// point-to-plane with decreasing distances; checked against point-to-point from the same guess.
const RoomScans& room_scans() {
  static const RoomScans scans = [] {
    RoomScans r;
    r.scan1 = io::read_cloud(test::data_path("cloud3d/pcl_room_scans/room_scan1.pcd"));
    r.scan2 = io::read_cloud(test::data_path("cloud3d/pcl_room_scans/room_scan2.pcd"));
    return r;
  }();
  return scans;
}

TEST(LocalizeRealTest, RoomScansFromRandomStarts) {
  PLUMB_REQUIRE_DATA(p1, "cloud3d/pcl_room_scans/room_scan1.pcd");
  PLUMB_REQUIRE_DATA(p2, "cloud3d/pcl_room_scans/room_scan2.pcd");
  const RoomScans& rs = room_scans();
  PointCloud target = voxel(rs.scan1, 0.05);
  PointCloud source = voxel(rs.scan2, 0.05);
  NormalSettings ns;
  ns.k = 20;
  ns.radius = 0.15f;
  compute_normals(target, ns);
  const Eigen::Isometry3d guess = make_pose(0.6931, Vector3d(1.79387, 0.720047, 0));
  IcpSettings is;
  is.method = IcpMethod::kPointToPlane;
  is.max_correspondence_distance = 0.5;
  is.distance_step = 0.1;
  is.min_correspondence_distance = 0.1;
  is.min_overlap = 0.6;
  is.overlap_distance = 0.05;
  is.max_iterations = 100;
  IcpResult ref = align_icp(source, target, guess, is);
  // Finish at a short distance so that only true surface pairs remain.
  is.max_correspondence_distance = 0.1;
  is.min_overlap = 0.0;
  ref = align_icp(source, target, ref.T_target_source, is);
  is.method = IcpMethod::kPointToPoint;
  is.max_correspondence_distance = 0.5;
  is.max_iterations = 200;
  IcpResult ref_p2p = align_icp(source, target, guess, is);
  is.max_correspondence_distance = 0.1;
  ref_p2p = align_icp(source, target, ref_p2p.T_target_source, is);
  const auto agree = pose_error_of(ref.T_target_source, ref_p2p.T_target_source);
  ASSERT_LT(agree.first, 0.02);
  ASSERT_LT(agree.second, 0.2 * kDeg);
  const Eigen::Isometry3d T_ref = ref.T_target_source;

  LocalizeSettings ls;
  const LocalizeTarget prepared = prepare_localize_target(rs.scan1, ls);
  Rng rng(2024);
  int failures = 0;
  for (int k = 0; k < kNumStarts; ++k) {
    const Eigen::Isometry3d T_rand =
        make_pose(rng.uniform(-M_PI, M_PI), Vector3d(rng.uniform(-10, 10), rng.uniform(-10, 10), rng.uniform(-10, 10)),
                  rng.uniform(-3, 3) * kDeg, rng.uniform(-3, 3) * kDeg);
    const PointCloud moved = transformed(rs.scan2, T_rand);
    LocalizeSettings lk = ls;
    lk.source_viewpoint = T_rand.translation().cast<float>();
    lk.sac_ia.seed = 100 + static_cast<std::uint64_t>(k);
    const LocalizeResult r = localize_coarse_to_fine(moved, prepared, lk);
    const Eigen::Isometry3d expected = T_ref * T_rand.inverse();
    const auto e = pose_error_of(r.T_target_source, expected);
    EXPECT_LT(e.first, 0.05) << "start " << k;
    EXPECT_LT(e.second, 0.5 * kDeg) << "start " << k;
    EXPECT_EQ(r.status, Status::kOk) << "start " << k;
    failures += e.first < 0.05 && e.second < 0.5 * kDeg ? 0 : 1;
  }
  EXPECT_EQ(failures, 0);
}

// fast_gicp's pair: align 251371071 (source) to 251370668 (target); relative.txt is T_target_source.
TEST(IcpRealTest, Hdl32PairMatchesReference) {
  PLUMB_REQUIRE_DATA(tp, "cloud3d/hdl32_pair/251370668.pcd");
  PLUMB_REQUIRE_DATA(sp, "cloud3d/hdl32_pair/251371071.pcd");
  PLUMB_REQUIRE_DATA(rp, "cloud3d/hdl32_pair/relative.txt");
  Eigen::Matrix4d M;
  std::ifstream in(rp);
  for (int i = 0; i < 16; ++i) in >> M(i / 4, i % 4);
  ASSERT_TRUE(in.good() || in.eof());
  const Eigen::Isometry3d T_ref(M);
  // Full resolution: voxelised copies of these 32-ring scans leave a ~0.35 deg bias.
  PointCloud target = io::read_cloud(tp);
  const PointCloud source = io::read_cloud(sp);
  NormalSettings ns;
  ns.k = 20;
  ns.radius = 0.5f;
  compute_normals(target, ns);
  const KdTree3f tree(target);
  IcpSettings is;
  is.method = IcpMethod::kPointToPlane;
  is.max_correspondence_distance = 1.0;
  is.distance_step = 0.3;
  is.min_correspondence_distance = 0.1;
  is.min_overlap = 0.8;
  is.overlap_distance = 0.2;
  is.kernel = RobustKernel::kHuber;
  is.kernel_scale = 0.1;
  const IcpResult gated = align_icp(source, target, tree, Eigen::Isometry3d::Identity(), is);
  EXPECT_EQ(gated.status, Status::kOk);
  is.max_correspondence_distance = 0.1;
  is.min_overlap = 0.0;
  const IcpResult r = align_icp(source, target, tree, gated.T_target_source, is);
  const auto e = pose_error_of(r.T_target_source, T_ref);
  EXPECT_LT(e.first, 0.05);
  EXPECT_LT(e.second, 0.3 * kDeg);
  EXPECT_GT(gated.degeneracy, 0.0);
}

}  // namespace
}  // namespace plumb
