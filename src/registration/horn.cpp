// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/registration/horn.hpp"

#include <algorithm>
#include <cmath>

#include <Eigen/Eigenvalues>

#include "plumb/core/error.hpp"

#include "core/eigen_instantiations.hpp"

namespace plumb {

HornResult HornAccumulator::solve() const {
  HornResult out;
  out.num_pairs = n_;
  if (n_ < 3 || !(w_sum_ > 0.0)) return out;
  const Vector3d mu_p = p_sum_ / w_sum_;
  const Vector3d mu_q = q_sum_ / w_sum_;
  // Centred cross-covariance S = sum w (p - mu_p)(q - mu_q)^T.
  const Matrix3d S = pq_sum_ - w_sum_ * mu_p * mu_q.transpose();
  const double var_p = pp_sum_ - w_sum_ * mu_p.squaredNorm();
  const double var_q = qq_sum_ - w_sum_ * mu_q.squaredNorm();
  // Horn's symmetric 4x4 matrix N; its top eigenvector is the rotation quaternion (w, x, y, z).
  Eigen::Matrix4d N;
  const double sxx = S(0, 0), sxy = S(0, 1), sxz = S(0, 2);
  const double syx = S(1, 0), syy = S(1, 1), syz = S(1, 2);
  const double szx = S(2, 0), szy = S(2, 1), szz = S(2, 2);
  N << sxx + syy + szz, syz - szy, szx - sxz, sxy - syx,  //
      syz - szy, sxx - syy - szz, sxy + syx, szx + sxz,   //
      szx - sxz, sxy + syx, -sxx + syy - szz, syz + szy,  //
      sxy - syx, szx + sxz, syz + szy, -sxx - syy + szz;
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix4d> es(N);
  if (es.info() != Eigen::Success) return out;
  const Eigen::Vector4d ev = es.eigenvalues();  // ascending
  // A set spanning less than a plane's worth of directions (collinear, coincident) leaves the
  // rotation about the line free: the two largest eigenvalues coincide.
  const double scale = std::max(std::abs(ev(0)), std::abs(ev(3)));
  if (!(scale > 0.0) || ev(3) - ev(2) <= 1e-9 * scale) return out;
  const Eigen::Vector4d v = es.eigenvectors().col(3);
  const Eigen::Quaterniond q(v(0), v(1), v(2), v(3));
  const Matrix3d R = q.normalized().toRotationMatrix();
  const Vector3d t = (q0_ + mu_q) - R * (p0_ + mu_p);  // Liu et al. 2022, eq. 6: q_T = u_q - R u_p
  out.T_target_source.linear() = R;
  out.T_target_source.translation() = t;
  // Residual sum: var_p + var_q - 2 tr(R S^T)... = var_p + var_q - 2 * lambda_max.
  const double ss = std::max(0.0, var_p + var_q - 2.0 * ev(3));
  out.rmse = std::sqrt(ss / w_sum_);
  out.valid = out.T_target_source.matrix().allFinite();
  if (!out.valid) out.T_target_source.setIdentity();
  return out;
}

HornResult horn_align(const std::vector<Vector3d>& source, const std::vector<Vector3d>& target,
                      const std::vector<double>* weights) {
  PLUMB_CHECK(source.size() == target.size(), "horn_align: " << source.size() << " source points but "
                                                              << target.size() << " target points");
  PLUMB_CHECK(weights == nullptr || weights->size() == source.size(),
              "horn_align: " << weights->size() << " weights for " << source.size() << " pairs");
  HornAccumulator acc;
  for (std::size_t i = 0; i < source.size(); ++i) {
    const double w = weights ? (*weights)[i] : 1.0;
    PLUMB_CHECK(source[i].allFinite() && target[i].allFinite() && std::isfinite(w) && w >= 0.0,
                "horn_align: pair " << i << " has a non-finite point or a bad weight " << w);
    acc.add(source[i], target[i], w);
  }
  return acc.solve();
}

}  // namespace plumb
