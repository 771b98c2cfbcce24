// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/imu/preintegration.hpp"

#include <algorithm>
#include <cmath>

#include <Eigen/Cholesky>

#include "plumb/core/error.hpp"

#include "core/eigen_instantiations.hpp"

namespace plumb {

namespace imu_detail {
namespace {

// Below this angle the hold-interval coefficients use their Taylor series (4 terms: the truncation
// and the closed forms' cancellation are both below 1e-11 relative there).
constexpr double kSeriesAngle = 0.25;

// Coefficients of Gamma1 = I + c1 K + c2 K^2 and Gamma2 = I/2 + c2 K + c3 K^2 (K = hat(phi),
// t = |phi|), and d c / dt divided by t, for the derivatives of Gamma a w.r.t. phi.
struct HoldCoefficients {
  double c1, c2, c3;        // (1-cos t)/t^2, (t-sin t)/t^3, (t^2/2+cos t-1)/t^4
  double d1, d2, d3;        // c1'(t)/t, c2'(t)/t, c3'(t)/t
};

HoldCoefficients hold_coefficients(double t) {
  HoldCoefficients h{};
  const double t2 = t * t;
  if (t < kSeriesAngle) {
    const double t4 = t2 * t2, t6 = t4 * t2;
    h.c1 = 1.0 / 2.0 - t2 / 24.0 + t4 / 720.0 - t6 / 40320.0;
    h.c2 = 1.0 / 6.0 - t2 / 120.0 + t4 / 5040.0 - t6 / 362880.0;
    h.c3 = 1.0 / 24.0 - t2 / 720.0 + t4 / 40320.0 - t6 / 3628800.0;
    h.d1 = -1.0 / 12.0 + t2 / 180.0 - t4 / 6720.0 + t6 / 453600.0;
    h.d2 = -1.0 / 60.0 + t2 / 1260.0 - t4 / 60480.0 + t6 / 4989600.0;
    h.d3 = -1.0 / 360.0 + t2 / 10080.0 - t4 / 604800.0 + t6 / 59875200.0;
    return h;
  }
  const double s = std::sin(t), c = std::cos(t);
  const double t3 = t2 * t, t4 = t2 * t2, t5 = t4 * t, t6 = t4 * t2;
  h.c1 = (1.0 - c) / t2;
  h.c2 = (t - s) / t3;
  h.c3 = (0.5 * t2 + c - 1.0) / t4;
  h.d1 = (t * s - 2.0 * (1.0 - c)) / t4;
  h.d2 = (1.0 - c) / t4 - 3.0 * (t - s) / t5;
  h.d3 = (t - s) / t5 - 4.0 * (0.5 * t2 + c - 1.0) / t6;
  return h;
}

// d/dphi [alpha(t) phi x a + beta(t) phi x (phi x a)], with alpha'/t = da, beta'/t = db.
Matrix3d d_series_a(const Vector3d& phi, const Vector3d& a, double alpha, double beta, double da,
                           double db) {
  const Vector3d pxa = phi.cross(a);
  const Vector3d pxpxa = phi.cross(pxa);
  Matrix3d M = -alpha * hat(a) + (da * pxa) * phi.transpose() + (db * pxpxa) * phi.transpose();
  M += beta * (phi.dot(a) * Matrix3d::Identity() + phi * a.transpose() - 2.0 * a * phi.transpose());
  return M;
}

bool finite3(const Vector3d& v) { return std::isfinite(v.x()) && std::isfinite(v.y()) && std::isfinite(v.z()); }

}  // namespace
}  // namespace imu_detail

ImuState retract(const ImuState& x, const Vector15d& delta) {
  ImuState y;
  y.R_world_body = x.R_world_body * so3::exp(delta.segment<3>(ImuTangent::kR));
  y.p_world_body = x.p_world_body + delta.segment<3>(ImuTangent::kP);
  y.v_world = x.v_world + delta.segment<3>(ImuTangent::kV);
  y.bias.gyro = x.bias.gyro + delta.segment<3>(ImuTangent::kBg);
  y.bias.accel = x.bias.accel + delta.segment<3>(ImuTangent::kBa);
  return y;
}

ImuPreintegration::ImuPreintegration(const ImuBias& bias_hat, const PreintegrationSettings& settings)
    : settings_(settings), bias_hat_(bias_hat) {
  const ImuNoise& n = settings.noise;
  PLUMB_CHECK(n.gyro_noise_density >= 0.0 && n.accel_noise_density >= 0.0 && n.gyro_bias_random_walk >= 0.0 &&
                  n.accel_bias_random_walk >= 0.0 && std::isfinite(n.gyro_noise_density) &&
                  std::isfinite(n.accel_noise_density) && std::isfinite(n.gyro_bias_random_walk) &&
                  std::isfinite(n.accel_bias_random_walk),
              "ImuPreintegration: noise densities must be finite and not negative");
  PLUMB_CHECK(imu_detail::finite3(settings.g_world), "ImuPreintegration: g_world is not finite");
  PLUMB_CHECK(settings.max_gap > 0.0, "ImuPreintegration: max_gap must be positive, got " << settings.max_gap);
  PLUMB_CHECK(imu_detail::finite3(bias_hat.gyro) && imu_detail::finite3(bias_hat.accel),
              "ImuPreintegration: bias is not finite");
}

void ImuPreintegration::reset(const ImuBias& bias_hat) {
  PLUMB_CHECK(imu_detail::finite3(bias_hat.gyro) && imu_detail::finite3(bias_hat.accel),
              "ImuPreintegration::reset: bias is not finite");
  *this = ImuPreintegration(bias_hat, settings_);
}

void ImuPreintegration::add_measurement(const Vector3d& gyro, const Vector3d& accel, double dt) {
  PLUMB_CHECK(dt > 0.0 && std::isfinite(dt), "ImuPreintegration::add_measurement: dt must be positive, got " << dt);
  PLUMB_CHECK(imu_detail::finite3(gyro) && imu_detail::finite3(accel),
              "ImuPreintegration::add_measurement: measurement is not finite");
  using imu_detail::d_series_a;
  const Vector3d phi = (gyro - bias_hat_.gyro) * dt;
  const Vector3d a = accel - bias_hat_.accel;
  const double t = phi.norm();
  const imu_detail::HoldCoefficients h = imu_detail::hold_coefficients(t);
  const Matrix3d K = hat(phi);
  const Matrix3d K2 = K * K;
  const Matrix3d E = Matrix3d::Identity() + (1.0 - t * t * h.c2) * K + h.c1 * K2;  // exp(phi)
  const Matrix3d G1 = Matrix3d::Identity() + h.c1 * K + h.c2 * K2;                 // J_l(phi)
  const Matrix3d G2 = 0.5 * Matrix3d::Identity() + h.c2 * K + h.c3 * K2;
  const Matrix3d Jr = Matrix3d::Identity() - h.c1 * K + h.c2 * K2;                 // J_r(phi)
  const Vector3d G1a = G1 * a, G2a = G2 * a;
  const Matrix3d M1 = d_series_a(phi, a, h.c1, h.c2, h.d1, h.d2);  // d(G1 a)/dphi
  const Matrix3d M2 = d_series_a(phi, a, h.c2, h.c3, h.d2, h.d3);  // d(G2 a)/dphi

  const double dt2 = dt * dt, dt3 = dt2 * dt;
  const Matrix3d& R = delta_R_;  // Delta R_ik, before the update
  const Matrix3d RG1 = R * G1, RG2 = R * G2;
  const Matrix3d R_hat_G1a = R * hat(G1a), R_hat_G2a = R * hat(G2a);
  const Matrix3d RM1 = R * M1, RM2 = R * M2;

  // Error-state transition A (order dphi, dp, dv, dbg, dba) and noise maps, from
  // dphi' = E^T dphi + Jr dtheta, dv' = dv - R hat(G1 a) dt dphi + R M1 dt dtheta + R G1 dt da,
  // dp' = dp + dv dt - R hat(G2 a) dt^2 dphi + R M2 dt^2 dtheta + R G2 dt^2 da, dtheta = -dt dbg.
  Matrix15d A = Matrix15d::Identity();
  A.block<3, 3>(0, 0) = E.transpose();
  A.block<3, 3>(0, 9) = -Jr * dt;
  A.block<3, 3>(3, 0) = -R_hat_G2a * dt2;
  A.block<3, 3>(3, 6) = Matrix3d::Identity() * dt;
  A.block<3, 3>(3, 9) = -RM2 * dt3;
  A.block<3, 3>(3, 12) = -RG2 * dt2;
  A.block<3, 3>(6, 0) = -R_hat_G1a * dt;
  A.block<3, 3>(6, 9) = -RM1 * dt2;
  A.block<3, 3>(6, 12) = -RG1 * dt;

  // White noise of one held sample: covariance density^2 / dt (Zhou et al. 2021, eq. 11-12;
  // Forster et al. 2017, eq. 62).
  const ImuNoise& n = settings_.noise;
  const double q_g = n.gyro_noise_density * n.gyro_noise_density / dt;
  const double q_a = n.accel_noise_density * n.accel_noise_density / dt;
  Eigen::Matrix<double, 9, 3> B_g, B_a;
  B_g << Jr * dt, RM2 * dt3, RM1 * dt2;
  B_a << Matrix3d::Zero(), RG2 * dt2, RG1 * dt;
  const Matrix9d Q9 = q_g * B_g * B_g.transpose() + q_a * B_a * B_a.transpose();

  const Matrix9d A9 = A.topLeftCorner<9, 9>();
  cov9_ = A9 * cov9_ * A9.transpose() + Q9;
  cov15_ = A * cov15_ * A.transpose();
  cov15_.topLeftCorner<9, 9>() += Q9;
  cov15_.block<3, 3>(9, 9).diagonal().array() += n.gyro_bias_random_walk * n.gyro_bias_random_walk * dt;
  cov15_.block<3, 3>(12, 12).diagonal().array() += n.accel_bias_random_walk * n.accel_bias_random_walk * dt;

  // Bias Jacobians (Forster appendix B, with the exact hold terms M1, M2): old values on the right.
  J_p_ba_ += J_v_ba_ * dt - RG2 * dt2;
  J_p_bg_ += J_v_bg_ * dt - R_hat_G2a * dt2 * J_R_bg_ - RM2 * dt3;
  J_v_ba_ -= RG1 * dt;
  J_v_bg_ -= R_hat_G1a * dt * J_R_bg_ + RM1 * dt2;
  J_R_bg_ = E.transpose() * J_R_bg_ - Jr * dt;

  // Means (Zhou et al. 2021, eq. 16-18, with the exact hold integrals).
  delta_p_ += delta_v_ * dt + R * G2a * dt2;
  delta_v_ += R * G1a * dt;
  delta_R_ = delta_R_ * E;
  delta_t_ += dt;
  ++num_measurements_;
}

Status ImuPreintegration::integrate(const std::vector<ImuSample>& samples, double t0, double t1) {
  PLUMB_CHECK(std::isfinite(t0) && std::isfinite(t1),
              "ImuPreintegration::integrate: interval [" << t0 << ", " << t1 << "] is not finite");
  PLUMB_CHECK(t1 >= t0, "ImuPreintegration::integrate: interval end " << t1 << " before its start " << t0);
  if (samples.empty()) return Status::kInsufficientData;
  if (t1 == t0) return Status::kOk;
  const std::size_t n = samples.size();
  // lo: last sample at or before t0 (0 when none); hi: first sample at or after t1 (n-1 when none).
  const auto first_after_t0 = std::upper_bound(samples.begin(), samples.end(), t0,
                                               [](double t, const ImuSample& s) { return t < s.stamp; });
  const auto first_from_t1 = std::lower_bound(samples.begin(), samples.end(), t1,
                                              [](const ImuSample& s, double t) { return s.stamp < t; });
  const std::size_t lo =
      first_after_t0 == samples.begin() ? 0 : static_cast<std::size_t>(first_after_t0 - samples.begin()) - 1;
  const std::size_t hi =
      first_from_t1 == samples.end() ? n - 1 : static_cast<std::size_t>(first_from_t1 - samples.begin());
  if (hi < lo) return Status::kInvalidInput;  // only possible when the stamps are not sorted

  const double max_gap = settings_.max_gap;
  for (std::size_t k = lo; k <= hi; ++k) {
    const ImuSample& s = samples[k];
    if (!std::isfinite(s.stamp) || !imu_detail::finite3(s.gyro) || !imu_detail::finite3(s.accel)) {
      return Status::kInvalidInput;
    }
    if (k > lo) {
      const double gap = s.stamp - samples[k - 1].stamp;
      if (!(gap > 0.0)) return Status::kInvalidInput;
      if (gap > max_gap) return Status::kInsufficientData;
    }
  }
  if (samples[lo].stamp > t0 + max_gap || samples[hi].stamp < t1 - max_gap) return Status::kInsufficientData;

  // Measurement at t0: interpolated between the samples around it, else the nearest one held.
  Vector3d gyro = samples[lo].gyro, accel = samples[lo].accel;
  if (samples[lo].stamp < t0 && lo + 1 <= hi && samples[lo + 1].stamp > t0) {
    const ImuSample& a = samples[lo];
    const ImuSample& b = samples[lo + 1];
    const double u = (t0 - a.stamp) / (b.stamp - a.stamp);
    gyro = (1.0 - u) * a.gyro + u * b.gyro;
    accel = (1.0 - u) * a.accel + u * b.accel;
  }
  double tau = t0;
  for (std::size_t k = lo + 1; k <= hi && samples[k].stamp < t1; ++k) {
    if (samples[k].stamp <= tau) continue;
    add_measurement(gyro, accel, samples[k].stamp - tau);
    tau = samples[k].stamp;
    gyro = samples[k].gyro;
    accel = samples[k].accel;
  }
  if (t1 > tau) add_measurement(gyro, accel, t1 - tau);
  return Status::kOk;
}

Matrix15d ImuPreintegration::sqrt_information_with_bias() const {
  // cov = L L^T  =>  cov^-1 = L^-T L^-1, so U = L^-1 (lower triangular) satisfies U^T U = cov^-1.
  const Eigen::LLT<Matrix15d> llt(cov15_);
  PLUMB_CHECK(llt.info() == Eigen::Success && cov15_.diagonal().minCoeff() > 0.0,
              "ImuPreintegration::sqrt_information_with_bias: covariance is not positive definite "
              "(zero noise densities or nothing integrated)");
  Matrix15d L_inv = Matrix15d::Identity();
  llt.matrixL().solveInPlace(L_inv);
  return L_inv;
}

Matrix3d ImuPreintegration::delta_R_ij_corrected(const ImuBias& bias) const {
  return delta_R_ * so3::exp(J_R_bg_ * (bias.gyro - bias_hat_.gyro));
}

Vector3d ImuPreintegration::delta_v_ij_corrected(const ImuBias& bias) const {
  return delta_v_ + J_v_bg_ * (bias.gyro - bias_hat_.gyro) + J_v_ba_ * (bias.accel - bias_hat_.accel);
}

Vector3d ImuPreintegration::delta_p_ij_corrected(const ImuBias& bias) const {
  return delta_p_ + J_p_bg_ * (bias.gyro - bias_hat_.gyro) + J_p_ba_ * (bias.accel - bias_hat_.accel);
}

ImuState ImuPreintegration::predict(const ImuState& state_i) const {
  const Vector3d& g = settings_.g_world;
  const double dt = delta_t_;
  const Matrix3d& R_i = state_i.R_world_body;
  ImuState j;
  j.R_world_body = R_i * delta_R_ij_corrected(state_i.bias);
  j.v_world = state_i.v_world + g * dt + R_i * delta_v_ij_corrected(state_i.bias);
  j.p_world_body = state_i.p_world_body + state_i.v_world * dt + 0.5 * g * dt * dt +
                   R_i * delta_p_ij_corrected(state_i.bias);
  j.bias = state_i.bias;
  return j;
}

ImuFactorResidual ImuPreintegration::residual(const ImuState& state_i, const ImuState& state_j) const {
  constexpr int kR = ImuTangent::kR, kP = ImuTangent::kP, kV = ImuTangent::kV, kBg = ImuTangent::kBg,
                kBa = ImuTangent::kBa;
  const Vector3d& g = settings_.g_world;
  const double dt = delta_t_;
  const Matrix3d& R_i = state_i.R_world_body;
  const Matrix3d& R_j = state_j.R_world_body;
  const Matrix3d Rt_i = R_i.transpose();
  const Vector3d dbg = state_i.bias.gyro - bias_hat_.gyro;
  const Vector3d dba = state_i.bias.accel - bias_hat_.accel;
  const Vector3d phi_b = J_R_bg_ * dbg;
  const Matrix3d dR = delta_R_ * so3::exp(phi_b);
  const Vector3d dv = delta_v_ + J_v_bg_ * dbg + J_v_ba_ * dba;
  const Vector3d dp = delta_p_ + J_p_bg_ * dbg + J_p_ba_ * dba;

  // Forster eq. 45 (in the order R, p, v), plus the bias random walk.
  const Vector3d v_rel = Rt_i * (state_j.v_world - state_i.v_world - g * dt);
  const Vector3d p_rel =
      Rt_i * (state_j.p_world_body - state_i.p_world_body - state_i.v_world * dt - 0.5 * g * dt * dt);
  ImuFactorResidual out;
  const Vector3d r_R = so3::log(dR.transpose() * Rt_i * R_j);
  out.r.segment<3>(kR) = r_R;
  out.r.segment<3>(kP) = p_rel - dp;
  out.r.segment<3>(kV) = v_rel - dv;
  out.r.segment<3>(kBg) = state_j.bias.gyro - state_i.bias.gyro;
  out.r.segment<3>(kBa) = state_j.bias.accel - state_i.bias.accel;

  // Forster appendix C, for right perturbations of R and world-frame additive p, v.
  const Matrix3d Jr_inv = so3::right_jacobian_inverse(r_R);
  const Matrix3d I = Matrix3d::Identity();
  Matrix15d& Ji = out.J_r_xi_i;
  Matrix15d& Jj = out.J_r_xi_j;
  Ji.block<3, 3>(kR, kR) = -Jr_inv * R_j.transpose() * R_i;
  Ji.block<3, 3>(kR, kBg) = -Jr_inv * so3::exp(r_R).transpose() * so3::right_jacobian(phi_b) * J_R_bg_;
  Ji.block<3, 3>(kP, kR) = hat(p_rel);
  Ji.block<3, 3>(kP, kP) = -Rt_i;
  Ji.block<3, 3>(kP, kV) = -Rt_i * dt;
  Ji.block<3, 3>(kP, kBg) = -J_p_bg_;
  Ji.block<3, 3>(kP, kBa) = -J_p_ba_;
  Ji.block<3, 3>(kV, kR) = hat(v_rel);
  Ji.block<3, 3>(kV, kV) = -Rt_i;
  Ji.block<3, 3>(kV, kBg) = -J_v_bg_;
  Ji.block<3, 3>(kV, kBa) = -J_v_ba_;
  Ji.block<3, 3>(kBg, kBg) = -I;
  Ji.block<3, 3>(kBa, kBa) = -I;
  Jj.block<3, 3>(kR, kR) = Jr_inv;
  Jj.block<3, 3>(kP, kP) = Rt_i;
  Jj.block<3, 3>(kV, kV) = Rt_i;
  Jj.block<3, 3>(kBg, kBg) = I;
  Jj.block<3, 3>(kBa, kBa) = I;
  return out;
}

}  // namespace plumb
