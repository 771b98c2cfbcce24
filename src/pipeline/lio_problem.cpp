// SPDX-License-Identifier: BSD-3-Clause
#include "lio_problem.hpp"

#include <algorithm>
#include <cmath>

#include <Eigen/Eigenvalues>

#include "plumb/core/parallel.hpp"
#include "plumb/core/robust_kernel.hpp"

namespace plumb::lio_detail {

Vector15d state_error(const ImuState& x, const ImuState& m) {
  Vector15d e;
  e.segment<3>(ImuTangent::kR) = so3::log(m.R_world_body.transpose() * x.R_world_body);
  e.segment<3>(ImuTangent::kP) = x.p_world_body - m.p_world_body;
  e.segment<3>(ImuTangent::kV) = x.v_world - m.v_world;
  e.segment<3>(ImuTangent::kBg) = x.bias.gyro - m.bias.gyro;
  e.segment<3>(ImuTangent::kBa) = x.bias.accel - m.bias.accel;
  return e;
}

double lidar_terms(const std::vector<LoamCorrespondence>& corr, const std::vector<Vector3d>& s_imu, const ImuState& x,
                   const HybridLioSettings& set, Matrix6d* H, Vector6d* g, double* sum_sq) {
  const Matrix3d& R = x.R_world_body;
  const Vector3d& p = x.p_world_body;
  double cost = 0.0;
  // Huber on the squared whitened norm; HybridLio checks the scale (> 0, and +inf is plain least squares).
  const RobustLoss huber{RobustKernel::kHuber, set.solver.huber_scale};
  Eigen::Matrix<double, 3, 6> Jq;
  for (std::size_t k = 0; k < corr.size(); ++k) {
    const LoamCorrespondence& c = corr[k];
    const Vector3d q = R * s_imu[k] + p;
    if (H != nullptr) {
      Jq.leftCols<3>() = -R * hat(s_imu[k]);
      Jq.rightCols<3>().setIdentity();
    }
    if (c.kind == LoamCorrespondence::Kind::kPlane) {
      const double inv = c.weight / set.solver.plane_sigma;
      const double d = c.dir.dot(q - c.a);
      const double r = inv * d;
      const double s = r * r;
      cost += 0.5 * huber.rho(s);
      if (H != nullptr) {
        const Matrix16d J = inv * c.dir.transpose() * Jq;
        const double w = huber.rho_prime(s);
        H->noalias() += w * J.transpose() * J;
        g->noalias() += w * J.transpose() * r;
        *sum_sq += d * d;
      }
    } else {
      const bool edge = c.kind == LoamCorrespondence::Kind::kEdge;
      const double inv = c.weight / (edge ? set.solver.edge_sigma : set.solver.point_sigma);
      const Vector3d d = edge ? Vector3d(c.dir.cross(q - c.a)) : Vector3d(q - c.a);
      const Vector3d r = inv * d;
      const double s = r.squaredNorm();
      cost += 0.5 * huber.rho(s);
      if (H != nullptr) {
        const Matrix36d J = edge ? Matrix36d(inv * hat(c.dir) * Jq) : Matrix36d(inv * Jq);
        const double w = huber.rho_prime(s);
        H->noalias() += w * J.transpose() * J;
        g->noalias() += w * J.transpose() * r;
        *sum_sq += d.squaredNorm();
      }
    }
  }
  return cost;
}

std::size_t associate_distributions(const PointCloud& map, const KdTree3f& tree, const PointCloud& cur,
                                    const Eigen::Isometry3d& T_map_cur, const HybridLioSettings& set,
                                    std::vector<LoamCorrespondence>& corr) {
  const std::size_t k = static_cast<std::size_t>(set.solver.icp_neighbors);
  const double max_d = set.solver.max_correspondence_distance;
  const float max_sq = static_cast<float>(max_d * max_d);
  const Eigen::Matrix3f R = T_map_cur.linear().cast<float>();
  const Eigen::Vector3f t = T_map_cur.translation().cast<float>();
  const double var0 = set.solver.point_sigma * set.solver.point_sigma;
  const std::size_t before = corr.size();
  // Independent queries in fixed chunks, appended in point order: the same list on any thread count.
  constexpr std::size_t kGrain = 256;
  parallel_append(set.threads, cur.points.size(), kGrain, corr,
                  [&](std::size_t begin, std::size_t end, std::vector<LoamCorrespondence>& out) {
    std::size_t idx[64];
    float d2[64];
    for (std::size_t i = begin; i < end; ++i) {
      const Vector3f& p = cur.points[i];
      if (!p.allFinite()) continue;
      const std::size_t m = tree.knn(R * p + t, k, idx, d2, max_sq);
      if (m < 3) continue;
      Vector3d mean;
      Matrix3d cov;
      loam_neighbour_moments(map, idx, m, mean, cov);
      Eigen::SelfAdjointEigenSolver<Matrix3d> eig;
      eig.computeDirect(cov);
      for (int a = 0; a < 3; ++a) {
        const double lambda = std::max(eig.eigenvalues()(a), 0.0);
        out.push_back({LoamCorrespondence::Kind::kPlane, p.cast<double>(), mean, eig.eigenvectors().col(a),
                       set.solver.plane_sigma / std::sqrt(lambda + var0)});
      }
    }
  });
  return (corr.size() - before) / 3;  // three residuals per matched point
}

JointProblem::JointProblem(const HybridLioSettings& set, const ImuPreintegration* pim, const ImuState& prior_mean,
                           const Matrix15d& prior_information)
    : set_(set), pim_(pim), prior_mean_(prior_mean), prior_information_(prior_information) {
  if (pim_ != nullptr) U_ = pim_->sqrt_information_with_bias();
}

double JointProblem::build(const ImuState& a, const ImuState& b, const std::vector<LoamCorrespondence>& corr,
                           const std::vector<Vector3d>& s_imu, Matrix30d* H, Vector30d* g, double* sum_sq) const {
  double cost = 0.0;
  if (H != nullptr) {
    H->setZero();
    g->setZero();
    *sum_sq = 0.0;
  }
  if (with_imu()) {
    const Vector15d e = state_error(a, prior_mean_);
    cost += 0.5 * e.dot(prior_information_ * e);
    const ImuFactorResidual f = pim_->residual(a, b);
    const Vector15d r = U_ * f.r;
    cost += 0.5 * r.squaredNorm();
    if (H != nullptr) {
      H->topLeftCorner<15, 15>() += prior_information_;
      g->head<15>() += prior_information_ * e;
      Eigen::Matrix<double, 15, 30> J;
      J.leftCols<15>() = U_ * f.J_r_xi_i;
      J.rightCols<15>() = U_ * f.J_r_xi_j;
      H->noalias() += J.transpose() * J;
      g->noalias() += J.transpose() * r;
    }
  }
  Matrix6d Hl = Matrix6d::Zero();
  Vector6d gl = Vector6d::Zero();
  cost += lidar_terms(corr, s_imu, b, set_, H != nullptr ? &Hl : nullptr, &gl, sum_sq);
  if (H != nullptr) {
    H->block<6, 6>(offset_j(), offset_j()) += Hl;
    g->segment<6>(offset_j()) += gl;
  }
  return cost;
}

void JointProblem::step(const Vector30d& delta, const ImuState& xi, const ImuState& xj, ImuState& a,
                        ImuState& b) const {
  if (with_imu()) {
    a = retract(xi, delta.head<15>());
    b = retract(xj, delta.tail<15>());
  } else {
    Vector15d d = Vector15d::Zero();
    d.head<6>() = delta.head<6>();
    a = xi;
    b = retract(xj, d);
  }
}

}  // namespace plumb::lio_detail
