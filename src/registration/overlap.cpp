// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/registration/overlap.hpp"

#include <cmath>

#include "plumb/core/error.hpp"

namespace plumb {

OverlapResult overlap_ratio(const PointCloud& source, const KdTree3f& target_tree,
                            const Eigen::Isometry3d& T_target_source, double beta) {
  PLUMB_CHECK(std::isfinite(beta) && beta > 0.0, "overlap_ratio: beta = " << beta << " must be > 0");
  PLUMB_CHECK(T_target_source.matrix().allFinite(), "overlap_ratio: T_target_source is not finite");
  OverlapResult out;
  const Eigen::Matrix3f R = T_target_source.linear().cast<float>();
  const Eigen::Vector3f t = T_target_source.translation().cast<float>();
  const float beta_sq = static_cast<float>(beta * beta);
  double sum_sq = 0.0;
  for (const Vector3f& p : source.points) {
    if (!p.allFinite()) continue;
    ++out.num_valid;
    const auto nn = target_tree.nearest(R * p + t, beta_sq);
    if (nn && nn->dist_sq <= beta_sq) {
      ++out.num_inliers;
      sum_sq += nn->dist_sq;
    }
  }
  if (out.num_valid > 0) out.overlap = static_cast<double>(out.num_inliers) / static_cast<double>(out.num_valid);
  if (out.num_inliers > 0) out.rmse = std::sqrt(sum_sq / static_cast<double>(out.num_inliers));
  return out;
}

}  // namespace plumb
