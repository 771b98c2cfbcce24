// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief One call per LiDAR frame: ground, vertical-plane key points and "decoration"
///        (Liu et al. 2022, sec. 2.2): segment_frame().

#include <cstddef>
#include <cstdint>
#include <vector>

#include "plumb/core/point_cloud.hpp"
#include "plumb/core/status.hpp"
#include "plumb/segmentation/frame_sample.hpp"
#include "plumb/segmentation/ground.hpp"
#include "plumb/segmentation/vertical_planes.hpp"

namespace plumb {

/// @brief Label of a point that is neither ground nor on a vertical plane ("decoration",
///        Liu et al. 2022, sec. 2.2).
constexpr std::int32_t kSegmentOther = 0;
/// @brief Label of a ground point.
constexpr std::int32_t kSegmentGround = 1;
/// @brief Label of a point on a vertical plane (a key point for the BIM correction).
constexpr std::int32_t kSegmentVertical = 2;

/// @brief Settings of segment_frame().
struct SegmentSettings {
  FrameSampleSettings sample;      ///< voxel sample + normals shared by both steps
  GroundSettings ground;           ///< ground step (its `sample` member is not used here)
  VerticalPlaneSettings vertical;  ///< vertical-plane step
};

/// @brief Wall time of each step of segment_frame() [s].
struct SegmentTimings {
  double sample = 0.0;    ///< voxel grid + kd-tree + normals
  double ground = 0.0;    ///< pre-segmentation + RANSAC + full-resolution ground points
  double vertical = 0.0;  ///< pre-segmentation + repeated RANSAC + full-resolution labelling
  double total = 0.0;     ///< the whole call
};

/// @brief Result of segment_frame().
struct SegmentResult {
  /// One label per input point, in input order: kSegmentOther, kSegmentGround or kSegmentVertical
  /// (non-finite points are kSegmentOther).
  std::vector<std::int32_t> labels;
  /// kOk when a ground plane was found; otherwise the ground step's status (kInsufficientData for
  /// an empty, all-NaN or tiny frame or no ground candidates, kDegenerate). Vertical planes may
  /// still be present when the ground is missing.
  Status status = Status::kInsufficientData;
  GroundResult ground;                ///< ground plane and its input indices
  VerticalPlanesResult vertical;      ///< vertical planes and the plane of every input point
  std::size_t num_ground = 0;         ///< points labelled kSegmentGround
  std::size_t num_vertical = 0;       ///< points labelled kSegmentVertical
  std::size_t num_other = 0;          ///< points labelled kSegmentOther (non-finite included)
  std::size_t num_sample = 0;         ///< points of the voxel sample
  SegmentTimings timings;             ///< [s]
};

/// @brief Segment one frame (sensor frame: origin at the sensor, z up) into ground, vertical
///        planes and the rest: sample_frame(), extract_ground(), extract_vertical_planes().
/// @param cloud the frame; any size, non-finite points allowed
/// @return labels and planes; never throws for data (empty / NaN / planeless frames give a status)
/// @throws plumb::Error only for invalid settings or a cloud with inconsistent fields
/// @note Deterministic for given settings (seeds inside). One thread. Cost is dominated by the
///       normals of the sample: O(m k log m) for m sample points, plus O(n) per plane for the n
///       input points.
SegmentResult segment_frame(const PointCloud& cloud, const SegmentSettings& settings = {});

}  // namespace plumb
