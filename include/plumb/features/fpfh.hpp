// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief Fast Point Feature Histograms (FPFH, Rusu et al. 2009; Liu et al. 2022, sec. 1.2, eq. 1), 33 bins,
///        with Open3D's conventions so that the histograms agree with `ComputeFPFHFeature`.

#include <array>
#include <cstddef>
#include <vector>

#include "plumb/core/point_cloud.hpp"

namespace plumb {

/// @brief Number of bins of an FPFH signature: 3 angle features (α, φ, θ) × 11 bins.
inline constexpr int kFpfhBins = 33;
/// @brief Bins per angle feature (one sub-histogram).
inline constexpr int kFpfhBinsPerFeature = 11;

/// @brief One FPFH descriptor: bins [0, 11) α, [11, 22) φ, [22, 33) θ.
using FpfhSignature = std::array<float, kFpfhBins>;

/// @brief Neighbourhood of compute_fpfh() (Open3D's KDTreeSearchParamHybrid).
struct FpfhSettings {
  /// Neighbourhood radius [m]; > 0 and finite. Usually about 5x the point spacing (voxel size).
  float radius = 0.5f;
  /// Cap on the neighbourhood size, the point itself included (Open3D's max_nn): the nearest
  /// `max_neighbors` points within `radius` are kept. 0 = unlimited.
  std::size_t max_neighbors = 100;
  /// Visible side only: when >= 0, a neighbour q of p counts only if each lies on the side of the
  /// other's surface its normal points to: n_p · (q - p) >= -tol and n_q · (p - q) >= -tol [m].
  /// A sensor cannot see behind a surface, while a model sampled on every face has points there
  /// (the far face of a thin wall, the room behind it); this keeps most of them out of the model's
  /// descriptors so they look like a scan's (surfaces coplanar across a wall, such as the next
  /// room's floor, still pass: that would need ray casting). Negative (default) = plain FPFH
  /// (Rusu 2009, Open3D, PCL).
  float visible_side_tolerance = -1.0f;
  /// Threads (0 = every core) of the radius searches and of the signatures; the SPFH pass, which
  /// shares each pair between its two points, stays on one. Results are bit-identical for any count.
  int threads = 1;
};

/// @brief Descriptors of compute_fpfh().
struct FpfhResult {
  /// One signature per described point: every cloud point, or the `indices` order.
  std::vector<FpfhSignature> features;
  /// The cloud index of the point each feature describes (parallel to `features`).
  std::vector<std::size_t> indices;
  /// Described points that got an all-zero signature: non-finite point or normal, or no neighbour
  /// (other than itself) within the radius.
  std::size_t num_invalid = 0;
};

/// @brief FPFH descriptors of a cloud with normals (Liu et al. 2022, eq. 1).
///
/// For a point p with neighbours p_1..p_k (within `radius`, at most `max_neighbors` - 1 besides p),
/// SPFH(p) bins the Darboux-frame pair features (α, φ, θ) of every pair (p, p_i) into three
/// 11-bin histograms, each normalised to sum 100. Then
///   FPFH(p) = SPFH(p) + N( Σ_i SPFH(p_i) / ω_i ),
/// where, as in Open3D (and PCL), ω_i is the *squared* distance |p - p_i|², neighbours at distance
/// 0 are left out of the sum, and N rescales each 11-bin sub-histogram of the weighted sum to 100
/// (this replaces the 1/k of Liu et al. 2022, eq. 1). So each sub-histogram of a valid signature sums to 200.
/// Pair features follow Open3D / PCL `computePairFeatures`: the source of the pair is the point
/// whose normal makes the smaller angle with the connecting line; a pair of coincident points or
/// one whose line is parallel to the source normal contributes the features (0, 0, 0).
///
/// @param cloud points with unit normals (`cloud.normals` must be present, else plumb::Error).
///        Points or normals that are not finite are never used as neighbours.
/// @param settings neighbourhood (radius, cap)
/// @param indices  nullptr: describe every point. Otherwise describe the points `*indices` (key
///        points, any order, repeats allowed), against the full cloud: their neighbours' SPFH is
///        computed from the full cloud too, so a key point gets the same signature as in the full
///        run. Out-of-range indices throw plumb::Error.
/// @return the signatures; invalid points (see FpfhResult::num_invalid) get all-zero signatures.
/// @note O(n k) after one radius search per point that needs an SPFH. Deterministic; single thread.
FpfhResult compute_fpfh(const PointCloud& cloud, const FpfhSettings& settings = {},
                        const std::vector<std::size_t>* indices = nullptr);

}  // namespace plumb
