// SPDX-License-Identifier: BSD-3-Clause
// LocalizeSettings: the fine stage's ICP defaults, and localize_settings_for_voxel's scaling.
#include "plumb/registration/localize.hpp"

#include <gtest/gtest.h>

#include "plumb/core/error.hpp"

namespace {

TEST(LocalizeSettingsTest, FineStageIcpIsPointToPlaneWithAPartialOverlapGate) {
  const plumb::LocalizeSettings settings;
  const plumb::IcpSettings& icp = settings.icp;
  EXPECT_EQ(icp.method, plumb::IcpMethod::kPointToPlane);
  EXPECT_EQ(icp.max_correspondence_distance, 0.6);
  EXPECT_EQ(icp.distance_step, 0.1);
  EXPECT_EQ(icp.min_correspondence_distance, 0.1);
  EXPECT_EQ(icp.min_overlap, 0.5);
  EXPECT_EQ(icp.overlap_distance, 0.1);
  EXPECT_EQ(icp.max_iterations, 30);
  EXPECT_EQ(icp.kernel, plumb::RobustKernel::kHuber);
  EXPECT_EQ(icp.kernel_scale, 0.1);
  EXPECT_EQ(icp.max_rounds, plumb::IcpSettings{}.max_rounds);
}

TEST(LocalizeSettingsTest, ForVoxelScalesTheLengthsAndKeepsTheRest) {
  const plumb::LocalizeSettings s = plumb::localize_settings_for_voxel(0.6);
  EXPECT_EQ(s.voxel_size, 0.6);
  EXPECT_DOUBLE_EQ(s.fine_voxel_size, 0.2);
  EXPECT_DOUBLE_EQ(s.sac_ia.min_sample_distance, 0.6 * 10.0 / 3.0);
  EXPECT_EQ(s.icp.max_correspondence_distance, 1.2);
  EXPECT_DOUBLE_EQ(s.icp.distance_step, 0.2);
  EXPECT_DOUBLE_EQ(s.icp.min_correspondence_distance, 0.2);
  EXPECT_DOUBLE_EQ(s.icp.overlap_distance, 0.2);
  EXPECT_DOUBLE_EQ(s.icp.kernel_scale, 0.2);
  EXPECT_EQ(s.icp.max_iterations, 30);
  EXPECT_EQ(s.icp.method, plumb::IcpMethod::kPointToPlane);
  EXPECT_THROW(plumb::localize_settings_for_voxel(0.0), plumb::Error);
  EXPECT_THROW(plumb::localize_settings_for_voxel(-1.0), plumb::Error);
}

}  // namespace
