// SPDX-License-Identifier: BSD-3-Clause
// IMU preintegration: analytic motions without noise (constant rates, constant acceleration,
// circles at constant speed), bias Jacobians and factor Jacobians against central differences,
// first-order bias correction against re-integration, covariance against Monte Carlo, bad input.
#include <cmath>
#include <limits>
#include <vector>

#include <gtest/gtest.h>

#include "plumb/core/error.hpp"
#include "plumb/core/lie.hpp"
#include "plumb/core/rng.hpp"
#include "plumb/imu/imu.hpp"
#include "plumb/imu/preintegration.hpp"

namespace plumb {
namespace {


Vector3d normal3(Rng& rng, double sigma = 1.0) {
  const double x = rng.normal(), y = rng.normal(), z = rng.normal();
  return sigma * Vector3d(x, y, z);
}

// Samples of constant gyro/accel at `rate` Hz with jittered stamps, covering [t0 - 0.02, t1 + 0.02].
std::vector<ImuSample> constant_samples(const Vector3d& gyro, const Vector3d& accel, double t0, double t1,
                                        double rate, Rng& rng) {
  std::vector<ImuSample> out;
  const double dt = 1.0 / rate;
  for (double t = t0 - 0.02; t < t1 + 0.02 + dt; t += dt) {
    out.push_back({t + rng.uniform(-0.2, 0.2) * dt, gyro, accel});
  }
  return out;
}

PreintegrationSettings no_gravity() {
  PreintegrationSettings s;
  s.g_world = Vector3d::Zero();
  return s;
}

TEST(ImuPreintegrationTest, ConstantRateRotatesAboutTheAxis) {
  // Rotation about a fixed axis at constant rate: Delta R = AngleAxis(|w| T, w/|w|); a specific
  // force parallel to the axis stays constant in the world, so Delta v = a T, Delta p = a T^2/2.
  Rng rng(1);
  const Vector3d axis = Vector3d(0.3, -0.5, 0.8).normalized();
  const double rate = 1.3, T = 2.7;
  const Vector3d accel = 0.9 * axis;
  const auto samples = constant_samples(rate * axis, accel, 0.1, 0.1 + T, 200.0, rng);
  ImuPreintegration pim;
  ASSERT_EQ(pim.integrate(samples, 0.1, 0.1 + T), Status::kOk);
  EXPECT_NEAR(pim.delta_t(), T, 1e-12);
  const Matrix3d R_ref = Eigen::AngleAxisd(rate * T, axis).toRotationMatrix();
  EXPECT_LT((pim.delta_R_ij() - R_ref).norm(), 1e-9);
  EXPECT_LT((pim.delta_v_ij() - accel * T).norm(), 1e-9);
  EXPECT_LT((pim.delta_p_ij() - 0.5 * accel * T * T).norm(), 1e-9);
}

TEST(ImuPreintegrationTest, ConstantAccelerationWithGravity) {
  // Level body, no rotation, world acceleration a: the accelerometer reads a - g.
  Rng rng(2);
  const Vector3d a_world(0.7, -0.4, 0.25), v0(1.0, 2.0, -0.5), p0(3.0, -1.0, 2.0);
  const double T = 1.9;
  PreintegrationSettings settings;  // g = (0, 0, -9.80665)
  const auto samples = constant_samples(Vector3d::Zero(), a_world - settings.g_world, 5.0, 5.0 + T, 100.0, rng);
  ImuPreintegration pim({}, settings);
  ASSERT_EQ(pim.integrate(samples, 5.0, 5.0 + T), Status::kOk);
  ImuState s0;
  s0.p_world_body = p0;
  s0.v_world = v0;
  const ImuState s1 = pim.predict(s0);
  EXPECT_LT((s1.R_world_body - Matrix3d::Identity()).norm(), 1e-12);
  EXPECT_LT((s1.v_world - (v0 + a_world * T)).norm(), 1e-9);
  EXPECT_LT((s1.p_world_body - (p0 + v0 * T + 0.5 * a_world * T * T)).norm(), 1e-9);
}

TEST(ImuPreintegrationTest, LevelCircleAtConstantSpeed) {
  // Heading along the track on a circle of radius r at speed s (left turn): yaw rate s/r, the
  // accelerometer reads the centripetal s^2/r along body +y and +g along body z.
  Rng rng(3);
  const double r = 4.0, s = 1.5, w = s / r;
  const double yaw0 = 0.7;
  PreintegrationSettings settings;
  const double g = -settings.g_world.z();
  for (double T : {0.5, 3.0, 2.0 * kPi / w}) {  // up to one full lap
    const auto samples = constant_samples(Vector3d(0, 0, w), Vector3d(0, s * s / r, g), 0.0, T, 200.0, rng);
    ImuPreintegration pim({}, settings);
    ASSERT_EQ(pim.integrate(samples, 0.0, T), Status::kOk);
    const Matrix3d Rz0 = Eigen::AngleAxisd(yaw0, Vector3d::UnitZ()).toRotationMatrix();
    ImuState s0;
    s0.R_world_body = Rz0;
    s0.p_world_body = Vector3d(1.0, 2.0, 3.0);
    s0.v_world = Rz0 * Vector3d(s, 0, 0);
    const ImuState s1 = pim.predict(s0);
    const Vector3d p_rel(r * std::sin(w * T), r * (1.0 - std::cos(w * T)), 0.0);
    const Vector3d v_rel(s * std::cos(w * T), s * std::sin(w * T), 0.0);
    const Matrix3d R_ref = Eigen::AngleAxisd(yaw0 + w * T, Vector3d::UnitZ()).toRotationMatrix();
    EXPECT_LT((s1.R_world_body - R_ref).norm(), 1e-9) << "T " << T;
    EXPECT_LT((s1.p_world_body - (s0.p_world_body + Rz0 * p_rel)).norm(), 1e-9) << "T " << T;
    EXPECT_LT((s1.v_world - Rz0 * v_rel).norm(), 1e-9) << "T " << T;
  }
}

TEST(ImuPreintegrationTest, TiltedCircleWithoutGravityAndFastTurn) {
  // The same circle in a plane of any orientation (gravity off so that the body-frame specific force
  // stays constant), with a fast turn (2 rad per sample interval at 10 Hz: the closed forms, not the series).
  Rng rng(4);
  const Matrix3d R0 = so3::exp(Vector3d(0.4, -1.1, 0.6));
  for (double w : {0.3, 20.0}) {
    const double r = 2.0, s = w * r, T = 1.3;
    const auto samples = constant_samples(Vector3d(0, 0, w), Vector3d(0, s * s / r, 0), 0.0, T, 10.0, rng);
    PreintegrationSettings settings = no_gravity();
    settings.max_gap = 0.2;  // 10 Hz samples
    ImuPreintegration pim({}, settings);
    ASSERT_EQ(pim.integrate(samples, 0.0, T), Status::kOk);
    ImuState s0;
    s0.R_world_body = R0;
    s0.v_world = R0 * Vector3d(s, 0, 0);
    const ImuState s1 = pim.predict(s0);
    const Vector3d p_rel(r * std::sin(w * T), r * (1.0 - std::cos(w * T)), 0.0);
    const Vector3d v_rel(s * std::cos(w * T), s * std::sin(w * T), 0.0);
    const double scale = std::max(1.0, s);
    EXPECT_LT((s1.R_world_body - R0 * Eigen::AngleAxisd(w * T, Vector3d::UnitZ()).toRotationMatrix()).norm(), 1e-9);
    EXPECT_LT((s1.p_world_body - R0 * p_rel).norm(), 1e-9 * scale) << "w " << w;
    EXPECT_LT((s1.v_world - R0 * v_rel).norm(), 1e-9 * scale) << "w " << w;
  }
}

TEST(ImuPreintegrationTest, InterpolatesAtTheIntervalStartAndHoldsEachSample) {
  // Yaw rate ramping 0, 1, 2, 3 rad/s at t = 0, 1, 2, 3. Over [0.5, 2.5]: 0.5 (interpolated) held
  // 0.5 s, 1 held 1 s, 2 held 0.5 s -> yaw 0.25 + 1 + 1 = 2.25 rad.
  std::vector<ImuSample> samples;
  for (int k = 0; k < 4; ++k) samples.push_back({double(k), Vector3d(0, 0, k), Vector3d::Zero()});
  PreintegrationSettings settings = no_gravity();
  settings.max_gap = 1.5;
  ImuPreintegration pim({}, settings);
  ASSERT_EQ(pim.integrate(samples, 0.5, 2.5), Status::kOk);
  EXPECT_EQ(pim.num_measurements(), 3u);
  EXPECT_NEAR(so3::log(pim.delta_R_ij()).z(), 2.25, 1e-12);
  // Appending [2.5, 3]: the rate interpolated at 2.5 (2.5 rad/s) held for 0.5 s.
  ASSERT_EQ(pim.integrate(samples, 2.5, 3.0), Status::kOk);
  EXPECT_LT((pim.delta_R_ij() - Eigen::AngleAxisd(3.5, Vector3d::UnitZ()).toRotationMatrix()).norm(), 1e-12);
  EXPECT_NEAR(pim.delta_t(), 2.5, 1e-12);
}

// Random, non-constant measurements of a moving body (rates up to ~1 rad/s, forces ~ g).
struct Sequence {
  std::vector<Vector3d> gyro, accel;
  double dt = 0.005;
};

Sequence random_sequence(std::uint64_t seed, int n) {
  Rng rng(seed);
  Sequence s;
  Vector3d w = normal3(rng, 0.5), a = Vector3d(0, 0, 9.8) + normal3(rng, 1.0);
  for (int k = 0; k < n; ++k) {
    w += normal3(rng, 0.05);
    a += normal3(rng, 0.2);
    s.gyro.push_back(w);
    s.accel.push_back(a);
  }
  return s;
}

ImuPreintegration integrate_sequence(const Sequence& seq, const ImuBias& bias,
                                     const PreintegrationSettings& settings = {}) {
  ImuPreintegration pim(bias, settings);
  for (std::size_t k = 0; k < seq.gyro.size(); ++k) pim.add_measurement(seq.gyro[k], seq.accel[k], seq.dt);
  return pim;
}

double rel_error(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) {
  return (a - b).norm() / std::max(1e-12, b.norm());
}

TEST(ImuPreintegrationTest, BiasJacobiansMatchCentralDifferences) {
  const Sequence seq = random_sequence(11, 300);
  ImuBias b0;
  b0.gyro = Vector3d(0.01, -0.02, 0.015);
  b0.accel = Vector3d(0.05, 0.02, -0.08);
  const ImuPreintegration pim = integrate_sequence(seq, b0);
  Matrix3d nR_bg, nv_bg, nv_ba, np_bg, np_ba;
  const double eps = 1e-6;
  for (int c = 0; c < 3; ++c) {
    for (int which = 0; which < 2; ++which) {
      ImuBias plus = b0, minus = b0;
      (which == 0 ? plus.gyro : plus.accel)(c) += eps;
      (which == 0 ? minus.gyro : minus.accel)(c) -= eps;
      const ImuPreintegration p = integrate_sequence(seq, plus), m = integrate_sequence(seq, minus);
      const Vector3d dv = (p.delta_v_ij() - m.delta_v_ij()) / (2 * eps);
      const Vector3d dp = (p.delta_p_ij() - m.delta_p_ij()) / (2 * eps);
      if (which == 0) {
        nR_bg.col(c) = (so3::log(pim.delta_R_ij().transpose() * p.delta_R_ij()) -
                        so3::log(pim.delta_R_ij().transpose() * m.delta_R_ij())) / (2 * eps);
        nv_bg.col(c) = dv;
        np_bg.col(c) = dp;
      } else {
        EXPECT_LT((p.delta_R_ij() - m.delta_R_ij()).norm(), 1e-15);  // accel bias does not rotate
        nv_ba.col(c) = dv;
        np_ba.col(c) = dp;
      }
    }
  }
  EXPECT_LT(rel_error(pim.J_R_bg(), nR_bg), 1e-6);
  EXPECT_LT(rel_error(pim.J_v_bg(), nv_bg), 1e-6);
  EXPECT_LT(rel_error(pim.J_v_ba(), nv_ba), 1e-6);
  EXPECT_LT(rel_error(pim.J_p_bg(), np_bg), 1e-6);
  EXPECT_LT(rel_error(pim.J_p_ba(), np_ba), 1e-6);
}

TEST(ImuPreintegrationTest, FirstOrderBiasUpdateErrorIsSecondOrder) {
  const Sequence seq = random_sequence(12, 400);
  const ImuPreintegration pim = integrate_sequence(seq, {});
  Rng rng(5);
  const Vector3d dir_g = normal3(rng).normalized(), dir_a = normal3(rng).normalized();
  double prev_err = 0.0;
  for (double h : {4e-3, 2e-3, 1e-3}) {
    ImuBias b;
    b.gyro = h * dir_g;
    b.accel = 10.0 * h * dir_a;
    const ImuPreintegration re = integrate_sequence(seq, b);
    const double eR = so3::log(re.delta_R_ij().transpose() * pim.delta_R_ij_corrected(b)).norm();
    const double ev = (re.delta_v_ij() - pim.delta_v_ij_corrected(b)).norm();
    const double ep = (re.delta_p_ij() - pim.delta_p_ij_corrected(b)).norm();
    // The correction captures the change: what remains is far smaller than the change itself.
    const double change_v = (re.delta_v_ij() - pim.delta_v_ij()).norm();
    EXPECT_LT(ev, 0.05 * change_v);
    const double err = eR + ev + ep;
    if (prev_err > 0.0) {
      EXPECT_NEAR(prev_err / err, 4.0, 0.4) << "h " << h;  // halving h quarters a second-order error
    }
    prev_err = err;
  }
}

TEST(ImuPreintegrationTest, FactorJacobiansMatchCentralDifferences) {
  const Sequence seq = random_sequence(13, 200);
  ImuBias bhat;
  bhat.gyro = Vector3d(0.002, 0.001, -0.003);
  const ImuPreintegration pim = integrate_sequence(seq, bhat);
  Rng rng(6);
  for (int trial = 0; trial < 3; ++trial) {
    ImuState xi, xj;
    xi.R_world_body = so3::exp(normal3(rng, 1.0));
    xi.p_world_body = normal3(rng, 3.0);
    xi.v_world = normal3(rng, 1.0);
    xi.bias.gyro = bhat.gyro + normal3(rng, 0.01);
    xi.bias.accel = normal3(rng, 0.05);
    xj = pim.predict(xi);
    Vector15d d;
    for (int k = 0; k < 15; ++k) d(k) = 0.05 * rng.normal();
    xj = retract(xj, d);  // a residual away from zero
    const ImuFactorResidual f = pim.residual(xi, xj);
    EXPECT_GT(f.r.norm(), 1e-3);
    Matrix15d Ni, Nj;
    const double eps = 1e-6;
    for (int k = 0; k < 15; ++k) {
      Vector15d e = Vector15d::Zero();
      e(k) = eps;
      Ni.col(k) = (pim.residual(retract(xi, e), xj).r - pim.residual(retract(xi, -e), xj).r) / (2 * eps);
      Nj.col(k) = (pim.residual(xi, retract(xj, e)).r - pim.residual(xi, retract(xj, -e)).r) / (2 * eps);
    }
    EXPECT_LT(rel_error(f.J_r_xi_i, Ni), 1e-6) << "trial " << trial << "\n" << f.J_r_xi_i - Ni;
    EXPECT_LT(rel_error(f.J_r_xi_j, Nj), 1e-6) << "trial " << trial << "\n" << f.J_r_xi_j - Nj;
  }
}

TEST(ImuPreintegrationTest, ResidualIsZeroAtThePrediction) {
  const Sequence seq = random_sequence(14, 100);
  const ImuPreintegration pim = integrate_sequence(seq, {});
  ImuState xi;
  xi.R_world_body = so3::exp(Vector3d(0.1, 0.2, -0.3));
  xi.v_world = Vector3d(1, 0, 0);
  xi.bias.gyro = Vector3d(0.001, 0, 0);
  EXPECT_LT(pim.residual(xi, pim.predict(xi)).r.norm(), 1e-12);
}

// Monte Carlo: N noisy runs of the same motion; the normalised squared error e^T Sigma^-1 e
// averages to the dimension d (std sqrt(2 d / N)), and the whitened sample covariance is ~ I.
void check_against_monte_carlo(const std::vector<Eigen::VectorXd>& errors, const Eigen::MatrixXd& cov) {
  const int d = static_cast<int>(cov.rows());
  const double n = static_cast<double>(errors.size());
  const Eigen::LLT<Eigen::MatrixXd> llt(cov);
  ASSERT_EQ(llt.info(), Eigen::Success);
  double nees = 0.0;
  Eigen::MatrixXd S = Eigen::MatrixXd::Zero(d, d);
  for (const auto& e : errors) {
    const Eigen::VectorXd w = llt.matrixL().solve(e);
    nees += w.squaredNorm();
    S += w * w.transpose();
  }
  nees /= n;
  S /= n;
  EXPECT_NEAR(nees, d, 4.0 * std::sqrt(2.0 * d / n));
  // Entries of the whitened sample covariance: std ~ 1/sqrt(n) off the diagonal, sqrt(2/n) on it.
  EXPECT_LT((S - Eigen::MatrixXd::Identity(d, d)).cwiseAbs().maxCoeff(), 6.0 * std::sqrt(2.0 / n))
      << S;
}

TEST(ImuPreintegrationTest, CovarianceMatchesMonteCarlo) {
  const Sequence seq = random_sequence(15, 200);  // 1 s at 200 Hz
  PreintegrationSettings settings;
  settings.noise.gyro_noise_density = 2e-3;
  settings.noise.accel_noise_density = 2e-2;
  settings.noise.gyro_bias_random_walk = 1e-3;
  settings.noise.accel_bias_random_walk = 1e-2;
  const ImuPreintegration nominal = integrate_sequence(seq, {}, settings);
  const double sg = settings.noise.gyro_noise_density / std::sqrt(seq.dt);
  const double sa = settings.noise.accel_noise_density / std::sqrt(seq.dt);
  const double wg = settings.noise.gyro_bias_random_walk * std::sqrt(seq.dt);
  const double wa = settings.noise.accel_bias_random_walk * std::sqrt(seq.dt);
  Rng rng(16);
  // True states: i anywhere, j from the noise-free preintegration; the 15x15 covariance is that of
  // the factor residual at the true states (its bias part: the true b_j - b_i).
  ImuState xi;
  xi.R_world_body = so3::exp(Vector3d(0.3, -0.2, 0.9));
  xi.v_world = Vector3d(1.0, -0.5, 0.2);
  const ImuState xj_nominal = nominal.predict(xi);
  std::vector<Eigen::VectorXd> e9, e15;
  constexpr int kRuns = 400;
  for (int run = 0; run < kRuns; ++run) {
    // White noise only (biases known): the 9x9 covariance.
    ImuPreintegration p9({}, settings);
    // White noise and bias random walk from b_i = 0: the 15x15 covariance.
    ImuPreintegration p15({}, settings);
    Vector3d bg = Vector3d::Zero(), ba = Vector3d::Zero();
    for (std::size_t k = 0; k < seq.gyro.size(); ++k) {
      p9.add_measurement(seq.gyro[k] + normal3(rng, sg), seq.accel[k] + normal3(rng, sa), seq.dt);
      p15.add_measurement(seq.gyro[k] + bg + normal3(rng, sg), seq.accel[k] + ba + normal3(rng, sa), seq.dt);
      bg += normal3(rng, wg);
      ba += normal3(rng, wa);
    }
    Eigen::VectorXd e(9);
    e << so3::log(nominal.delta_R_ij().transpose() * p9.delta_R_ij()), p9.delta_p_ij() - nominal.delta_p_ij(),
        p9.delta_v_ij() - nominal.delta_v_ij();
    e9.push_back(e);
    ImuState xj = xj_nominal;
    xj.bias.gyro = bg;
    xj.bias.accel = ba;
    e15.push_back(p15.residual(xi, xj).r);
  }
  {
    SCOPED_TRACE("9x9, biases known");
    check_against_monte_carlo(e9, nominal.covariance());
  }
  {
    SCOPED_TRACE("15x15, with bias random walk");
    check_against_monte_carlo(e15, nominal.covariance_with_bias());
  }
  // The whitening matrix whitens: U Sigma U^T = I.
  const Matrix15d U = nominal.sqrt_information_with_bias();
  EXPECT_LT((U * nominal.covariance_with_bias() * U.transpose() - Matrix15d::Identity()).norm(), 1e-8);
}

TEST(ImuPreintegrationTest, BadSamplesGiveAStatusAndLeaveTheStateUnchanged) {
  Rng rng(7);
  const auto good = constant_samples(Vector3d(0, 0, 0.3), Vector3d(0, 0, 9.8), 0.0, 1.0, 200.0, rng);
  auto expect_status = [](const std::vector<ImuSample>& samples, double t0, double t1, Status expected) {
    ImuPreintegration pim;
    EXPECT_EQ(pim.integrate(samples, t0, t1), expected);
    EXPECT_EQ(pim.num_measurements(), 0u);
    EXPECT_EQ(pim.delta_t(), 0.0);
    EXPECT_TRUE(pim.delta_R_ij().isIdentity(0.0));
  };
  expect_status({}, 0.0, 1.0, Status::kInsufficientData);
  auto backwards = good;
  std::swap(backwards[50].stamp, backwards[51].stamp);
  expect_status(backwards, 0.0, 1.0, Status::kInvalidInput);
  auto repeated = good;
  repeated[60].stamp = repeated[59].stamp;
  expect_status(repeated, 0.0, 1.0, Status::kInvalidInput);
  for (int field = 0; field < 3; ++field) {
    auto nan = good;
    const double q = std::numeric_limits<double>::quiet_NaN();
    if (field == 0) nan[70].stamp = q;
    if (field == 1) nan[70].gyro.y() = q;
    if (field == 2) nan[70].accel.z() = std::numeric_limits<double>::infinity();
    expect_status(nan, 0.0, 1.0, Status::kInvalidInput);
  }
  auto gap = good;
  gap.erase(gap.begin() + 80, gap.begin() + 100);  // 0.1 s without samples > max_gap 0.05 s
  expect_status(gap, 0.0, 1.0, Status::kInsufficientData);
  expect_status(good, -1.0, 0.5, Status::kInsufficientData);  // starts long before the first sample
  expect_status(good, 0.5, 2.0, Status::kInsufficientData);   // ends long after the last sample
  expect_status(good, 3.0, 4.0, Status::kInsufficientData);   // entirely after
  // A bad sample outside the span does not matter.
  auto late_nan = good;
  late_nan.back().gyro.x() = std::numeric_limits<double>::quiet_NaN();
  ImuPreintegration pim;
  EXPECT_EQ(pim.integrate(late_nan, 0.1, 0.5), Status::kOk);
  EXPECT_NEAR(pim.delta_t(), 0.4, 1e-12);
  // An empty interval integrates nothing.
  EXPECT_EQ(pim.integrate(good, 0.5, 0.5), Status::kOk);
  EXPECT_NEAR(pim.delta_t(), 0.4, 1e-12);
}

TEST(ImuPreintegrationTest, MisuseThrows) {
  ImuPreintegration pim;
  const std::vector<ImuSample> samples{{0.0, Vector3d::Zero(), Vector3d::Zero()},
                                       {0.01, Vector3d::Zero(), Vector3d::Zero()}};
  EXPECT_THROW(pim.integrate(samples, 0.01, 0.0), Error);
  EXPECT_THROW(pim.integrate(samples, std::numeric_limits<double>::quiet_NaN(), 0.01), Error);
  EXPECT_THROW(pim.add_measurement(Vector3d::Zero(), Vector3d::Zero(), 0.0), Error);
  EXPECT_THROW(pim.add_measurement(Vector3d::Zero(), Vector3d::Zero(), -0.01), Error);
  EXPECT_THROW(pim.add_measurement(Vector3d(std::nan(""), 0, 0), Vector3d::Zero(), 0.01), Error);
  EXPECT_THROW(pim.sqrt_information_with_bias(), Error);  // nothing integrated: zero covariance
  PreintegrationSettings bad;
  bad.noise.gyro_noise_density = -1.0;
  EXPECT_THROW(ImuPreintegration({}, bad), Error);
  bad = {};
  bad.max_gap = 0.0;
  EXPECT_THROW(ImuPreintegration({}, bad), Error);
  EXPECT_EQ(pim.num_measurements(), 0u);
}

TEST(ImuNoiseTest, PresetsAreOrderedByGrade) {
  const ImuNoise mems = ImuNoise::mems(), tactical = ImuNoise::tactical_2deg_h();
  EXPECT_LT(tactical.gyro_noise_density, mems.gyro_noise_density);
  EXPECT_LT(tactical.gyro_bias_random_walk, mems.gyro_bias_random_walk);
  // 2 deg/h of drift over an hour of random walk: sigma_bg * sqrt(3600 s) = 2 deg/h.
  EXPECT_NEAR(tactical.gyro_bias_random_walk * 60.0, 2.0 * kPi / 180.0 / 3600.0, 1e-15);
  EXPECT_DOUBLE_EQ(-gravity_z_up().z(), kStandardGravity);
}

}  // namespace
}  // namespace plumb
