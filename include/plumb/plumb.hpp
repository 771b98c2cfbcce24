// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief Umbrella header: the whole public API of plumb (tests/core/umbrella_test.cpp checks that
/// every public header is listed here).

#include "plumb/version.hpp"

#include "plumb/core/as_built.hpp"
#include "plumb/core/clock.hpp"
#include "plumb/core/deskew.hpp"
#include "plumb/core/error.hpp"
#include "plumb/core/laser_scan.hpp"
#include "plumb/core/levenberg_marquardt.hpp"
#include "plumb/core/lie.hpp"
#include "plumb/core/point_cloud.hpp"
#include "plumb/core/pose2.hpp"
#include "plumb/core/rng.hpp"
#include "plumb/core/robust_kernel.hpp"
#include "plumb/core/sensor_data.hpp"
#include "plumb/core/status.hpp"
#include "plumb/core/trajectory.hpp"
#include "plumb/core/types.hpp"

#include "plumb/search/brute_force.hpp"
#include "plumb/search/kdtree.hpp"
#include "plumb/search/neighbors.hpp"

#include "plumb/filters/crop.hpp"
#include "plumb/filters/voxel_grid.hpp"

#include "plumb/features/fpfh.hpp"
#include "plumb/features/normals.hpp"

#include "plumb/registration/feature_index.hpp"
#include "plumb/registration/horn.hpp"
#include "plumb/registration/icp.hpp"
#include "plumb/registration/localize.hpp"
#include "plumb/registration/overlap.hpp"
#include "plumb/registration/sac_ia.hpp"

#include "plumb/segmentation/frame_sample.hpp"
#include "plumb/segmentation/ground.hpp"
#include "plumb/segmentation/plane_ransac.hpp"
#include "plumb/segmentation/presegment.hpp"
#include "plumb/segmentation/segment_frame.hpp"
#include "plumb/segmentation/vertical_planes.hpp"

#include "plumb/io/bcf.hpp"
#include "plumb/io/calib_tuples.hpp"
#include "plumb/io/carmen.hpp"
#include "plumb/io/cloud_io.hpp"
#include "plumb/io/frame_dump.hpp"
#include "plumb/io/input_file.hpp"
#include "plumb/io/kitti_bin.hpp"
#include "plumb/io/pcd.hpp"
#include "plumb/io/stamps.hpp"
#include "plumb/io/ply.hpp"
#include "plumb/io/ros_messages.hpp"
#include "plumb/io/rosbag.hpp"
#include "plumb/io/trajectory.hpp"
#include "plumb/io/svg.hpp"
#include "plumb/io/wheel_encoders.hpp"

#include "plumb/eval/align.hpp"
#include "plumb/eval/kitti_segments.hpp"
#include "plumb/eval/metrics.hpp"

#include "plumb/scan2d/cloud_to_scan.hpp"
#include "plumb/scan2d/correlative.hpp"
#include "plumb/scan2d/plicp.hpp"
#include "plumb/scan2d/scan_odometry.hpp"

#include "plumb/calibration/odometry_laser.hpp"
#include "plumb/calibration/tuple_extraction.hpp"

#include "plumb/loam/features.hpp"
#include "plumb/loam/ground.hpp"
#include "plumb/loam/local_map.hpp"
#include "plumb/loam/odometry.hpp"
#include "plumb/loam/range_image.hpp"
#include "plumb/loam/residuals.hpp"

#include "plumb/imu/imu.hpp"
#include "plumb/imu/preintegration.hpp"
#include "plumb/optim/imu_factor.hpp"
#include "plumb/optim/least_squares.hpp"

#include "plumb/bim/bim_cloud.hpp"
#include "plumb/bim/demo_building.hpp"
#include "plumb/bim/floor_plan.hpp"
#include "plumb/bim/ifc.hpp"
#include "plumb/bim/ifc_writer.hpp"
#include "plumb/bim/mesh.hpp"
#include "plumb/bim/polygon.hpp"
#include "plumb/bim/sample.hpp"
#include "plumb/bim/step.hpp"

#include "plumb/sim/imu_model.hpp"
#include "plumb/sim/lidar.hpp"
#include "plumb/sim/lidar_model_json.hpp"
#include "plumb/sim/raycaster.hpp"
#include "plumb/sim/robot.hpp"
#include "plumb/sim/route.hpp"
#include "plumb/sim/scenario.hpp"
#include "plumb/sim/wheel_model.hpp"
#include "plumb/sim/world.hpp"

#include "plumb/pipeline/as_built.hpp"
#include "plumb/pipeline/bim_localizer.hpp"
#include "plumb/pipeline/bim_odometry.hpp"
#include "plumb/pipeline/hybrid_lio.hpp"
#include "plumb/pipeline/pose_composer.hpp"

#include "plumb/app/deviation_files.hpp"
#include "plumb/app/lio_run.hpp"
#include "plumb/app/run.hpp"
#include "plumb/app/simulate.hpp"
