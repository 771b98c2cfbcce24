// SPDX-License-Identifier: BSD-3-Clause
// The pipelines' settings: a value-initialised XxxSettings{} carries the defaults of its nested
// settings, field by field.
#include <cmath>

#include <gtest/gtest.h>

#include "plumb/pipeline/bim_localizer.hpp"
#include "plumb/pipeline/bim_odometry.hpp"
#include "plumb/pipeline/hybrid_lio.hpp"

namespace {

TEST(PipelineSettingsDefaultsTest, BimOdometryRegistersKeyPointsPointToPlaneFromAClosePose) {
  const plumb::BimOdometrySettings settings;
  const plumb::IcpSettings& icp = settings.icp;
  EXPECT_EQ(icp.method, plumb::IcpMethod::kPointToPlane);
  EXPECT_EQ(icp.max_correspondence_distance, 0.2);
  EXPECT_EQ(icp.distance_step, 0.05);
  EXPECT_EQ(icp.min_correspondence_distance, 0.1);
  EXPECT_EQ(icp.max_rounds, 4);
  EXPECT_EQ(icp.max_iterations, 15);
  EXPECT_EQ(icp.min_overlap, 0.5);
  EXPECT_EQ(icp.overlap_distance, 0.1);
  EXPECT_EQ(icp.kernel, plumb::RobustKernel::kHuber);
  EXPECT_EQ(icp.kernel_scale, 0.05);
  // The fields the BIM registration leaves alone keep IcpSettings' defaults.
  EXPECT_EQ(icp.tolerance, plumb::IcpSettings{}.tolerance);
}

TEST(PipelineSettingsDefaultsTest, BimOdometryFrontEndAndInitialCovariance) {
  const plumb::BimOdometrySettings s;
  EXPECT_EQ(s.front_end.local_map_size, 5u);
  EXPECT_EQ(s.front_end.keyframe_distance, plumb::ScanOdometrySettings{}.keyframe_distance);
  // 2 cm and 0.5 degrees standard deviation, independent.
  const double t = 0.02, r = 0.5 * 3.14159265358979323846 / 180.0;
  plumb::Vector6d d;
  d << t * t, t * t, t * t, r * r, r * r, r * r;
  EXPECT_EQ(s.initial_covariance, plumb::Matrix6d(d.asDiagonal()));
}

TEST(PipelineSettingsDefaultsTest, BimLocalizerGridAndFineStage) {
  const plumb::BimLocalizerSettings s;
  EXPECT_EQ(s.map.resolution, 0.1);
  EXPECT_EQ(s.map.sigma, 0.1);
  EXPECT_EQ(s.map.levels, 7);
  EXPECT_EQ(s.map.margin, plumb::CorrelativeMapSettings{}.margin);
  // The fine stage is localize_settings_for_voxel(0.15) with up to 50 ICP iterations per round.
  const plumb::LocalizeSettings v = plumb::localize_settings_for_voxel(0.15);
  EXPECT_EQ(s.fine.voxel_size, 0.15);
  EXPECT_EQ(s.fine.fine_voxel_size, v.fine_voxel_size);
  EXPECT_EQ(s.fine.sac_ia.min_sample_distance, v.sac_ia.min_sample_distance);
  EXPECT_EQ(s.fine.icp.max_correspondence_distance, 0.3);
  EXPECT_EQ(s.fine.icp.distance_step, v.icp.distance_step);
  EXPECT_EQ(s.fine.icp.min_correspondence_distance, v.icp.min_correspondence_distance);
  EXPECT_EQ(s.fine.icp.overlap_distance, v.icp.overlap_distance);
  EXPECT_EQ(s.fine.icp.kernel_scale, v.icp.kernel_scale);
  EXPECT_EQ(s.fine.icp.method, plumb::IcpMethod::kPointToPlane);
  EXPECT_EQ(s.fine.icp.max_iterations, 50);
  EXPECT_EQ(v.icp.max_iterations, 30);
}

TEST(PipelineSettingsDefaultsTest, HybridLioLocalMaps) {
  const plumb::LioMapSettings s;
  EXPECT_EQ(s.edge_map.voxel_size, 0.3);
  EXPECT_EQ(s.edge_map.max_points_per_voxel, 1);
  EXPECT_EQ(s.edge_map.max_distance, 60.0);
  EXPECT_EQ(s.edge_map.max_voxels, 100000u);
  EXPECT_EQ(s.plane_map.voxel_size, 0.4);
  EXPECT_EQ(s.plane_map.max_points_per_voxel, 1);
  EXPECT_EQ(s.plane_map.max_distance, 60.0);
  EXPECT_EQ(s.plane_map.max_voxels, 100000u);
  EXPECT_EQ(s.point_map.voxel_size, 0.4);
  EXPECT_EQ(s.point_map.max_points_per_voxel, 4);
  EXPECT_EQ(s.point_map.max_distance, 60.0);
  EXPECT_EQ(s.point_map.max_voxels, 150000u);
  // No age limit, as VoxelHashMapSettings.
  EXPECT_EQ(s.edge_map.max_age, 0u);
  EXPECT_EQ(s.plane_map.max_age, 0u);
  EXPECT_EQ(s.point_map.max_age, 0u);
}

}  // namespace
