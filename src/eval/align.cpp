// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/eval/align.hpp"

#include <cmath>

#include <Eigen/SVD>

#include "plumb/core/error.hpp"

namespace plumb::eval {

const char* to_string(AlignMode mode) {
  switch (mode) {
    case AlignMode::kNone: return "none";
    case AlignMode::kSE3: return "se3";
    case AlignMode::kSim3: return "sim3";
  }
  return "unknown";
}

UmeyamaResult umeyama(const std::vector<Vector3d>& source, const std::vector<Vector3d>& target,
                      bool with_scale) {
  PLUMB_CHECK(!source.empty(), "umeyama: empty point sets");
  PLUMB_CHECK(source.size() == target.size(),
              "umeyama: " << source.size() << " source points but " << target.size() << " target points");
  const double n = static_cast<double>(source.size());
  Vector3d mean_source = Vector3d::Zero();
  Vector3d mean_target = Vector3d::Zero();
  for (std::size_t i = 0; i < source.size(); ++i) {
    mean_source += source[i];
    mean_target += target[i];
  }
  mean_source /= n;
  mean_target /= n;
  PLUMB_CHECK(mean_source.allFinite() && mean_target.allFinite(), "umeyama: a point is not finite (or too large)");

  // Eq. 36 (variance of the source) and eq. 38 (cross-covariance target x source).
  double variance_source = 0.0;
  Matrix3d covariance = Matrix3d::Zero();
  for (std::size_t i = 0; i < source.size(); ++i) {
    const Vector3d ds = source[i] - mean_source;
    const Vector3d dt = target[i] - mean_target;
    variance_source += ds.squaredNorm();
    covariance += dt * ds.transpose();
  }
  variance_source /= n;
  covariance /= n;

  UmeyamaResult result;
  const Eigen::JacobiSVD<Matrix3d> svd(covariance, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Matrix3d& U = svd.matrixU();
  const Matrix3d& V = svd.matrixV();
  const Vector3d d = svd.singularValues();
  // Eq. 43: S = diag(1, 1, -1) when det(U) det(V) < 0 (the best orthogonal matrix is a reflection).
  Vector3d S = Vector3d::Ones();
  if (U.determinant() * V.determinant() < 0.0) S.z() = -1.0;
  const Matrix3d R = U * S.asDiagonal() * V.transpose();
  double scale = 1.0;
  if (with_scale) {
    PLUMB_CHECK(variance_source > 0.0, "umeyama: all source points coincide, the scale is undefined");
    scale = d.dot(S) / variance_source;  // eq. 42
  }
  const Vector3d t = mean_target - scale * R * mean_source;  // eq. 41

  result.T_ref_est.linear() = R;
  result.T_ref_est.translation() = t;
  result.scale = scale;
  double sse = 0.0;
  for (std::size_t i = 0; i < source.size(); ++i) {
    sse += (target[i] - (scale * (R * source[i]) + t)).squaredNorm();
  }
  result.rmse = std::sqrt(sse / n);
  if (source.size() < 2) {
    result.status = Status::kInsufficientData;
  } else if (d(1) <= 1e-12 * std::max(d(0), 1e-300)) {
    result.status = Status::kDegenerate;
  }
  return result;
}

std::vector<Vector3d> positions(const Trajectory& trajectory) {
  std::vector<Vector3d> out;
  out.reserve(trajectory.size());
  for (const Eigen::Isometry3d& T : trajectory.poses) out.push_back(T.translation());
  return out;
}

Trajectory apply_similarity(const Trajectory& trajectory, const Eigen::Isometry3d& T_ref_est,
                            double scale) {
  Trajectory out = trajectory;
  for (Eigen::Isometry3d& T : out.poses) {
    Eigen::Isometry3d scaled = T;
    scaled.translation() *= scale;
    T = T_ref_est * scaled;
  }
  return out;
}

AlignResult align_trajectory(const Trajectory& estimate, const Trajectory& reference, AlignMode mode) {
  PLUMB_CHECK(!estimate.empty(), "align_trajectory: empty estimate");
  PLUMB_CHECK(estimate.size() == reference.size(),
              "align_trajectory: estimate has " << estimate.size() << " poses, reference "
                                                << reference.size() << " (associate them first)");
  AlignResult result;
  if (mode == AlignMode::kNone) {
    result.aligned = estimate;
    return result;
  }
  result.transform = umeyama(positions(estimate), positions(reference), mode == AlignMode::kSim3);
  result.aligned = apply_similarity(estimate, result.transform.T_ref_est, result.transform.scale);
  return result;
}

}  // namespace plumb::eval
