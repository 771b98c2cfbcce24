// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <cmath>

#include <Eigen/Eigenvalues>

#include "plumb/core/error.hpp"

namespace plumb {

namespace detail {

/// PCA of the neighbours `idx[0..n)`: unit normal (smallest eigenvector) and surface variation.
/// Returns false when the neighbourhood is degenerate (< 3 points or all coincident).
inline bool pca_normal(const std::vector<Vector3f>& pts, const std::size_t* idx, std::size_t n,
                       Vector3f& normal, float& curvature) {
  if (n < 3) return false;
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (std::size_t j = 0; j < n; ++j) mean += pts[idx[j]].cast<double>();
  mean /= static_cast<double>(n);
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (std::size_t j = 0; j < n; ++j) {
    const Eigen::Vector3d d = pts[idx[j]].cast<double>() - mean;
    cov.noalias() += d * d.transpose();
  }
  const double trace = cov.trace();
  if (!(trace > 0.0)) return false;
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(cov);
  if (es.info() != Eigen::Success) return false;
  const Eigen::Vector3d ev = es.eigenvalues();  // ascending
  normal = es.eigenvectors().col(0).cast<float>().normalized();
  curvature = static_cast<float>(std::max(0.0, ev(0)) / trace);
  return normal.allFinite();
}

}  // namespace detail

inline NormalResult estimate_normals(const std::vector<Vector3f>& cloud, const KdTree<3>& tree,
                                     const std::vector<Vector3f>& tree_points,
                                     const NormalSettings& settings) {
  PLUMB_CHECK(settings.k >= 3, "estimate_normals: settings.k = " << settings.k << " must be >= 3");
  PLUMB_CHECK(!(settings.radius < 0.0f) && !std::isnan(settings.radius),
              "estimate_normals: settings.radius = " << settings.radius << " must be >= 0");
  PLUMB_CHECK(tree.num_input_points() == tree_points.size(),
              "estimate_normals: tree was built from " << tree.num_input_points()
                                                       << " points but tree_points has "
                                                       << tree_points.size());
  const float nan = std::numeric_limits<float>::quiet_NaN();
  NormalResult out;
  out.normals.assign(cloud.size(), Vector3f::Constant(nan));
  out.curvature.assign(cloud.size(), nan);
  std::vector<std::size_t> idx(settings.k);
  std::vector<float> d2(settings.k);
  const float r2 = settings.radius * settings.radius;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const Vector3f& p = cloud[i];
    std::size_t n = p.allFinite() ? tree.knn(p, settings.k, idx.data(), d2.data()) : 0;
    if (settings.radius > 0.0f) {
      while (n > 0 && d2[n - 1] > r2) --n;  // sorted ascending
    }
    Vector3f normal;
    float curv = nan;
    if (!detail::pca_normal(tree_points, idx.data(), n, normal, curv)) {
      ++out.num_invalid;
      continue;
    }
    if (settings.orient_to_viewpoint && normal.dot(settings.viewpoint - p) < 0.0f) normal = -normal;
    out.normals[i] = normal;
    out.curvature[i] = curv;
  }
  return out;
}

inline std::size_t compute_normals(PointCloud& cloud, const NormalSettings& settings) {
  PLUMB_CHECK(!cloud.empty(), "compute_normals: the cloud is empty");
  const KdTree<3> tree(cloud.points);
  NormalResult r = estimate_normals(cloud.points, tree, cloud.points, settings);
  cloud.normals = std::move(r.normals);
  return r.num_invalid;
}

}  // namespace plumb
