// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief The reduced copy of a frame on which plumb's segmentation estimates normals and runs
///        RANSAC: a voxel-grid sample with PCA normals (Liu et al. 2022, sec. 2.2, ground steps
///        (1)-(2)). Full-resolution points are labelled afterwards by their distance to the planes
///        found on the sample.

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

/// @brief Which neighbours give a sample point its normal (sample_frame()).
enum class FrameNormals {
  /// The `normal_k` nearest among the sample points of the 3 x 3 x 3 voxels around the point's own
  /// that lie within `normal_radius`; where fewer than `normal_min_block` lie there (sparse places),
  /// the k nearest within the radius as kNearest. A walk along voxel rows instead of a tree search
  /// for most points. Where the k nearest lie inside the block (dense surfaces) the neighbours are
  /// those of kNearest; elsewhere they are nearby points of the same scale.
  kVoxelBlock,
  /// The `normal_k` nearest sample points within `normal_radius`: estimate_normals() on a kd-tree
  /// of the sample (features/normals.hpp).
  kNearest,
};

/// @brief How a frame is reduced before normals are estimated.
struct FrameSampleSettings {
  /// Voxel edge of the sample [m], > 0. Each voxel keeps its real point nearest to the centroid
  /// (which also filters noise: one point per voxel, Liu et al. 2022, sec. 2.2, ground step (1)).
  /// 0.3 m keeps walls and floors of a room dense enough for 8-neighbour normals while a 32-line
  /// frame shrinks ~14x (the normals of the sample are most of segment_frame()'s cost).
  double voxel_size = 0.3;
  FrameNormals normals = FrameNormals::kVoxelBlock;  ///< neighbourhood of a normal, see FrameNormals
  /// Neighbours per normal at most (the point included), >= 3.
  std::size_t normal_k = 8;
  /// kVoxelBlock: a block with fewer sample points than this within the radius uses the k nearest
  /// from a kd-tree instead (5: a 32-beam frame's far surfaces, where rings are farther apart than
  /// a voxel, keep their kNearest normals).
  std::size_t normal_min_block = 5;
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
///
/// The sample is exactly voxel_grid(cloud, {voxel_size, kNearestToCentroid}) (grid anchored at the
/// finite points' bounding-box minimum, ascending voxel-key order, ties to the lowest index), taken
/// from the coordinates alone: no copy of the cloud or of its other fields. Normals from the
/// neighbourhood chosen by `settings.normals` (FrameNormals).
/// @param cloud a frame in the sensor frame (origin = sensor, z up); non-finite points skipped
/// @return the sample; kInsufficientData (and an empty sample) when fewer than 3 points are finite
/// @throws plumb::Error on invalid settings or a cloud whose optional fields are inconsistent
/// @note O(n) for the n input points (radix sort of the voxel keys), then the normals of the m
///       sample points: O(m k) walking voxel rows (kVoxelBlock, plus O(k log m) per sparse point),
///       O(m k log m) with the kd-tree (kNearest). One thread, deterministic.
FrameSample sample_frame(const PointCloud& cloud, const FrameSampleSettings& settings = {});

}  // namespace plumb
