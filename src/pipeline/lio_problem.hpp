// SPDX-License-Identifier: BSD-3-Clause
#pragma once
/// @file
/// @brief The estimation problem of HybridLio (private to the library): the LiDAR residuals as
///        functions of the IMU state, the point-to-distribution association, and the joint
///        IMU + LiDAR least-squares problem over two consecutive states that HybridLio::solve()
///        minimises (Zhou et al. 2021, eq. 6, 7, 19-22). Kept apart from the driver so that each
///        block can be checked on its own (tests/pipeline/lio_problem_test.cpp).

#include <cstddef>
#include <vector>

#include <Eigen/Geometry>

#include "plumb/core/lie.hpp"
#include "plumb/core/point_cloud.hpp"
#include "plumb/imu/preintegration.hpp"
#include "plumb/loam/odometry.hpp"
#include "plumb/pipeline/hybrid_lio.hpp"
#include "plumb/search/kdtree.hpp"

namespace plumb::lio_detail {

constexpr int kDimJoint = 30;
using Vector30d = Eigen::Matrix<double, kDimJoint, 1>;
using Matrix30d = Eigen::Matrix<double, kDimJoint, kDimJoint>;

inline Eigen::Isometry3d pose_of(const ImuState& s) { return se3::make(s.R_world_body, s.p_world_body); }

/// x (-) m in ImuTangent order (rotation as log(R_m^T R_x)).
Vector15d state_error(const ImuState& x, const ImuState& m);

/// The LiDAR residuals of Zhou et al. 2021, eq. 6, 7, 20, as functions of the IMU state x: a query
/// point s in the IMU frame (s_imu[k] for corr[k]) maps to q = R s + p; Jacobians w.r.t. [dphi, dp]
/// (right perturbation of R, p + dp). A correspondence's weight multiplies its whitened residual
/// (1: its kind's sigma), robustified by Huber at settings.huber_scale. Returns 1/2 sum rho; adds
/// the IRLS-weighted normal equations, and to sum_sq the squared residuals [m^2], when H is not null.
double lidar_terms(const std::vector<LoamCorrespondence>& corr, const std::vector<Vector3d>& s_imu, const ImuState& x,
                   const HybridLioSettings& set, Matrix6d* H, Vector6d* g, double* sum_sq);

/// IcpMetric::kPointToDistribution pairs: each point of `cur`, moved by T_map_cur, against the mean
/// and covariance of its icp_neighbors nearest map points within max_correspondence_distance (at
/// least 3 of them). A pair becomes three kPlane correspondences, one along each covariance axis,
/// whose weight turns the plane residual's 1 / plane_sigma into 1 / sqrt(lambda + point_sigma^2):
/// together the Mahalanobis distance of the point. Appends to corr; returns the pairs.
std::size_t associate_distributions(const PointCloud& map, const KdTree3f& tree, const PointCloud& cur,
                                    const Eigen::Isometry3d& T_map_cur, const HybridLioSettings& set,
                                    std::vector<LoamCorrespondence>& corr);

/// The joint problem over x_i (tangent offset 0) and x_j (offset 15) with the IMU factor and the
/// marginal prior on x_i, or over the pose of x_j alone (offset 0) without them (Zhou et al. 2021,
/// eq. 19-22). The references given to the constructor must outlive the problem.
class JointProblem {
 public:
  /// pim: the preintegrated IMU between the two states, or null (LiDAR only, pose of x_j alone).
  JointProblem(const HybridLioSettings& set, const ImuPreintegration* pim, const ImuState& prior_mean,
               const Matrix15d& prior_information);

  bool with_imu() const { return pim_ != nullptr; }
  int dim() const { return with_imu() ? kDimJoint : 6; }   ///< unknowns
  int offset_j() const { return with_imu() ? 15 : 0; }     ///< where x_j's tangent starts

  /// 1/2 the sum of squared (robust) residuals at (a, b); when H is not null, also the Gauss-Newton
  /// system H, g (of the first dim() unknowns) and the squared LiDAR distances sum_sq [m^2].
  double build(const ImuState& a, const ImuState& b, const std::vector<LoamCorrespondence>& corr,
               const std::vector<Vector3d>& s_imu, Matrix30d* H, Vector30d* g, double* sum_sq) const;

  /// (a, b) = (xi, xj) moved by delta (only the pose of xj without the IMU factor).
  void step(const Vector30d& delta, const ImuState& xi, const ImuState& xj, ImuState& a, ImuState& b) const;

 private:
  const HybridLioSettings& set_;
  const ImuPreintegration* pim_;
  const ImuState& prior_mean_;
  const Matrix15d& prior_information_;
  Matrix15d U_ = Matrix15d::Zero();  ///< square root of the IMU factor's information
};

}  // namespace plumb::lio_detail
