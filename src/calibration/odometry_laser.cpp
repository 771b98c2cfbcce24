// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/calibration/odometry_laser.hpp"

#include <algorithm>
#include <cmath>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/LU>

#include "plumb/core/error.hpp"

#include "core/eigen_instantiations.hpp"

namespace plumb {
namespace {

/// sin(a)/a and (1 - cos(a))/a, with their series near 0.
void arc_factors(double a, double& sin_over, double& one_minus_cos_over) {
  if (std::abs(a) > 1e-6) {
    sin_over = std::sin(a) / a;
    one_minus_cos_over = (1.0 - std::cos(a)) / a;
  } else {
    const double a2 = a * a;
    sin_over = 1.0 - a2 / 6.0;
    one_minus_cos_over = a / 2.0 - a * a2 / 24.0;
  }
}

struct SolveOutcome {
  Status status = Status::kDegenerate;
  OdometryLaserParams params;
  double j21 = 0.0;
  double j22 = 0.0;
  double condition_number = 0.0;
};

/// The two linear steps on the tuples selected by `use`.
SolveOutcome solve_two_steps(const std::vector<CalibrationTuple>& tuples, const std::vector<bool>& use,
                             const OdometryLaserCalibrationSettings& settings) {
  SolveOutcome out;
  // Step 1: ŝ_θ = T (J21 φ_L + J22 φ_R), least squares over the tuples.
  Eigen::Matrix2d A = Eigen::Matrix2d::Zero();
  Eigen::Vector2d g = Eigen::Vector2d::Zero();
  for (std::size_t k = 0; k < tuples.size(); ++k) {
    if (!use[k]) continue;
    const CalibrationTuple& t = tuples[k];
    const Eigen::Vector2d L(t.T * t.phi_left, t.T * t.phi_right);
    A += L * L.transpose();
    g += t.laser_motion.theta * L;
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eig_a(A);
  const double lo = eig_a.eigenvalues()(0), hi = eig_a.eigenvalues()(1);
  if (!(hi > 0.0) || !(lo > 0.0)) return out;
  out.condition_number = hi / lo;
  if (!(out.condition_number <= settings.max_condition_number)) return out;
  const Eigen::Vector2d J = A.ldlt().solve(g);
  out.j21 = J(0);
  out.j22 = J(1);
  if (!std::isfinite(out.j21) || !std::isfinite(out.j22)) return out;

  // Step 2: the translation part of r ⊕ l = l ⊕ ŝ, linear in x = (b, l_x, l_y, cos l_θ, sin l_θ):
  //   (I - R(o_θ)) l_t + R(l_θ) ŝ_t - b c = 0,  c = o_t / b from J21, J22.
  Eigen::Matrix<double, 5, 5> M = Eigen::Matrix<double, 5, 5>::Zero();
  for (std::size_t k = 0; k < tuples.size(); ++k) {
    if (!use[k]) continue;
    const CalibrationTuple& t = tuples[k];
    const double o_theta = t.T * (out.j21 * t.phi_left + out.j22 * t.phi_right);
    double f1 = 1.0, f2 = 0.0;
    arc_factors(o_theta, f1, f2);
    // v / b = (-J21 φ_L + J22 φ_R) / 2.
    const double v_over_b = 0.5 * (-out.j21 * t.phi_left + out.j22 * t.phi_right);
    const double cx = t.T * v_over_b * f1, cy = t.T * v_over_b * f2;
    const double c = std::cos(o_theta), s = std::sin(o_theta);
    const double sx = t.laser_motion.x, sy = t.laser_motion.y;
    Eigen::Matrix<double, 2, 5> L;
    L << -cx, 1.0 - c, s, sx, -sy,  //
        -cy, -s, 1.0 - c, sy, sx;
    M += L.transpose() * L;
  }
  // Constrained minimum of xᵀ M x with |x_{3:4}| = 1. With M = [P Q; Qᵀ D] (P for b, l_x, l_y),
  // det(M + λW) = det(P) det(S + λI), S = D - Qᵀ P⁻¹ Q: the quadratic of the Lagrange condition.
  // Its larger root λ = -λ_min(S) gives the minimum xᵀ M x = λ_min(S), with x_{3:4} the
  // corresponding eigenvector z of S and x_{0:2} = -P⁻¹ Q z.
  const Eigen::Matrix3d P = M.topLeftCorner<3, 3>();
  const Eigen::Matrix<double, 3, 2> Q = M.topRightCorner<3, 2>();
  const Eigen::Matrix2d D = M.bottomRightCorner<2, 2>();
  const Eigen::Vector3d p_diag = P.diagonal();
  if (!(p_diag.minCoeff() > 0.0)) return out;
  const Eigen::Vector3d inv_sqrt = p_diag.cwiseSqrt().cwiseInverse();
  const Eigen::Matrix3d P_scaled = inv_sqrt.asDiagonal() * P * inv_sqrt.asDiagonal();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig_p(P_scaled);
  if (!(eig_p.eigenvalues()(0) >= settings.min_scaled_eigenvalue)) return out;
  const Eigen::LDLT<Eigen::Matrix3d> P_ldlt(P);
  const Eigen::Matrix<double, 3, 2> PinvQ = P_ldlt.solve(Q);
  Eigen::Matrix2d S = D - Q.transpose() * PinvQ;
  S = 0.5 * (S + S.transpose()).eval();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eig_s(S);
  Eigen::Vector2d z = eig_s.eigenvectors().col(0);
  Eigen::Vector3d head = -PinvQ * z;
  if (head(0) < 0.0) {  // x and -x give the same cost; the axle is positive
    z = -z;
    head = -head;
  }
  const double b = head(0);
  out.params.axle = b;
  out.params.radius_left = -b * out.j21;
  out.params.radius_right = b * out.j22;
  out.params.laser = Pose2{head(1), head(2), std::atan2(z(1), z(0))};
  const Vector6d v = out.params.vector();
  if (!v.allFinite() || !(b > 0.0) || !(out.params.radius_left > 0.0) ||
      !(out.params.radius_right > 0.0)) {
    out.params = {};
    return out;
  }
  out.status = Status::kOk;
  return out;
}

/// Residual used for outlier rejection: (l ⊕ ŝ) - (r ⊕ l), angle wrapped.
Vector3d disagreement(const OdometryLaserParams& params, const CalibrationTuple& t) {
  const Pose2 r = differential_drive_motion(params.radius_left, params.radius_right, params.axle, t.T,
                                            t.phi_left, t.phi_right);
  const Pose2 a = params.laser.oplus(t.laser_motion);
  const Pose2 b = r.oplus(params.laser);
  return {a.x - b.x, a.y - b.y, wrap_angle(a.theta - b.theta)};
}

/// Value at index round(q n) of the sorted values (clamped), as Censi's solver picks its threshold.
double quantile_threshold(std::vector<double> values, double q) {
  std::sort(values.begin(), values.end());
  const double pos = std::round(q * static_cast<double>(values.size()));
  std::size_t index = pos <= 0.0 ? 0 : static_cast<std::size_t>(pos);
  index = std::min(index, values.size() - 1);
  return values[index];
}

std::size_t count(const std::vector<bool>& use) {
  return static_cast<std::size_t>(std::count(use.begin(), use.end(), true));
}

}  // namespace

Pose2 differential_drive_motion(double radius_left, double radius_right, double axle, double T,
                                double phi_left, double phi_right) {
  const double v = 0.5 * (radius_left * phi_left + radius_right * phi_right);
  const double omega = (-radius_left * phi_left + radius_right * phi_right) / axle;
  const double o_theta = omega * T;
  double f1 = 1.0, f2 = 0.0;
  arc_factors(o_theta, f1, f2);
  return {v * T * f1, v * T * f2, o_theta};
}

Pose2 predicted_laser_motion(const OdometryLaserParams& params, const CalibrationTuple& tuple) {
  const Pose2 r = differential_drive_motion(params.radius_left, params.radius_right, params.axle,
                                            tuple.T, tuple.phi_left, tuple.phi_right);
  return params.laser.ominus().oplus(r).oplus(params.laser);  // Liu et al. 2022, eq. 14
}

Matrix6d odometry_laser_information(const std::vector<CalibrationTuple>& tuples,
                                    const OdometryLaserParams& params,
                                    const Vector3d& laser_noise_std) {
  PLUMB_CHECK(laser_noise_std.allFinite() && laser_noise_std.minCoeff() > 0.0,
              "odometry_laser_information: noise std must be finite and positive, got "
                  << laser_noise_std.transpose());
  const Vector6d p0 = params.vector();
  // Central differences with a step relative to each parameter's scale (at least 1 cm / 1 rad).
  Vector6d step;
  for (int j = 0; j < 6; ++j) step(j) = 1e-6 * std::max(std::abs(p0(j)), 1e-2);
  const Vector3d w = laser_noise_std.cwiseInverse().cwiseAbs2();
  Matrix6d fim = Matrix6d::Zero();
  for (const CalibrationTuple& t : tuples) {
    Eigen::Matrix<double, 3, 6> J;
    for (int j = 0; j < 6; ++j) {
      Vector6d plus = p0, minus = p0;
      plus(j) += step(j);
      minus(j) -= step(j);
      const Pose2 sp = predicted_laser_motion(OdometryLaserParams::from_vector(plus), t);
      const Pose2 sm = predicted_laser_motion(OdometryLaserParams::from_vector(minus), t);
      J.col(j) = Vector3d(sp.x - sm.x, sp.y - sm.y, sp.theta - sm.theta) / (2.0 * step(j));
    }
    fim += J.transpose() * w.asDiagonal() * J;
  }
  return fim;
}

OdometryLaserCalibrationResult calibrate_odometry_laser(const std::vector<CalibrationTuple>& tuples,
                                                        const OdometryLaserCalibrationSettings& settings) {
  PLUMB_CHECK(settings.outlier_iterations >= 0,
              "calibrate_odometry_laser: outlier_iterations must be >= 0, got " << settings.outlier_iterations);
  PLUMB_CHECK(settings.outlier_quantile > 0.0 && settings.outlier_quantile <= 1.0,
              "calibrate_odometry_laser: outlier_quantile must be in (0, 1], got " << settings.outlier_quantile);
  for (std::size_t k = 0; k < tuples.size(); ++k) {
    const CalibrationTuple& t = tuples[k];
    PLUMB_CHECK(std::isfinite(t.T) && t.T > 0.0,
                "calibrate_odometry_laser: tuple " << k << " has interval T = " << t.T << " (must be > 0)");
    PLUMB_CHECK(std::isfinite(t.phi_left) && std::isfinite(t.phi_right) &&
                    t.laser_motion.vector().allFinite(),
                "calibrate_odometry_laser: tuple " << k << " has a non-finite field");
  }

  OdometryLaserCalibrationResult result;
  result.num_tuples = tuples.size();
  result.inlier.assign(tuples.size(), false);
  const std::size_t min_tuples = std::max<std::size_t>(settings.min_tuples, 3);
  if (tuples.size() < min_tuples) {
    result.status = Status::kInsufficientData;
    return result;
  }

  std::vector<bool> use(tuples.size(), true);
  std::vector<std::vector<bool>> history;  // the tuple set before each solve
  SolveOutcome last;
  for (int round = 0; round <= settings.outlier_iterations; ++round) {
    history.push_back(use);
    if (count(use) < min_tuples) {
      result.status = Status::kInsufficientData;
      return result;
    }
    last = solve_two_steps(tuples, use, settings);
    ++result.solves;
    result.condition_number = last.condition_number;
    if (last.status != Status::kOk) {
      result.status = last.status;
      return result;
    }
    if (round == settings.outlier_iterations) break;
    // Drop the tuples above the quantile of translation or angle residual.
    std::vector<std::size_t> index;
    std::vector<double> err_xy, err_theta;
    for (std::size_t k = 0; k < tuples.size(); ++k) {
      if (!use[k]) continue;
      const Vector3d e = disagreement(last.params, tuples[k]);
      index.push_back(k);
      err_xy.push_back(std::hypot(e(0), e(1)));
      err_theta.push_back(std::abs(e(2)));
    }
    const double thr_xy = quantile_threshold(err_xy, settings.outlier_quantile);
    const double thr_theta = quantile_threshold(err_theta, settings.outlier_quantile);
    for (std::size_t i = 0; i < index.size(); ++i) {
      if (err_xy[i] > thr_xy || err_theta[i] > thr_theta) use[index[i]] = false;
    }
  }

  result.params = last.params;
  result.j21 = last.j21;
  result.j22 = last.j22;
  result.inlier = use;
  result.num_inliers = count(use);

  // Scan-matcher noise from the residuals ŝ - s(params) of the set after noise_estimate_round rounds.
  const int noise_round = std::clamp(settings.noise_estimate_round, 0, settings.outlier_iterations);
  const std::vector<bool>& noise_set = history[static_cast<std::size_t>(noise_round)];
  std::vector<Vector3d> res;
  Vector3d mean = Vector3d::Zero();
  for (std::size_t k = 0; k < tuples.size(); ++k) {
    if (!noise_set[k]) continue;
    const Pose2 s = predicted_laser_motion(result.params, tuples[k]);
    const Vector3d e(tuples[k].laser_motion.x - s.x, tuples[k].laser_motion.y - s.y,
                     wrap_angle(tuples[k].laser_motion.theta - s.theta));
    res.push_back(e);
    mean += e;
  }
  mean /= static_cast<double>(res.size());
  Vector3d var = Vector3d::Zero();
  for (const Vector3d& e : res) var += (e - mean).cwiseAbs2();
  var /= static_cast<double>(res.size() - 1);
  // A perfectly consistent data set (synthetic, noise-free) would give σ = 0; floor it so the
  // information stays finite (the covariance is then ~0, as it should be).
  const Vector3d floor(1e-12, 1e-12, 1e-12);
  result.laser_noise_std = var.cwiseSqrt().cwiseMax(floor);

  std::vector<CalibrationTuple> used;
  used.reserve(result.num_inliers);
  for (std::size_t k = 0; k < tuples.size(); ++k)
    if (use[k]) used.push_back(tuples[k]);
  const Matrix6d fim = odometry_laser_information(used, result.params, result.laser_noise_std);
  // Invert in the scale of the parameters (unit-diagonal information) so a radius [m] and an angle
  // [rad] compare; a tiny scaled eigenvalue means some direction of the parameters is not informed.
  const Vector6d diag = fim.diagonal();
  if (!(diag.minCoeff() > 0.0) || !diag.allFinite()) {
    result.status = Status::kDegenerate;
    result.params = {};
    return result;
  }
  const Vector6d inv_sqrt = diag.cwiseSqrt().cwiseInverse();
  const Matrix6d scaled = inv_sqrt.asDiagonal() * fim * inv_sqrt.asDiagonal();
  const Eigen::SelfAdjointEigenSolver<Matrix6d> eig(scaled);
  const Vector6d ev = eig.eigenvalues();
  if (!(ev(0) > 1e-12)) {
    result.status = Status::kDegenerate;
    result.params = {};
    return result;
  }
  const Matrix6d scaled_inv = eig.eigenvectors() * ev.cwiseInverse().asDiagonal() * eig.eigenvectors().transpose();
  const Matrix6d covariance = inv_sqrt.asDiagonal() * scaled_inv * inv_sqrt.asDiagonal();
  result.covariance = 0.5 * (covariance + covariance.transpose());
  result.status = Status::kOk;
  return result;
}

}  // namespace plumb
