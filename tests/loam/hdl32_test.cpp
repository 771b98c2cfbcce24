// SPDX-License-Identifier: BSD-3-Clause
// LOAM front end on a real HDL-32E pair (shared/data/cloud3d/hdl32_pair, from koide3/fast_gicp):
// the range image finds the sensor's 32 rings without a ring field, the per-sector feature counts
// are printed, and scan-to-scan matches fast_gicp's reference relative pose (relative.txt, the
// transform mapping the second scan 251371071 into the first 251370668: T_prev_cur) to 5 cm / 0.3 deg.
#include <cmath>
#include <fstream>

#include <gtest/gtest.h>

#include "plumb/core/lie.hpp"
#include "plumb/io/pcd.hpp"
#include "plumb/loam/features.hpp"
#include "plumb/loam/odometry.hpp"
#include "plumb/loam/range_image.hpp"
#include "test_data.hpp"

namespace plumb {
namespace {


Eigen::Isometry3d read_relative(const std::string& path) {
  std::ifstream in(path);
  Eigen::Matrix4d M;
  for (int i = 0; i < 16; ++i) in >> M(i / 4, i % 4);
  EXPECT_TRUE(in.good() || in.eof()) << path;
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  // Re-orthonormalise the printed rotation (6 digits).
  T.linear() = Eigen::Quaterniond(M.topLeftCorner<3, 3>()).normalized().toRotationMatrix();
  T.translation() = M.topRightCorner<3, 1>();
  return T;
}

RangeImageSettings hdl32_image() {
  RangeImageSettings s;
  s.horizontal_resolution_deg = 0.16;  // ~2160 firings per turn at 10 Hz
  return s;
}

TEST(LoamHdl32Test, RangeImageFindsThe32Rings) {
  PLUMB_REQUIRE_DATA(path, "cloud3d/hdl32_pair/251370668.pcd");
  const PointCloud cloud = io::read_pcd(path);
  ASSERT_FALSE(cloud.has_rings());
  const RangeImage img = build_range_image(cloud, hdl32_image());
  ASSERT_EQ(img.status, Status::kOk);
  ASSERT_EQ(img.num_rows, 32);
  // HDL-32E: elevations -30.67 .. +10.67 deg in 4/3 deg steps (SOURCES.md).
  for (int r = 0; r < 32; ++r) {
    EXPECT_NEAR(img.row_elevation[static_cast<std::size_t>(r)] * 180.0 / kPi, -30.67 + r * 4.0 / 3.0, 0.05) << r;
  }
  // The data holds zero-range returns (dropped) and ~2160 firings per ring.
  EXPECT_GT(img.num_dropped, 0u);
  EXPECT_GT(img.num_pixels_filled, 55000u);
}

TEST(LoamHdl32Test, ScanToScanMatchesReferenceRelativePose) {
  PLUMB_REQUIRE_DATA(prev_path, "cloud3d/hdl32_pair/251370668.pcd");
  PLUMB_REQUIRE_DATA(cur_path, "cloud3d/hdl32_pair/251371071.pcd");
  PLUMB_REQUIRE_DATA(rel_path, "cloud3d/hdl32_pair/relative.txt");
  const PointCloud prev_cloud = io::read_pcd(prev_path);
  const PointCloud cur_cloud = io::read_pcd(cur_path);
  const Eigen::Isometry3d T_prev_cur_ref = read_relative(rel_path);

  const LoamFeatures prev = extract_loam_features(prev_cloud, hdl32_image(), LoamFeatureSettings{});
  const LoamFeatures cur = extract_loam_features(cur_cloud, hdl32_image(), LoamFeatureSettings{});
  ASSERT_EQ(prev.status, Status::kOk);
  ASSERT_EQ(cur.num_rings, 32);
  EXPECT_GE(cur.planes.size(), 48u);  // a structured scene: LOAM mode of the hybrid switch

  for (const Eigen::Isometry3d& guess : {Eigen::Isometry3d::Identity(), T_prev_cur_ref}) {
    const LoamResult r = loam_scan_to_scan(prev, cur, guess);
    const Eigen::Isometry3d E = T_prev_cur_ref.inverse() * r.T_prev_cur;
    const double t_err = E.translation().norm();
    const double r_err_deg = so3::log(E.linear()).norm() * 180.0 / kPi;
    EXPECT_EQ(r.status, Status::kOk);
    EXPECT_LT(t_err, 0.05);
    EXPECT_LT(r_err_deg, 0.3);
  }
}

}  // namespace
}  // namespace plumb
