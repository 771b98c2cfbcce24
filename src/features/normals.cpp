// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/features/normals.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

#include <Eigen/Eigenvalues>

#include "plumb/core/error.hpp"
#include "plumb/core/parallel.hpp"

#include "core/eigen_instantiations.hpp"
#include "features/normals_detail.hpp"

namespace plumb {

namespace detail {

Eigen::Matrix3d neighbourhood_covariance(const std::vector<Vector3f>& pts,
                                         const std::size_t* idx, std::size_t n) {
  const Eigen::Vector3d origin = pts[idx[0]].cast<double>();
  double sx = 0, sy = 0, sz = 0, sxx = 0, sxy = 0, sxz = 0, syy = 0, syz = 0, szz = 0;
  for (std::size_t j = 0; j < n; ++j) {
    const Vector3f& p = pts[idx[j]];
    const double x = static_cast<double>(p.x()) - origin.x();
    const double y = static_cast<double>(p.y()) - origin.y();
    const double z = static_cast<double>(p.z()) - origin.z();
    sx += x;
    sy += y;
    sz += z;
    sxx += x * x;
    sxy += x * y;
    sxz += x * z;
    syy += y * y;
    syz += y * z;
    szz += z * z;
  }
  const double inv = 1.0 / static_cast<double>(n);
  const double mx = sx * inv, my = sy * inv, mz = sz * inv;
  Eigen::Matrix3d cov;
  cov(0, 0) = sxx * inv - mx * mx;
  cov(0, 1) = sxy * inv - mx * my;
  cov(0, 2) = sxz * inv - mx * mz;
  cov(1, 1) = syy * inv - my * my;
  cov(1, 2) = syz * inv - my * mz;
  cov(2, 2) = szz * inv - mz * mz;
  cov(1, 0) = cov(0, 1);
  cov(2, 0) = cov(0, 2);
  cov(2, 1) = cov(1, 2);
  return cov;
}

bool normal_from_covariance(const Eigen::Matrix3d& cov, Vector3f& normal, float& curvature) {
  const double trace = cov.trace();
  if (!(trace > 0.0) || !std::isfinite(trace)) return false;
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es;
  es.computeDirect(cov);
  const Eigen::Vector3d ev = es.eigenvalues();  // ascending
  // Collinear (or a single point repeated): the middle eigenvalue vanishes next to the largest.
  // The closed form resolves a pair of small eigenvalues to ~sqrt(eps) * largest (~1e-8), so the
  // test sits above that: a neighbourhood thinner than ~3e-4 of its length counts as a line.
  if (!(ev(1) > 1e-7 * ev(2))) return false;
  const Eigen::Vector3d v = es.eigenvectors().col(0);
  const double len = v.norm();
  if (!(len > 0.5)) return false;  // closed form failed (should not happen on a valid matrix)
  normal = (v / len).cast<float>();
  curvature = static_cast<float>(std::max(0.0, ev(0)) / trace);
  return normal.allFinite();
}

bool pca_normal(const std::vector<Vector3f>& pts, const std::size_t* idx, std::size_t n,
                Vector3f& normal, float& curvature) {
  if (n < 3) return false;
  return normal_from_covariance(neighbourhood_covariance(pts, idx, n), normal, curvature);
}

}  // namespace detail

NormalResult estimate_normals(const std::vector<Vector3f>& cloud, const KdTree<3>& tree,
                              const std::vector<Vector3f>& tree_points,
                              const NormalSettings& settings) {
  PLUMB_CHECK(settings.threads >= 0, "estimate_normals: settings.threads = " << settings.threads << " must be >= 0");
  PLUMB_CHECK(settings.k >= 3, "estimate_normals: settings.k = " << settings.k << " must be >= 3");
  PLUMB_CHECK(!(settings.radius < 0.0f) && std::isfinite(settings.radius),
              "estimate_normals: settings.radius = " << settings.radius
                                                     << " must be >= 0 and finite");
  PLUMB_CHECK(tree.num_input_points() == tree_points.size(),
              "estimate_normals: tree was built from " << tree.num_input_points()
                                                       << " points but tree_points has "
                                                       << tree_points.size());
  const float nan = std::numeric_limits<float>::quiet_NaN();
  NormalResult out;
  out.normals.assign(cloud.size(), Vector3f::Constant(nan));
  out.curvature.assign(cloud.size(), nan);
  const std::size_t k = settings.k;
  const float r2 = settings.radius * settings.radius;
  const bool hybrid = settings.radius > 0.0f;
  // Points are independent: fixed chunks of them run on settings.threads threads, each writing
  // its own points' outputs, so the result does not depend on the thread count.
  constexpr std::size_t kGrain = 512;
  std::vector<std::size_t> invalid(chunk_count(cloud.size(), kGrain), 0);
  parallel_for(settings.threads, cloud.size(), kGrain, [&](std::size_t begin, std::size_t end) {
    std::size_t& num_invalid = invalid[begin / kGrain];
    // Buffers reused for every point (no allocation once they have grown).
    std::vector<std::size_t> idx(k);
    std::vector<float> d2(k);
    std::vector<std::pair<float, std::size_t>> cand;
    // Hybrid search strategy: a radius search costs in proportion to the points inside the ball, a
    // k-nearest search in proportion to k. Use the radius search while the balls hold few points
    // (at most 4k, judged from the previous point: neighbouring points have similar density), else
    // k nearest then trimmed to the radius. Both give the same neighbours (the k nearest in radius).
    bool use_radius = hybrid;
    for (std::size_t i = begin; i < end; ++i) {
      const Vector3f& p = cloud[i];
      if (!p.allFinite()) {
        ++num_invalid;
        continue;
      }
      std::size_t n = 0;
      if (use_radius) {
        const std::size_t m = tree.radius(p, settings.radius, idx, d2, /*sorted=*/false);
        use_radius = m <= 4 * k;
        if (m > k) {
          cand.resize(m);
          for (std::size_t j = 0; j < m; ++j) cand[j] = {d2[j], idx[j]};
          std::nth_element(cand.begin(), cand.begin() + static_cast<std::ptrdiff_t>(k - 1),
                           cand.end());
          for (std::size_t j = 0; j < k; ++j) idx[j] = cand[j].second;
          n = k;
        } else {
          n = m;
        }
      } else {
        if (idx.size() < k) {
          idx.resize(k);
          d2.resize(k);
        }
        n = tree.knn(p, k, idx.data(), d2.data());
        if (hybrid) {
          // sorted ascending; how many of the k nearest lie inside the ball tells the density
          while (n > 0 && d2[n - 1] > r2) --n;
          use_radius = n < k;
        }
      }
      Vector3f normal;
      float curv = nan;
      if (!detail::pca_normal(tree_points, idx.data(), n, normal, curv)) {
        ++num_invalid;
        continue;
      }
      if (settings.orient_to_viewpoint && normal.dot(settings.viewpoint - p) < 0.0f) normal = -normal;
      out.normals[i] = normal;
      out.curvature[i] = curv;
    }
  });
  for (const std::size_t n : invalid) out.num_invalid += n;
  return out;
}

std::size_t compute_normals(PointCloud& cloud, const NormalSettings& settings) {
  PLUMB_CHECK(!cloud.empty(), "compute_normals: the cloud is empty");
  std::size_t num_finite = 0;
  for (const auto& p : cloud.points) num_finite += p.allFinite() ? 1 : 0;
  PLUMB_CHECK(num_finite > 0, "compute_normals: the cloud has no finite point");
  const KdTree<3> tree(cloud.points);
  NormalResult r = estimate_normals(cloud.points, tree, cloud.points, settings);
  cloud.normals = std::move(r.normals);
  return r.num_invalid;
}

}  // namespace plumb
