// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief The reduced copy of a frame on which plumb's segmentation estimates normals and runs
///        RANSAC: a voxel-grid sample with PCA normals (SEEDS A2.2 steps 1-2). Full-resolution
///        points are labelled afterwards by their distance to the planes found on the sample.

#include <chrono>
#include <cmath>
#include <cstddef>
#include <limits>
#include <vector>

#include "plumb/core/error.hpp"
#include "plumb/core/point_cloud.hpp"
#include "plumb/core/status.hpp"
#include "plumb/core/types.hpp"
#include "plumb/features/normals.hpp"
#include "plumb/filters/voxel_grid.hpp"
#include "plumb/search/kdtree.hpp"

namespace plumb {

/// @brief How a frame is reduced before normals are estimated.
struct FrameSampleSettings {
  /// Voxel edge of the sample [m], > 0. Each voxel keeps its real point nearest to the centroid
  /// (which also filters noise: one point per voxel, SEEDS A2.4 step 1). 0.3 m keeps walls and
  /// floors of a room dense enough for 8-neighbour normals while a 32-line frame shrinks ~14x
  /// (the normals of the sample are most of segment_frame()'s cost).
  double voxel_size = 0.3;
  std::size_t normal_k = 8;  ///< neighbours per normal (the point included), >= 3
  /// Neighbours farther than this are not used for a normal [m]; 0 = plain k nearest. Points with
  /// fewer than 3 neighbours inside get no normal (NaN) and are never plane candidates.
  float normal_radius = 1.0f;
  /// Normals are oriented toward this point [m]: the sensor, which is the origin of the frame.
  Vector3f viewpoint = Vector3f::Zero();
  /// Normals only for sample points with z <= this [m] (the others get NaN); +inf = all.
  /// extract_ground() on its own uses 0: the ground lies below the sensor, which halves the work.
  float normal_max_z = std::numeric_limits<float>::infinity();
};

/// @brief A frame's sample: points, normals and where each came from.
struct FrameSample {
  std::vector<Vector3f> points;        ///< sample points (real input points) [m]
  std::vector<Vector3f> normals;       ///< unit normals toward the viewpoint; NaN when not estimable
  std::vector<std::size_t> source;     ///< input-cloud index of each sample point
  std::size_t num_finite = 0;          ///< finite points of the input
  double voxel_size = 0.0;             ///< voxel edge the sample was made with [m]
  Status status = Status::kInsufficientData;  ///< kOk when the sample has >= 3 points
  double seconds = 0.0;                ///< wall time of sample_frame() [s]
};

/// @brief Voxel-grid sample of `cloud` with PCA normals (features/normals.hpp).
/// @param cloud a frame in the sensor frame (origin = sensor, z up); non-finite points skipped
/// @return the sample; kInsufficientData (and an empty sample) when fewer than 3 points are finite
/// @throws plumb::Error on invalid settings or a cloud whose optional fields are inconsistent
inline FrameSample sample_frame(const PointCloud& cloud, const FrameSampleSettings& settings = {}) {
  const auto t0 = std::chrono::steady_clock::now();
  PLUMB_CHECK(std::isfinite(settings.voxel_size) && settings.voxel_size > 0.0,
              "sample_frame: voxel_size = " << settings.voxel_size << " must be finite and > 0");
  PLUMB_CHECK(settings.normal_k >= 3, "sample_frame: normal_k = " << settings.normal_k << " must be >= 3");
  PLUMB_CHECK(!std::isnan(settings.normal_max_z), "sample_frame: normal_max_z is NaN");
  cloud.check_consistent("sample_frame");
  FrameSample out;
  out.voxel_size = settings.voxel_size;
  for (const Vector3f& p : cloud.points) out.num_finite += p.allFinite() ? 1 : 0;
  if (out.num_finite >= 3) {
    // Only the coordinates matter here: sample a points-only view of the cloud.
    PointCloud xyz;
    const PointCloud* source = &cloud;
    if (cloud.has_normals() || cloud.has_intensities() || cloud.has_rings() || cloud.has_times() ||
        cloud.has_labels()) {
      xyz.points = cloud.points;
      source = &xyz;
    }
    VoxelGridSettings vs;
    vs.leaf_size = settings.voxel_size;
    VoxelGridResult v = voxel_grid(*source, vs);
    out.points = std::move(v.cloud.points);
    out.source = std::move(v.indices);
    if (out.points.size() >= 3) {
      const KdTree<3> tree(out.points);
      NormalSettings ns;
      ns.k = settings.normal_k;
      ns.radius = settings.normal_radius;
      ns.viewpoint = settings.viewpoint;
      ns.orient_to_viewpoint = true;
      if (std::isinf(settings.normal_max_z) && settings.normal_max_z > 0.0f) {
        out.normals = estimate_normals(out.points, tree, out.points, ns).normals;
      } else {
        std::vector<Vector3f> queries;
        std::vector<std::size_t> where;
        for (std::size_t i = 0; i < out.points.size(); ++i) {
          if (out.points[i].z() <= settings.normal_max_z) {
            queries.push_back(out.points[i]);
            where.push_back(i);
          }
        }
        out.normals.assign(out.points.size(), Vector3f::Constant(std::numeric_limits<float>::quiet_NaN()));
        const NormalResult nr = estimate_normals(queries, tree, out.points, ns);
        for (std::size_t j = 0; j < where.size(); ++j) out.normals[where[j]] = nr.normals[j];
      }
      out.status = Status::kOk;
    } else {
      out.points.clear();
      out.source.clear();
    }
  }
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return out;
}

}  // namespace plumb
