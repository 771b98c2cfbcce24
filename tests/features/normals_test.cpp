// SPDX-License-Identifier: BSD-3-Clause
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include <Eigen/Eigenvalues>

#include "plumb/core/error.hpp"
#include "plumb/features/normals.hpp"
#include "plumb/io/pcd.hpp"
#include "test_data.hpp"

#include "features/normals_detail.hpp"

namespace plumb {
namespace {

constexpr float kNan = std::numeric_limits<float>::quiet_NaN();

float angle_deg(const Vector3f& a, const Vector3f& b) {
  const double c = std::clamp(static_cast<double>(a.normalized().dot(b.normalized())), -1.0, 1.0);
  return static_cast<float>(std::acos(c) * 180.0 / M_PI);
}

/// Points on the plane through `origin` spanned by the unit vectors e1, e2, jittered grid.
std::vector<Vector3f> plane_points(const Vector3f& origin, const Vector3f& e1, const Vector3f& e2,
                                   int n, float spacing, std::mt19937& rng) {
  std::uniform_real_distribution<float> jitter(-0.3f * spacing, 0.3f * spacing);
  std::vector<Vector3f> pts;
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j) {
      const float a = static_cast<float>(i) * spacing + jitter(rng);
      const float b = static_cast<float>(j) * spacing + jitter(rng);
      pts.push_back(origin + a * e1 + b * e2);
    }
  }
  return pts;
}

TEST(NormalsTest, PlaneGivesItsNormalOrientedToViewpoint) {
  std::mt19937 rng(7);
  const Vector3f n_true = Vector3f(0.3f, -0.5f, 0.8f).normalized();
  const Vector3f e1 = n_true.unitOrthogonal();
  const Vector3f e2 = n_true.cross(e1);
  PointCloud cloud;
  cloud.points = plane_points(Vector3f(1.0f, 2.0f, -3.0f), e1, e2, 30, 0.05f, rng);
  for (const bool above : {true, false}) {
    NormalSettings s;
    s.k = 12;
    s.viewpoint = Vector3f(1.0f, 2.0f, -3.0f) + (above ? 10.0f : -10.0f) * n_true;
    EXPECT_EQ(compute_normals(cloud, s), 0u);
    ASSERT_EQ(cloud.normals.size(), cloud.size());
    for (std::size_t i = 0; i < cloud.size(); ++i) {
      const Vector3f& n = cloud.normals[i];
      EXPECT_NEAR(n.norm(), 1.0f, 1e-5f);
      // sign fixed by the viewpoint: toward it, i.e. +n_true when it lies above the plane
      EXPECT_LT(angle_deg(n, above ? n_true : Vector3f(-n_true)), 0.01f) << i;
      EXPECT_GT(n.dot(s.viewpoint - cloud.points[i]), 0.0f);
    }
  }
}

TEST(NormalsTest, SphereNormalsAreRadialAndPointToCentre) {
  // Fibonacci lattice: nearly uniform, so each neighbourhood is a nearly symmetric cap whose
  // covariance has the radius as its smallest axis.
  const Vector3f c(0.5f, -1.0f, 2.0f);
  const float radius = 2.0f;
  const int n = 6000;
  const double golden = M_PI * (3.0 - std::sqrt(5.0));
  PointCloud cloud;
  for (int i = 0; i < n; ++i) {
    const double z = 1.0 - 2.0 * (i + 0.5) / n;
    const double r = std::sqrt(1.0 - z * z);
    const Vector3d d(r * std::cos(golden * i), r * std::sin(golden * i), z);
    cloud.points.push_back(c + radius * d.cast<float>());
  }
  NormalSettings s;
  s.k = 15;
  s.viewpoint = c;  // inside: normals point inward
  ASSERT_EQ(compute_normals(cloud, s), 0u);
  float worst = 0.0f;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    worst = std::max(worst, angle_deg(cloud.normals[i], c - cloud.points[i]));
  }
  EXPECT_LT(worst, 1.0f);
}

TEST(NormalsTest, CylinderNormalsAreRadialAndHorizontal) {
  // regular grid on the cylinder x^2 + y^2 = r^2, 0 <= z <= 3: 120 angles x 75 heights
  PointCloud cloud;
  const float r = 0.8f;
  for (int i = 0; i < 120; ++i) {
    for (int j = 0; j < 75; ++j) {
      const float a = 2.0f * static_cast<float>(M_PI) * static_cast<float>(i) / 120.0f;
      cloud.points.emplace_back(r * std::cos(a), r * std::sin(a), 0.04f * static_cast<float>(j));
    }
  }
  NormalSettings s;
  s.k = 15;
  s.viewpoint = Vector3f(0.0f, 0.0f, 1.5f);
  ASSERT_EQ(compute_normals(cloud, s), 0u);
  float worst = 0.0f;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const Vector3f& p = cloud.points[i];
    worst = std::max(worst, angle_deg(cloud.normals[i], Vector3f(-p.x(), -p.y(), 0.0f)));
  }
  // rows at the ends see a one-sided neighbourhood, which still has no vertical tilt by symmetry
  EXPECT_LT(worst, 1.0f);
}

/// Oracle: the k nearest points within the radius by brute force, their covariance about the mean
/// (two passes) and Eigen's iterative solver. `d` is scratch.
Vector3f brute_force_normal(const std::vector<Vector3f>& pts, const Vector3f& q, std::size_t k,
                            float radius, std::vector<std::pair<float, std::size_t>>& d,
                            std::size_t& count) {
  d.clear();
  for (std::size_t j = 0; j < pts.size(); ++j) {
    const float d2 = (pts[j] - q).squaredNorm();
    if (radius <= 0.0f || d2 <= radius * radius) d.emplace_back(d2, j);
  }
  if (d.size() > k) {
    std::nth_element(d.begin(), d.begin() + static_cast<std::ptrdiff_t>(k - 1), d.end());
    d.resize(k);
  }
  count = d.size();
  if (count < 3) return Vector3f::Constant(kNan);
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const auto& e : d) mean += pts[e.second].cast<double>();
  mean /= static_cast<double>(count);
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (const auto& e : d) {
    const Eigen::Vector3d x = pts[e.second].cast<double>() - mean;
    cov += x * x.transpose();
  }
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(cov);
  return es.eigenvectors().col(0).cast<float>();
}

TEST(NormalsTest, HybridSearchMatchesBruteForceOnUnevenDensity) {
  // A dense patch next to a sparse one, on a wavy surface, so that the hybrid search switches
  // between its radius and k-nearest strategies; every normal must equal the oracle's.
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::vector<Vector3f> pts;
  for (int i = 0; i < 2000; ++i) {
    const bool dense = i % 2 == 0;
    // dense: 1000 points per m^2; sparse: 28 per m^2 (k = 10 fills a ball of 0.056 m / 0.34 m)
    const float x = dense ? u(rng) : 1.0f + 6.0f * u(rng);
    const float y = dense ? u(rng) : 6.0f * u(rng);
    pts.emplace_back(x, y, 0.2f * std::sin(2.0f * x) * std::cos(3.0f * y) + 0.01f * u(rng));
  }
  const KdTree<3> tree(pts);
  for (const float radius : {0.0f, 0.06f, 0.15f, 0.3f}) {
    NormalSettings s;
    s.k = 10;
    s.radius = radius;
    s.orient_to_viewpoint = false;
    s.threads = 3;  // the chunked search (each chunk restarts the strategy) is what is checked
    const NormalResult r = estimate_normals(pts, tree, pts, s);
    std::size_t num_nan = 0;
    std::vector<std::pair<float, std::size_t>> scratch;
    for (std::size_t i = 0; i < pts.size(); ++i) {
      std::size_t count = 0;
      const Vector3f ref = brute_force_normal(pts, pts[i], s.k, radius, scratch, count);
      if (count < 3) {
        EXPECT_TRUE(std::isnan(r.normals[i].x())) << "radius " << radius << " point " << i;
        ++num_nan;
        continue;
      }
      ASSERT_TRUE(r.normals[i].allFinite()) << "radius " << radius << " point " << i;
      EXPECT_GT(std::fabs(r.normals[i].dot(ref)), 0.9999f) << "radius " << radius << " point " << i;
    }
    EXPECT_EQ(r.num_invalid, num_nan);
    if (radius == 0.06f) {
      EXPECT_GT(num_nan, 0u);  // the sparse patch has isolated points
    }
  }
}

TEST(NormalsTest, ClosedFormEigenvectorMatchesIterativeSolver) {
  std::mt19937 rng(17);
  std::normal_distribution<double> g(0.0, 1.0);
  for (int t = 0; t < 2000; ++t) {
    // covariance of a random frame with spread (1, s1, s0): from isotropic to nearly planar
    const Eigen::Matrix3d R =
        Eigen::Quaterniond(g(rng), g(rng), g(rng), g(rng)).normalized().toRotationMatrix();
    const double s1 = std::pow(10.0, -3.0 * std::fabs(g(rng)) / 3.0);
    const double s0 = s1 * std::pow(10.0, -1.0 - 5.0 * std::fabs(g(rng)) / 3.0);
    const Eigen::Matrix3d cov = R * Eigen::Vector3d(s0, s1, 1.0).asDiagonal() * R.transpose();
    Vector3f n;
    float curv = 0.0f;
    ASSERT_TRUE(detail::normal_from_covariance(cov, n, curv));
    EXPECT_GT(std::fabs(n.cast<double>().dot(R.col(0))), 1.0 - 1e-6) << t;
    EXPECT_NEAR(curv, s0 / (s0 + s1 + 1.0), 1e-6);
  }
}

TEST(NormalsTest, MatchesOpen3dOnBunny) {
  PLUMB_REQUIRE_DATA(path, "cloud3d/pcl_test/bunny.pcd");
  PointCloud cloud = io::read_pcd(path);
  // Open3D's normals from the FPFH golden file (scripts/fpfh_golden/make_golden.py), estimated
  // with KDTreeSearchParamHybrid(radius, max_nn).
  std::ifstream in(test::source_dir() + "/tests/features/golden/bunny_open3d_fpfh.txt");
  ASSERT_TRUE(in.good());
  std::string line, key;
  std::size_t n = 0, max_nn = 0;
  float radius = 0.0f;
  while (std::getline(in, line) && line[0] == '#') {
  }
  std::istringstream(line) >> key >> n;
  ASSERT_EQ(n, cloud.size());
  std::getline(in, line);
  std::istringstream(line) >> key >> radius >> max_nn;
  ASSERT_EQ(key, "normals");
  std::vector<Vector3f> o3d(n);
  for (auto& v : o3d) {
    std::getline(in, line);
    std::istringstream(line) >> v.x() >> v.y() >> v.z();
  }
  NormalSettings s;
  s.k = max_nn;
  s.radius = radius;
  const NormalResult r = estimate_normals(cloud.points, KdTree<3>(cloud.points), cloud.points, s);
  EXPECT_EQ(r.num_invalid, 0u);
  for (std::size_t i = 0; i < n; ++i) {
    // PCA fixes no sign (Open3D's is its solver's); the axes must agree
    EXPECT_GT(std::fabs(r.normals[i].dot(o3d[i])), 1.0f - 1e-5f) << i;
  }
}

TEST(NormalsTest, DegenerateInputGivesNanNotCrash) {
  NormalSettings s;
  s.k = 5;
  // coincident points
  PointCloud same;
  same.points.assign(10, Vector3f(1.0f, 2.0f, 3.0f));
  EXPECT_EQ(compute_normals(same, s), 10u);
  for (const auto& n : same.normals) EXPECT_TRUE(std::isnan(n.x()));
  // collinear points: no unique normal
  PointCloud line;
  for (int i = 0; i < 20; ++i) line.points.emplace_back(0.1f * i, 0.2f * i, -0.05f * i);
  EXPECT_EQ(compute_normals(line, s), 20u);
  // fewer than 3 points
  PointCloud two;
  two.points = {Vector3f(0, 0, 0), Vector3f(1, 0, 0)};
  EXPECT_EQ(compute_normals(two, s), 2u);
  // NaN points among good ones: NaN normal there, the others valid and unaffected
  std::mt19937 rng(1);
  PointCloud mixed;
  mixed.points =
      plane_points(Vector3f::Zero(), Vector3f::UnitX(), Vector3f::UnitY(), 10, 0.1f, rng);
  mixed.points[3] = Vector3f(kNan, 0.0f, 0.0f);
  mixed.points[50].z() = std::numeric_limits<float>::infinity();
  s.viewpoint = Vector3f(0, 0, 5);
  EXPECT_EQ(compute_normals(mixed, s), 2u);
  for (std::size_t i = 0; i < mixed.size(); ++i) {
    if (i == 3 || i == 50) {
      EXPECT_TRUE(std::isnan(mixed.normals[i].x()));
    } else {
      EXPECT_GT(mixed.normals[i].z(), 0.9999f) << i;
    }
  }
}

TEST(NormalsTest, BadInputThrows) {
  PointCloud empty;
  EXPECT_THROW(compute_normals(empty), Error);
  PointCloud all_nan;
  all_nan.points.assign(5, Vector3f::Constant(kNan));
  EXPECT_THROW(compute_normals(all_nan), Error);
  PointCloud ok;
  ok.points = {Vector3f(0, 0, 0), Vector3f(1, 0, 0), Vector3f(0, 1, 0)};
  NormalSettings bad_k;
  bad_k.k = 2;
  EXPECT_THROW(compute_normals(ok, bad_k), Error);
  NormalSettings bad_r;
  bad_r.radius = -1.0f;
  EXPECT_THROW(compute_normals(ok, bad_r), Error);
  bad_r.radius = kNan;
  EXPECT_THROW(compute_normals(ok, bad_r), Error);
  const KdTree<3> tree(ok.points);
  std::vector<Vector3f> other(4, Vector3f::Zero());
  EXPECT_THROW(estimate_normals(ok.points, tree, other), Error);
}

TEST(NormalsTest, Deterministic) {
  std::mt19937 rng(9);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  std::vector<Vector3f> pts;
  for (int i = 0; i < 3000; ++i) pts.emplace_back(u(rng), u(rng), 0.1f * u(rng));
  const KdTree<3> tree(pts);
  NormalSettings s;
  s.k = 12;
  s.radius = 0.1f;
  const NormalResult a = estimate_normals(pts, tree, pts, s);
  // The same call again, and on several threads: bit-identical, NaN included.
  for (const int threads : {1, 2, 3, 8, 0}) {
    s.threads = threads;
    const NormalResult b = estimate_normals(pts, tree, pts, s);
    ASSERT_EQ(a.normals.size(), b.normals.size());
    for (std::size_t i = 0; i < pts.size(); ++i) {
      EXPECT_EQ(std::memcmp(a.normals[i].data(), b.normals[i].data(), sizeof(Vector3f)), 0) << threads;
      EXPECT_EQ(std::memcmp(&a.curvature[i], &b.curvature[i], sizeof(float)), 0) << threads;
    }
    EXPECT_EQ(a.num_invalid, b.num_invalid);
  }
  EXPECT_GT(a.num_invalid, 0u);  // NaNs are part of what is compared
}

}  // namespace
}  // namespace plumb
