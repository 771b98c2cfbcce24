// SPDX-License-Identifier: BSD-3-Clause
// The robust kernels against independent references: their closed-form losses (Huber bit for bit
// as Liu et al. 2022, eq. 2 writes it), the loss derivative by central differences (= weight * r),
// the squared-norm form against the residual form, and IRLS with these weights landing on the
// minimum of the summed loss found by a grid search.
#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include <gtest/gtest.h>

#include "plumb/core/error.hpp"
#include "plumb/core/rng.hpp"
#include "plumb/core/robust_kernel.hpp"

namespace plumb {
namespace {

std::vector<RobustLoss> all_kernels(double scale) {
  return {RobustLoss::none(), RobustLoss::huber(scale), RobustLoss::cauchy(scale), RobustLoss::tukey(scale)};
}

TEST(KernelsTest, HuberMatchesSeedEquation) {
  const double m1 = 0.3;
  const RobustLoss huber = RobustLoss::huber(m1);
  EXPECT_DOUBLE_EQ(huber.loss(0.1), 0.005);
  EXPECT_DOUBLE_EQ(huber.loss(-0.1), 0.005);
  EXPECT_DOUBLE_EQ(huber.loss(1.0), 0.3 * (2.0 - 0.3) / 2.0);
  // Continuous with a continuous derivative at m1.
  EXPECT_NEAR(huber.loss(m1 - 1e-9), huber.loss(m1 + 1e-9), 1e-8);
  const double h = 1e-6;
  const double left = (huber.loss(m1 - h) - huber.loss(m1 - 2 * h)) / h;
  const double right = (huber.loss(m1 + 2 * h) - huber.loss(m1 + h)) / h;
  EXPECT_NEAR(left, right, 1e-5);
}

TEST(KernelsTest, WeightIsDerivativeOverResidual) {
  // Huber: w(r) = rho'(r) / r, checked numerically.
  const double s = 0.2;
  const RobustLoss huber = RobustLoss::huber(s);
  for (double r : {0.05, 0.19, 0.25, 1.0, 3.0}) {
    const double h = 1e-7;
    const double drho = (huber.loss(r + h) - huber.loss(r - h)) / (2 * h);
    EXPECT_NEAR(huber.weight(r), drho / r, 1e-6) << r;
    // Cauchy: rho = s^2/2 log(1 + (r/s)^2).
    auto cauchy = [&](double x) { return 0.5 * s * s * std::log1p((x / s) * (x / s)); };
    EXPECT_NEAR(RobustLoss::cauchy(s).weight(r), (cauchy(r + h) - cauchy(r - h)) / (2 * h) / r, 1e-6);
  }
  EXPECT_EQ(RobustLoss::tukey(0.2).weight(0.3), 0.0);
  EXPECT_EQ(RobustLoss::tukey(0.2).weight(0.0), 1.0);
  EXPECT_EQ(RobustLoss::make(RobustKernel::kNone, 0.2).weight(100.0), 1.0);
  EXPECT_EQ(RobustLoss::huber(0.2).weight(std::nan("")), 0.0);
}

TEST(RobustLossTest, WeightIsTheDerivativeAndLossesAreContinuous) {
  for (const RobustLoss& loss : {RobustLoss::none(), RobustLoss::huber(0.5), RobustLoss::cauchy(0.5)}) {
    for (double s : {0.0, 0.01, 0.2, 0.26, 1.0, 10.0, 1e4}) {
      const double h = 1e-7 * std::max(1.0, s);
      const double numeric = (loss.rho(s + h) - loss.rho(std::max(0.0, s - h))) / (s + h - std::max(0.0, s - h));
      EXPECT_NEAR(loss.rho_prime(s), numeric, 1e-5 * std::max(1.0, numeric)) << "s " << s;
      EXPECT_LE(loss.rho(s), s + 1e-15);  // robust losses never exceed the quadratic
      EXPECT_GT(loss.rho_prime(s), 0.0);
      EXPECT_LE(loss.rho_prime(s), 1.0);
    }
    EXPECT_NEAR(loss.rho(0.25 - 1e-12), loss.rho(0.25 + 1e-12), 1e-10);  // at the Huber corner d^2
  }
  EXPECT_DOUBLE_EQ(RobustLoss::huber(0.5).rho(4.0), 2.0 * 0.5 * 2.0 - 0.25);
  EXPECT_DOUBLE_EQ(RobustLoss::cauchy(0.5).rho(4.0), 0.25 * std::log(17.0));
}

TEST(RobustKernelTest, LossesMatchTheirClosedForms) {
  const double d = 0.4;
  for (double r : {-3.0, -0.41, -0.1, 0.0, 0.05, 0.39, 0.4, 0.7, 25.0}) {
    const double u2 = (r / d) * (r / d);
    EXPECT_DOUBLE_EQ(RobustLoss::none().loss(r), r * r / 2.0) << r;
    EXPECT_DOUBLE_EQ(RobustLoss::huber(d).loss(r), std::abs(r) <= d ? r * r / 2.0 : d * std::abs(r) - d * d / 2.0)
        << r;
    EXPECT_DOUBLE_EQ(RobustLoss::cauchy(d).loss(r), d * d / 2.0 * std::log(1.0 + u2)) << r;
    const double tukey = std::abs(r) < d ? d * d / 6.0 * (1.0 - std::pow(1.0 - u2, 3)) : d * d / 6.0;
    EXPECT_NEAR(RobustLoss::tukey(d).loss(r), tukey, 1e-15) << r;
  }
}

TEST(RobustKernelTest, HuberLossIsBitForBitTheSacIaPenalty) {
  // Liu et al. 2022, eq. 2, as written: l^2/2 if |l| < m1, else m1 (2|l| - m1) / 2. The kernel
  // rounds to the same double (halving and doubling are exact), the corner |l| = m1 included.
  Rng rng(7);
  for (int i = 0; i < 20000; ++i) {
    const double m1 = std::exp(rng.uniform(-8.0, 3.0));
    const double l = (i % 10 == 0) ? m1 : std::exp(rng.uniform(-10.0, 6.0)) * (rng.uniform() < 0.5 ? -1.0 : 1.0);
    const double a = std::abs(l);
    const double eq2 = a < m1 ? 0.5 * a * a : 0.5 * m1 * (2.0 * a - m1);
    ASSERT_EQ(RobustLoss::huber(m1).loss(l), eq2) << "l " << l << " m1 " << m1;
  }
}

TEST(RobustKernelTest, WeightTimesResidualIsTheLossDerivative) {
  const double d = 0.3;
  for (const RobustLoss& k : all_kernels(d)) {
    for (double r : {-2.0, -0.31, -0.2, -1e-3, 1e-3, 0.1, 0.29, 0.31, 0.5, 4.0}) {
      const double h = 1e-6;
      const double numeric = (k.loss(r + h) - k.loss(r - h)) / (2.0 * h);
      EXPECT_NEAR(k.weight(r) * r, numeric, 1e-8) << static_cast<int>(k.kernel) << " r " << r;
    }
  }
}

TEST(RobustKernelTest, SquaredNormFormAgreesWithTheResidualForm) {
  const double d = 0.3;
  for (const RobustLoss& k : all_kernels(d)) {
    for (double r : {0.0, 0.01, 0.2, 0.29, 0.31, 0.6, 3.0, 40.0}) {
      const double s = r * r;
      EXPECT_NEAR(k.rho(s), 2.0 * k.loss(r), 1e-12 * std::max(1.0, s)) << static_cast<int>(k.kernel) << " r " << r;
      EXPECT_NEAR(k.rho_prime(s), k.weight(r), 1e-12) << static_cast<int>(k.kernel) << " r " << r;
      if (s > 0.0 && std::abs(r - d) > 1e-3) {
        const double h = 1e-7 * s;
        EXPECT_NEAR(k.rho_prime(s), (k.rho(s + h) - k.rho(s - h)) / (2.0 * h), 1e-6) << static_cast<int>(k.kernel);
      }
    }
  }
}

TEST(RobustKernelTest, IrlsLandsOnTheMinimumOfTheSummedLoss) {
  // 70 samples around 1.0 and 30 gross outliers: the mean is pulled away; IRLS with each kernel's
  // weights (mu <- sum w x / sum w) reaches the minimiser of sum loss(x - mu), found by a grid.
  Rng rng(3);
  std::vector<double> x;
  for (int i = 0; i < 70; ++i) x.push_back(1.0 + 0.05 * rng.normal());
  for (int i = 0; i < 30; ++i) x.push_back(rng.uniform(3.0, 10.0));
  std::vector<double> sorted = x;
  std::sort(sorted.begin(), sorted.end());
  const double median = sorted[sorted.size() / 2];
  for (const RobustLoss& k : {RobustLoss::huber(0.1), RobustLoss::cauchy(0.1), RobustLoss::tukey(0.3)}) {
    double mu = median;
    for (int it = 0; it < 500; ++it) {
      double sw = 0.0, swx = 0.0;
      for (double xi : x) {
        const double w = k.weight(xi - mu);
        sw += w;
        swx += w * xi;
      }
      mu = swx / sw;
    }
    auto total = [&](double m) {
      double t = 0.0;
      for (double xi : x) t += k.loss(xi - m);
      return t;
    };
    double best = median, best_total = std::numeric_limits<double>::infinity();
    for (double m = median - 0.5; m <= median + 0.5; m += 1e-5) {
      const double t = total(m);
      if (t < best_total) {
        best_total = t;
        best = m;
      }
    }
    EXPECT_NEAR(mu, best, 2e-5) << static_cast<int>(k.kernel);
    EXPECT_NEAR(mu, 1.0, 0.05) << static_cast<int>(k.kernel);
  }
  double mean = 0.0;
  for (double xi : x) mean += xi / static_cast<double>(x.size());
  EXPECT_GT(mean, 2.0);  // plain least squares follows the outliers
}

TEST(RobustKernelTest, WeightsAreBoundedAndBadScalesThrow) {
  for (const RobustLoss& k : all_kernels(0.5)) {
    EXPECT_EQ(k.weight(0.0), 1.0);
    EXPECT_EQ(k.rho_prime(0.0), 1.0);
    for (double r : {-7.0, -0.5, 0.2, 0.5, 0.9, 1e6}) {
      EXPECT_GE(k.weight(r), 0.0);
      EXPECT_LE(k.weight(r), 1.0);
      EXPECT_EQ(k.weight(r), k.weight(-r));
      EXPECT_EQ(k.loss(r), k.loss(-r));
      EXPECT_LE(k.loss(r), r * r / 2.0);
    }
  }
  // kNone weighs everything, a NaN residual included; the others drop a NaN residual.
  EXPECT_EQ(RobustLoss::none().weight(std::nan("")), 1.0);
  EXPECT_EQ(RobustLoss::cauchy(0.5).weight(std::nan("")), 0.0);
  EXPECT_EQ(RobustLoss::tukey(0.5).weight(std::nan("")), 0.0);
  for (double bad : {0.0, -1.0, std::numeric_limits<double>::infinity(), std::nan("")}) {
    EXPECT_THROW(RobustLoss::huber(bad), Error);
    EXPECT_THROW(RobustLoss::make(RobustKernel::kTukey, bad), Error);
  }
}

}  // namespace
}  // namespace plumb
