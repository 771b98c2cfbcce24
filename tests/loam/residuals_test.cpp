// SPDX-License-Identifier: BSD-3-Clause
// LOAM residuals (Zhou et al. 2021, eq. 5-7, 20): the cosine of eq. 5 against acos of the dot product, the
// edge residual's norm against eq. 6's cross-product formula, and every analytic Jacobian against
// central differences of the right perturbation T exp(delta).
#include <cmath>

#include <gtest/gtest.h>

#include "plumb/core/lie.hpp"
#include "plumb/core/rng.hpp"
#include "plumb/loam/features.hpp"
#include "plumb/loam/residuals.hpp"

namespace plumb {
namespace {

Vector3d random_vec(Rng& rng, double scale) {
  return Vector3d(rng.normal(), rng.normal(), rng.normal()) * scale;
}

Eigen::Isometry3d random_pose(Rng& rng) {
  Vector6d xi;
  for (int i = 0; i < 6; ++i) xi(i) = rng.uniform(-1.5, 1.5);
  return se3::exp(xi);
}

// Central differences of f(T exp(delta)) w.r.t. delta, for a residual of M rows.
template <int M, typename F>
Eigen::Matrix<double, M, 6> numeric_jacobian(const Eigen::Isometry3d& T, F&& f) {
  Eigen::Matrix<double, M, 6> J;
  const double h = 1e-6;
  for (int k = 0; k < 6; ++k) {
    Vector6d d = Vector6d::Zero();
    d(k) = h;
    const Eigen::Matrix<double, M, 1> fp = f(T * se3::exp(d));
    const Eigen::Matrix<double, M, 1> fm = f(T * se3::exp(-d));
    J.col(k) = (fp - fm) / (2.0 * h);
  }
  return J;
}

TEST(LoamCosineTest, MatchesAngleBetweenNeighbourVectors) {
  Rng rng(3);
  for (int i = 0; i < 200; ++i) {
    const Vector3d a = random_vec(rng, 2.0), b = random_vec(rng, 2.0), c = random_vec(rng, 2.0);
    const Vector3d u = (a - b).normalized(), v = (c - b).normalized();
    EXPECT_NEAR(loam_cosine(a, b, c), u.dot(v), 1e-9);
  }
  // Collinear with the point between its neighbours: 180 deg; right angle: 0; coincident: NaN.
  EXPECT_NEAR(loam_cosine({0, 0, 0}, {1, 0, 0}, {2.5, 0, 0}), -1.0, 1e-12);
  EXPECT_NEAR(loam_cosine({1, 0, 0}, {0, 0, 0}, {0, 3, 0}), 0.0, 1e-12);
  EXPECT_TRUE(std::isnan(loam_cosine({1, 0, 0}, {1, 0, 0}, {0, 3, 0})));
}

TEST(LoamResidualTest, EdgeResidualNormIsEquation6) {
  Rng rng(5);
  for (int i = 0; i < 100; ++i) {
    const Eigen::Isometry3d T = random_pose(rng);
    const Vector3d p = random_vec(rng, 5.0), j = random_vec(rng, 5.0), l = random_vec(rng, 5.0);
    const auto u = make_edge_line(j, l);
    ASSERT_TRUE(u.has_value());
    const Vector3d q = T * p;
    const double eq6 = (q - j).cross(q - l).norm() / (j - l).norm();
    EXPECT_NEAR(point_to_edge_residual(T, p, j, *u).norm(), eq6, 1e-9 * (1.0 + eq6));
  }
  EXPECT_FALSE(make_edge_line({1, 2, 3}, {1, 2, 3}).has_value());
}

TEST(LoamResidualTest, PlaneResidualIsEquation7Distance) {
  Rng rng(6);
  for (int i = 0; i < 100; ++i) {
    const Eigen::Isometry3d T = random_pose(rng);
    const Vector3d p = random_vec(rng, 5.0);
    const Vector3d j = random_vec(rng, 5.0), l = random_vec(rng, 5.0), m = random_vec(rng, 5.0);
    const auto n = make_plane_normal(j, l, m);
    ASSERT_TRUE(n.has_value());
    const Vector3d q = T * p;
    // eq. 7: |(q - j) . ((j - l) x (j - m))| / |(j - l) x (j - m)|
    const Vector3d c = (j - l).cross(j - m);
    const double eq7 = std::abs((q - j).dot(c)) / c.norm();
    EXPECT_NEAR(std::abs(point_to_plane_residual(T, p, j, *n)), eq7, 1e-9 * (1.0 + eq7));
  }
  EXPECT_FALSE(make_plane_normal({0, 0, 0}, {1, 1, 1}, {2, 2, 2}).has_value());
}

TEST(LoamResidualTest, AnalyticJacobiansMatchNumeric) {
  Rng rng(11);
  for (int i = 0; i < 50; ++i) {
    const Eigen::Isometry3d T = random_pose(rng);
    const Vector3d p = random_vec(rng, 4.0), a = random_vec(rng, 4.0), b = random_vec(rng, 4.0);
    const Vector3d dir = (b - a).normalized();

    Matrix36d J_edge;
    point_to_edge_residual(T, p, a, dir, &J_edge);
    const auto J_edge_num = numeric_jacobian<3>(
        T, [&](const Eigen::Isometry3d& X) { return point_to_edge_residual(X, p, a, dir); });
    EXPECT_TRUE(J_edge.isApprox(J_edge_num, 1e-6)) << J_edge << "\n\n" << J_edge_num;

    Matrix16d J_plane;
    point_to_plane_residual(T, p, a, dir, &J_plane);
    const auto J_plane_num = numeric_jacobian<1>(T, [&](const Eigen::Isometry3d& X) {
      return Eigen::Matrix<double, 1, 1>(point_to_plane_residual(X, p, a, dir));
    });
    EXPECT_TRUE(J_plane.isApprox(J_plane_num, 1e-6)) << J_plane << "\n\n" << J_plane_num;

    Matrix36d J_point;
    point_to_point_residual(T, p, a, &J_point);
    const auto J_point_num = numeric_jacobian<3>(
        T, [&](const Eigen::Isometry3d& X) { return point_to_point_residual(X, p, a); });
    EXPECT_TRUE(J_point.isApprox(J_point_num, 1e-6)) << J_point << "\n\n" << J_point_num;
  }
}

}  // namespace
}  // namespace plumb
