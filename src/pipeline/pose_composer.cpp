// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/pipeline/pose_composer.hpp"

#include <cmath>

#include <Eigen/Eigenvalues>

#include "plumb/core/error.hpp"
#include "plumb/core/lie.hpp"

#include "core/eigen_instantiations.hpp"

namespace plumb {
namespace {

/// Regularised lower incomplete gamma function P(a, x), a > 0, x >= 0 (series / continued fraction).
double gamma_p(double a, double x) {
  if (x <= 0.0) return 0.0;
  const double log_prefix = a * std::log(x) - x - std::lgamma(a);
  if (x < a + 1.0) {
    double term = 1.0 / a, sum = term;
    for (int n = 1; n < 500; ++n) {
      term *= x / (a + n);
      sum += term;
      if (std::abs(term) < std::abs(sum) * 1e-16) break;
    }
    return sum * std::exp(log_prefix);
  }
  // Lentz's continued fraction for Q(a, x).
  const double tiny = 1e-300;
  double b = x + 1.0 - a, c = 1.0 / tiny, d = 1.0 / b, h = d;
  for (int n = 1; n < 500; ++n) {
    const double an = -n * (n - a);
    b += 2.0;
    d = an * d + b;
    if (std::abs(d) < tiny) d = tiny;
    c = b + an / c;
    if (std::abs(c) < tiny) c = tiny;
    d = 1.0 / d;
    const double delta = d * c;
    h *= delta;
    if (std::abs(delta - 1.0) < 1e-16) break;
  }
  return 1.0 - std::exp(log_prefix) * h;
}

void check_symmetric_psd(const Matrix6d& M, const char* what, bool definite) {
  PLUMB_CHECK(M.allFinite(), "PoseComposer: " << what << " has non-finite entries");
  const double scale = std::max(1.0, M.cwiseAbs().maxCoeff());
  PLUMB_CHECK((M - M.transpose()).cwiseAbs().maxCoeff() <= 1e-9 * scale,
              "PoseComposer: " << what << " is not symmetric");
  const Eigen::SelfAdjointEigenSolver<Matrix6d> es(0.5 * (M + M.transpose()), Eigen::EigenvaluesOnly);
  const double lo = es.eigenvalues()(0);
  if (definite) {
    PLUMB_CHECK(lo > 0.0, "PoseComposer: " << what << " must be positive definite (smallest eigenvalue " << lo
                                           << ")");
  } else {
    PLUMB_CHECK(lo >= -1e-9 * scale, "PoseComposer: " << what << " must be positive semi-definite (smallest eigenvalue "
                                                       << lo << ")");
  }
}

void check_pose(const Eigen::Isometry3d& T, const char* what) {
  PLUMB_CHECK(T.matrix().allFinite(), "PoseComposer: " << what << " is not finite");
  const double orth = (T.linear().transpose() * T.linear() - Matrix3d::Identity()).cwiseAbs().maxCoeff();
  PLUMB_CHECK(orth < 1e-6 && T.linear().determinant() > 0.0,
              "PoseComposer: " << what << " has no rotation matrix (|RᵀR − I| = " << orth << ")");
}

Matrix6d symmetrize(const Matrix6d& M) { return 0.5 * (M + M.transpose()); }

}  // namespace

double chi_square_quantile(double p, int dof) {
  PLUMB_CHECK(dof >= 1, "chi_square_quantile: dof = " << dof << " must be >= 1");
  PLUMB_CHECK(p > 0.0 && p < 1.0, "chi_square_quantile: p = " << p << " must be in (0, 1)");
  const double a = 0.5 * dof;
  double lo = 0.0, hi = std::max(1.0, 2.0 * dof);
  while (gamma_p(a, 0.5 * hi) < p) hi *= 2.0;
  for (int i = 0; i < 200 && hi - lo > 1e-12 * hi; ++i) {
    const double mid = 0.5 * (lo + hi);
    (gamma_p(a, 0.5 * mid) < p ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

Matrix6d planar_covariance(const Matrix3d& c, double var_z, double var_roll_pitch) {
  PLUMB_CHECK(c.allFinite() && std::isfinite(var_z) && std::isfinite(var_roll_pitch) && var_z >= 0.0 &&
                  var_roll_pitch >= 0.0,
              "planar_covariance: non-finite or negative input");
  Matrix6d Q = Matrix6d::Zero();
  const int idx[3] = {0, 1, 5};  // x, y, yaw in [ρ; φ]
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) Q(idx[i], idx[j]) = c(i, j);
  Q(2, 2) = var_z;
  Q(3, 3) = Q(4, 4) = var_roll_pitch;
  return Q;
}

Matrix6d body_to_world_information(const Eigen::Isometry3d& T_world_body, const Matrix6d& information_body) {
  const Matrix6d Ad_inv = se3::adjoint(T_world_body.inverse());
  return symmetrize(Ad_inv.transpose() * information_body * Ad_inv);
}

const char* to_string(AnchorDecision d) {
  switch (d) {
    case AnchorDecision::kAccepted: return "accepted";
    case AnchorDecision::kRejected: return "rejected";
    case AnchorDecision::kIgnored: return "ignored";
  }
  return "unknown";
}

PoseComposer::PoseComposer(const Eigen::Isometry3d& T_world_base0, const Matrix6d& P0,
                           const PoseComposerSettings& settings)
    : settings_(settings), pose_(T_world_base0), P_(symmetrize(P0)) {
  PLUMB_CHECK(settings.gate_probability > 0.0 && settings.gate_probability < 1.0,
              "PoseComposer: gate_probability = " << settings.gate_probability << " must be in (0, 1)");
  PLUMB_CHECK(settings.rank_tolerance >= 0.0 && settings.rank_tolerance < 1.0,
              "PoseComposer: rank_tolerance = " << settings.rank_tolerance << " must be in [0, 1)");
  check_pose(T_world_base0, "initial pose");
  check_symmetric_psd(P0, "initial covariance P0", true);
}

void PoseComposer::add_motion(const Eigen::Isometry3d& T_prev_cur, const Matrix6d& Q) {
  check_pose(T_prev_cur, "motion");
  check_symmetric_psd(Q, "motion covariance Q", false);
  pose_ = pose_ * T_prev_cur;
  const Matrix6d Ad = se3::adjoint(pose_);
  P_ = symmetrize(P_ + Ad * Q * Ad.transpose());
}

AnchorResult PoseComposer::add_anchor(const Eigen::Isometry3d& T_meas, const Matrix6d& information) {
  check_pose(T_meas, "anchor pose");
  check_symmetric_psd(information, "anchor information", false);
  AnchorResult r;
  const Matrix6d L = symmetrize(information);
  const Eigen::SelfAdjointEigenSolver<Matrix6d> es(L, Eigen::EigenvaluesOnly);
  const double largest = es.eigenvalues()(5);
  if (!(largest > 0.0)) return r;  // nothing constrained
  for (int i = 0; i < 6; ++i) r.dof += es.eigenvalues()(i) > settings_.rank_tolerance * largest ? 1 : 0;
  r.gate = chi_square_quantile(settings_.gate_probability, r.dof);

  Eigen::Isometry3d delta_T = T_meas * pose_.inverse();
  r.innovation = se3::log(delta_T);
  auto mahalanobis = [&](const Matrix6d& P) {
    const Matrix6d posterior_info = symmetrize(P.inverse() + L);
    const Matrix6d posterior_cov = symmetrize(posterior_info.inverse());
    const Matrix6d S_inv = symmetrize(L - L * posterior_cov * L);
    return std::make_pair(r.innovation.dot(S_inv * r.innovation), posterior_cov);
  };
  if (settings_.max_consecutive_rejections > 0 && consecutive_rejections_ >= settings_.max_consecutive_rejections) {
    // The composer's covariance no longer explains the anchors: widen it by the innovation seen.
    P_ = symmetrize(P_ + last_rejected_innovation_ * last_rejected_innovation_.transpose() +
                    r.innovation * r.innovation.transpose());
    r.inflated = true;
    consecutive_rejections_ = 0;
  }
  auto [d2, posterior_cov] = mahalanobis(P_);
  r.mahalanobis_sq = d2;
  if (!(d2 <= r.gate)) {
    r.decision = AnchorDecision::kRejected;
    ++num_rejected_;
    ++consecutive_rejections_;
    last_rejected_innovation_ = r.innovation;
    return r;
  }
  r.correction = posterior_cov * L * r.innovation;
  pose_ = se3::exp(r.correction) * pose_;
  // Keep the rotation exactly orthonormal after many corrections.
  pose_.linear() = Eigen::Quaterniond(pose_.linear()).normalized().toRotationMatrix();
  P_ = posterior_cov;
  r.decision = AnchorDecision::kAccepted;
  ++num_accepted_;
  consecutive_rejections_ = 0;
  return r;
}

}  // namespace plumb
