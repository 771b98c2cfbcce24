// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/registration/icp.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <vector>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

#include "plumb/core/error.hpp"
#include "plumb/core/lie.hpp"
#include "plumb/core/parallel.hpp"
#include "plumb/registration/horn.hpp"
#include "plumb/registration/overlap.hpp"
#include "plumb/search/neighbors.hpp"

#include "core/eigen_instantiations.hpp"
#include "registration/icp_detail.hpp"

namespace plumb {

namespace detail {
namespace {

void check_icp_settings(const IcpSettings& s) {
  auto pos = [](double v) { return std::isfinite(v) && v > 0.0; };
  PLUMB_CHECK(pos(s.max_correspondence_distance),
              "align_icp: settings.max_correspondence_distance = " << s.max_correspondence_distance << " must be > 0");
  PLUMB_CHECK(pos(s.min_correspondence_distance) && s.min_correspondence_distance <= s.max_correspondence_distance,
              "align_icp: settings.min_correspondence_distance = " << s.min_correspondence_distance
                                                                   << " must be in (0, max_correspondence_distance]");
  PLUMB_CHECK(pos(s.distance_step), "align_icp: settings.distance_step = " << s.distance_step << " must be > 0");
  PLUMB_CHECK(s.max_rounds >= 1, "align_icp: settings.max_rounds = " << s.max_rounds << " must be >= 1");
  PLUMB_CHECK(s.max_iterations >= 1, "align_icp: settings.max_iterations = " << s.max_iterations << " must be >= 1");
  PLUMB_CHECK(std::isfinite(s.tolerance) && s.tolerance >= 0.0,
              "align_icp: settings.tolerance = " << s.tolerance << " must be >= 0");
  PLUMB_CHECK(std::isfinite(s.min_step) && s.min_step >= 0.0,
              "align_icp: settings.min_step = " << s.min_step << " must be >= 0");
  PLUMB_CHECK(s.min_overlap >= 0.0 && s.min_overlap <= 1.0,
              "align_icp: settings.min_overlap = " << s.min_overlap << " must be in [0, 1]");
  PLUMB_CHECK(pos(s.overlap_distance), "align_icp: settings.overlap_distance = " << s.overlap_distance << " must be > 0");
  PLUMB_CHECK(s.max_normal_angle >= 0.0, "align_icp: settings.max_normal_angle = " << s.max_normal_angle << " must be >= 0");
  PLUMB_CHECK(pos(s.kernel_scale), "align_icp: settings.kernel_scale = " << s.kernel_scale << " must be > 0");
  PLUMB_CHECK(s.min_correspondences >= 3,
              "align_icp: settings.min_correspondences = " << s.min_correspondences << " must be >= 3");
  PLUMB_CHECK(s.threads >= 0, "align_icp: settings.threads = " << s.threads << " must be >= 0 (0 = every core)");
  PLUMB_CHECK(std::isfinite(s.degeneracy_threshold) && s.degeneracy_threshold >= 0.0,
              "align_icp: settings.degeneracy_threshold = " << s.degeneracy_threshold << " must be >= 0");
}

/// Nearest target point of x, the source point whose cache entry is `c`, when it lies within d
/// (d_sq: the caller's float d^2): returns its squared distance and sets j, or returns +inf when no
/// target point is within d.
///
/// The cache (see IcpNnCache) replaces most kd-tree queries by an exact test. A point at x that was
/// last queried at x_ref has moved by delta = |x - x_ref|; by the triangle inequality every
/// uncached target point is at least lim = r - delta from x. So
/// - when the best cached point is within lim, it is the nearest neighbour (no query);
/// - when lim > d and no cached point is within d, there is no neighbour within d (no query;
///   this also keeps far points of a partial overlap from being searched every iteration);
/// - otherwise a new kNN query at x refreshes the entry, bounded by the farthest cached point
///   (K points lie within it) and by 2d (farther points never pair; r is then at least 2d).
/// Any d may be asked of the same cache (the entry's r records how far it is complete).
/// Cached distances are summed as the kd-tree sums them (detail::dist_sq) and lim keeps a margin
/// far above float rounding, so the result is bit-identical to a plain nearest() query within d,
/// except which of several points at exactly the same float distance is taken (the kd-tree leaves
/// that unspecified too; duplicated target points are the common case, and there the choice
/// cannot change the result).
float cached_nearest(const PointCloud& target, const KdTree3f& tree, const Vector3f& x, float d, float d_sq,
                            IcpNnCache::Entry& c, std::uint32_t& j) {
  constexpr std::size_t K = IcpNnCache::kK;
  float best = std::numeric_limits<float>::infinity();
  float worst = 0.0f;
  j = std::numeric_limits<std::uint32_t>::max();
  for (std::uint32_t k = 0; k < c.count; ++k) {
    const float dk = detail::dist_sq<3>(target.points[c.idx[k]].data(), x.data());
    if (dk < best) {
      best = dk;
      j = c.idx[k];
    }
    worst = std::max(worst, dk);
  }
  if (c.r > 0.0f) {
    // The margin covers float rounding of the coordinate differences and distances (~1e-7
    // relative to the coordinates), with a wide safety factor; it costs a few hits at most.
    const float slack = 1e-5f * (1.0f + x.cwiseAbs().maxCoeff() + c.r);
    const float lim = c.r - (x - c.x_ref).norm() - slack;
    if (lim > 0.0f && best <= lim * lim) return best <= d_sq ? best : std::numeric_limits<float>::infinity();
    if (lim > d) return std::numeric_limits<float>::infinity();  // best > lim^2 > d^2, the rest beyond lim
  }
  std::size_t knn_idx[K];
  float knn_d[K];
  const float far_sq = 4.0f * d_sq;
  const float bound = c.count == K ? std::min(far_sq, worst) : far_sq;
  const std::size_t n = tree.knn(x, K, knn_idx, knn_d, bound);
  c.x_ref = x;
  c.count = static_cast<std::uint32_t>(n);
  for (std::size_t k = 0; k < n; ++k) c.idx[k] = static_cast<std::uint32_t>(knn_idx[k]);
  c.r = std::sqrt(n == K ? knn_d[K - 1] : bound);
  if (n == 0 || !(knn_d[0] <= d_sq)) return std::numeric_limits<float>::infinity();
  j = c.idx[0];
  return knn_d[0];
}

double icp_residual(const IcpPair& pr, bool point_to_plane) {
  return point_to_plane ? pr.n.dot(pr.x - pr.q) : (pr.x - pr.q).norm();
}

/// The normal matrix J^T J of the pairs' residuals, rotation about the pairs' centroid (`pivot`).
Matrix6d icp_normal_matrix(const std::vector<IcpPair>& pairs, bool point_to_plane, Vector3d& pivot) {
  pivot.setZero();
  Matrix6d H = Matrix6d::Zero();
  if (pairs.empty()) return H;
  for (const IcpPair& pr : pairs) pivot += pr.x;
  pivot /= static_cast<double>(pairs.size());
  for (const IcpPair& pr : pairs) {
    const Vector3d x = pr.x - pivot;
    if (point_to_plane) {
      Vector6d J;
      J << x.cross(pr.n), pr.n;
      H.noalias() += J * J.transpose();
    } else {
      Eigen::Matrix<double, 3, 6> J;
      J << -hat(x), Matrix3d::Identity();
      H.noalias() += J.transpose() * J;
    }
  }
  return H;
}

/// Smallest eigenvalue of the normal matrix divided by the number of pairs.
double icp_degeneracy(const Matrix6d& normal_matrix, std::size_t num_pairs) {
  if (num_pairs == 0) return 0.0;
  const Matrix6d H = normal_matrix / static_cast<double>(num_pairs);
  Eigen::SelfAdjointEigenSolver<Matrix6d> es(H, Eigen::EigenvaluesOnly);
  return es.info() == Eigen::Success ? std::max(0.0, es.eigenvalues()(0)) : 0.0;
}

}  // namespace

/// Nearest-neighbour pairs of the source under T within distance d (Liu et al. 2022, sec. 1.3, ICP
/// steps (1)-(2)), through `cache` (cached_nearest). Returns the mean squared residual of the metric.
double icp_pairs(const PointCloud& source, const PointCloud& target, const KdTree3f& tree,
                        const Eigen::Isometry3d& T, double d, const IcpSettings& s,
                        std::vector<IcpPair>& pairs, IcpNnCache& cache) {
  pairs.clear();
  const Eigen::Matrix3f R = T.linear().cast<float>();
  const Eigen::Vector3f t = T.translation().cast<float>();
  const float d_f = static_cast<float>(d);
  const float d_sq = static_cast<float>(d * d);
  const bool point_to_plane = s.method == IcpMethod::kPointToPlane;
  const bool check_angle = source.has_normals() && target.has_normals() && s.max_normal_angle < 1.5707963;
  const float min_cos = static_cast<float>(std::cos(s.max_normal_angle));
  // Each source point touches only its own cache entry: chunks of points are independent, and
  // their pairs are appended in point order whatever the thread count.
  parallel_append(s.threads, source.points.size(), kIcpGrain, pairs,
                  [&](std::size_t begin, std::size_t end, std::vector<IcpPair>& out) {
    for (std::size_t i = begin; i < end; ++i) {
      const Vector3f& p = source.points[i];
      if (!p.allFinite()) continue;
      const Vector3f x = R * p + t;
      std::uint32_t j = 0;
      const float best = cached_nearest(target, tree, x, d_f, d_sq, cache[i], j);
      if (!(best <= d_sq)) continue;
      if (check_angle) {
        const Vector3f& nt = target.normals[j];
        const Vector3f& ns = source.normals[i];
        // A missing normal on either side does not veto the pair (except where the metric needs it).
        if (nt.allFinite() && ns.allFinite() && std::abs((R * ns).dot(nt)) < min_cos) continue;
      }
      IcpPair pr;
      pr.i = i;
      pr.j = j;
      pr.x = x.cast<double>();
      pr.q = target.points[j].cast<double>();
      if (point_to_plane) {
        const Vector3f& nt = target.normals[j];
        if (!nt.allFinite()) continue;
        pr.n = nt.cast<double>();
        const double r = pr.n.dot(pr.x - pr.q);
        pr.r_sq = r * r;
      } else {
        pr.n.setZero();
        pr.r_sq = static_cast<double>(best);
      }
      out.push_back(pr);
    }
  });
  double sum_sq = 0.0;  // in pair order: the same sum on any thread count
  for (const IcpPair& pr : pairs) sum_sq += pr.r_sq;
  return pairs.empty() ? 0.0 : sum_sq / static_cast<double>(pairs.size());
}

/// overlap_ratio() of the source under T through the ICP's neighbour cache: the same result (see
/// cached_nearest), without a kd-tree query for most points.
OverlapResult icp_overlap(const PointCloud& source, const PointCloud& target, const KdTree3f& tree,
                                 const Eigen::Isometry3d& T, double beta, IcpNnCache& cache, int threads) {
  OverlapResult out;
  const Eigen::Matrix3f R = T.linear().cast<float>();
  const Eigen::Vector3f t = T.translation().cast<float>();
  const float beta_f = static_cast<float>(beta);
  const float beta_sq = static_cast<float>(beta * beta);
  // Per point: its squared distance when an inlier, -1 when not finite, +inf otherwise; summed in
  // point order after the (parallel) queries.
  std::vector<float> best(source.points.size());
  parallel_for(threads, source.points.size(), kIcpGrain, [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i) {
      const Vector3f& p = source.points[i];
      if (!p.allFinite()) {
        best[i] = -1.0f;
        continue;
      }
      std::uint32_t j = 0;
      best[i] = cached_nearest(target, tree, R * p + t, beta_f, beta_sq, cache[i], j);
    }
  });
  double sum_sq = 0.0;
  for (const float b : best) {
    if (b < 0.0f) continue;
    ++out.num_valid;
    if (b <= beta_sq) {
      ++out.num_inliers;
      sum_sq += b;
    }
  }
  if (out.num_valid > 0) out.overlap = static_cast<double>(out.num_inliers) / static_cast<double>(out.num_valid);
  if (out.num_inliers > 0) out.rmse = std::sqrt(sum_sq / static_cast<double>(out.num_inliers));
  return out;
}

/// One update from the current pairs; false when the system cannot be solved.
bool icp_step(const std::vector<IcpPair>& pairs, const IcpSettings& s, Eigen::Isometry3d& delta) {
  const bool point_to_plane = s.method == IcpMethod::kPointToPlane;
  const RobustLoss kernel = RobustLoss::make(s.kernel, s.kernel_scale);
  if (!point_to_plane) {
    // Liu et al. 2022, eq. 5-6: Horn's closed form on the (weighted) pairs.
    HornAccumulator acc;
    for (const IcpPair& pr : pairs) {
      const double w = kernel.weight(icp_residual(pr, false));
      acc.add(pr.x, pr.q, w);
    }
    const HornResult h = acc.solve();
    if (!h.valid) return false;
    delta = h.T_target_source;
    return true;
  }
  // Point-to-plane: minimise sum w (n.(exp(omega) x + t - q))^2, linearised about the centroid
  // of the pairs for conditioning: x' = c + R (x - c) + t.
  Vector3d c = Vector3d::Zero();
  for (const IcpPair& pr : pairs) c += pr.x;
  c /= static_cast<double>(pairs.size());
  Matrix6d H = Matrix6d::Zero();
  Vector6d g = Vector6d::Zero();
  for (const IcpPair& pr : pairs) {
    const double r = pr.n.dot(pr.x - pr.q);
    const double w = kernel.weight(r);
    if (!(w > 0.0)) continue;
    Vector6d J;
    J << (pr.x - c).cross(pr.n), pr.n;
    H.noalias() += w * J * J.transpose();
    g.noalias() += w * r * J;
  }
  const Eigen::LDLT<Matrix6d> ldlt(H);
  if (ldlt.info() != Eigen::Success) return false;
  const Vector6d xi = ldlt.solve(-g);
  if (!xi.allFinite()) return false;
  const Matrix3d R = so3::exp(xi.head<3>());
  delta.setIdentity();
  delta.linear() = R;
  delta.translation() = c - R * c + xi.tail<3>();
  return delta.matrix().allFinite();
}

}  // namespace detail

IcpResult align_icp(const PointCloud& source, const PointCloud& target, const KdTree3f& target_tree,
                           const Eigen::Isometry3d& T_init, const IcpSettings& settings) {
  detail::check_icp_settings(settings);
  source.check_consistent("align_icp: source");
  target.check_consistent("align_icp: target");
  PLUMB_CHECK(target_tree.num_input_points() == target.size(),
              "align_icp: target_tree was built from " << target_tree.num_input_points()
                                                       << " points but the target has " << target.size());
  PLUMB_CHECK(T_init.matrix().allFinite(), "align_icp: T_init is not finite");
  const bool point_to_plane = settings.method == IcpMethod::kPointToPlane;
  PLUMB_CHECK(!point_to_plane || target.has_normals(), "align_icp: point-to-plane needs target normals");

  IcpResult out;
  out.T_target_source = T_init;
  out.final_correspondence_distance = settings.max_correspondence_distance;
  std::size_t num_finite = 0;
  for (const Vector3f& p : source.points) num_finite += p.allFinite() ? 1 : 0;
  if (num_finite < 3 || target_tree.size() < 3) {
    out.status = Status::kInsufficientData;
    return out;
  }

  Eigen::Isometry3d T = T_init;
  double d = settings.max_correspondence_distance;
  std::vector<detail::IcpPair> pairs;
  pairs.reserve(source.size());
  detail::IcpNnCache cache(source.size());
  bool failed = false;
  bool gate_passed = false;
  for (int round = 0; round < settings.max_rounds && !failed; ++round) {
    ++out.rounds;
    out.final_correspondence_distance = d;
    out.converged = false;
    double prev_mse = std::numeric_limits<double>::infinity();
    for (int it = 0; it < settings.max_iterations; ++it) {
      const double mse = detail::icp_pairs(source, target, target_tree, T, d, settings, pairs, cache);
      if (pairs.size() < settings.min_correspondences) {
        out.status = Status::kInsufficientData;
        failed = true;
        break;
      }
      // Liu et al. 2022, sec. 1.3, ICP step (3): stop when d_k - d_{k+1} < tau.
      if (std::abs(prev_mse - mse) < settings.tolerance) {
        out.converged = true;
        break;
      }
      prev_mse = mse;
      Eigen::Isometry3d delta;
      if (!detail::icp_step(pairs, settings, delta)) {
        out.status = Status::kDegenerate;
        failed = true;
        break;
      }
      T = delta * T;
      T.linear() = Eigen::Quaterniond(T.linear()).normalized().toRotationMatrix();
      ++out.iterations;
      const double step_t = delta.translation().norm();
      const double step_r = Eigen::AngleAxisd(delta.linear()).angle();
      if (step_t < settings.min_step && step_r < settings.min_step) {
        out.converged = true;
        break;
      }
    }
    if (failed) break;
    // Liu et al. 2022, sec. 1.3, ICP step (4): accept when the overlap ratio reaches c, else shrink d
    // and run again.
    out.overlap = detail::icp_overlap(source, target, target_tree, T, settings.overlap_distance, cache, settings.threads).overlap;
    if (out.overlap >= settings.min_overlap) {
      gate_passed = true;
      break;
    }
    const double next = d - settings.distance_step;
    if (next < settings.min_correspondence_distance - 1e-12) break;
    d = next;
  }
  out.T_target_source = T;
  detail::icp_pairs(source, target, target_tree, T, d, settings, pairs, cache);
  out.num_inliers = pairs.size();
  if (!pairs.empty()) {
    double sum_sq = 0.0;
    for (const auto& pr : pairs) {
      const double r = detail::icp_residual(pr, point_to_plane);
      sum_sq += r * r;
    }
    out.rmse = std::sqrt(sum_sq / static_cast<double>(pairs.size()));
    out.normal_matrix = detail::icp_normal_matrix(pairs, point_to_plane, out.normal_matrix_pivot);
    out.degeneracy = detail::icp_degeneracy(out.normal_matrix, pairs.size());
  }
  if (settings.keep_correspondences) {
    out.correspondences.reserve(pairs.size());
    for (const auto& pr : pairs) out.correspondences.push_back({pr.i, pr.j, pr.x, pr.q, pr.n});
  }
  if (failed) return out;
  if (!gate_passed) {
    out.status = Status::kRejected;
  } else if (settings.degeneracy_threshold > 0.0 && out.degeneracy < settings.degeneracy_threshold) {
    out.status = Status::kDegenerate;
  } else if (!out.converged) {
    out.status = Status::kNotConverged;
  } else {
    out.status = Status::kOk;
  }
  return out;
}

IcpResult align_icp(const PointCloud& source, const PointCloud& target,
                           const Eigen::Isometry3d& T_init, const IcpSettings& settings) {
  std::size_t num_finite = 0;
  for (const Vector3f& p : target.points) num_finite += p.allFinite() ? 1 : 0;
  if (num_finite < 3) {  // nothing to build a tree on; the full overload reports the same
    detail::check_icp_settings(settings);
    IcpResult out;
    out.T_target_source = T_init;
    out.status = Status::kInsufficientData;
    return out;
  }
  const KdTree3f tree(target.points);
  return align_icp(source, target, tree, T_init, settings);
}

}  // namespace plumb
