// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/segmentation/plane_ransac.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Eigenvalues>

#include "plumb/core/error.hpp"
#include "plumb/core/rng.hpp"

#include "core/eigen_instantiations.hpp"
#include "segmentation/plane_ransac_detail.hpp"

namespace plumb {

namespace detail {

std::size_t count_plane_inliers(const PlaneCandidates& c, float a, float b, float cc, float d, float tau,
                                float cos_max, std::size_t beat) {
  const std::size_t n = c.x.size();
  const float* x = c.x.data();
  const float* y = c.y.data();
  const float* z = c.z.data();
  const float* nx = c.nx.data();
  const float* ny = c.ny.data();
  const float* nz = c.nz.data();
  constexpr std::size_t kBlock = 512;
  std::size_t count = 0;
  for (std::size_t begin = 0; begin < n; begin += kBlock) {
    const std::size_t end = std::min(n, begin + kBlock);
    std::uint32_t block = 0;
    if (c.has_normals) {
      for (std::size_t i = begin; i < end; ++i) {
        const float dist = std::abs(a * x[i] + b * y[i] + cc * z[i] - d);
        const float agree = std::abs(a * nx[i] + b * ny[i] + cc * nz[i]);
        block += static_cast<std::uint32_t>((dist < tau) & (agree >= cos_max));
      }
    } else {
      for (std::size_t i = begin; i < end; ++i) {
        const float dist = std::abs(a * x[i] + b * y[i] + cc * z[i] - d);
        block += static_cast<std::uint32_t>(dist < tau);
      }
    }
    count += block;
    if (count + (n - end) <= beat) return count;
  }
  return count;
}

double NormalBins::line_pseudo_angle(double u, double v) {
  if (v < 0.0 || (v == 0.0 && u < 0.0)) {
    u = -u;
    v = -v;
  }
  const double s = std::abs(u) + v;
  if (!(s > 0.0)) return 0.0;
  return u >= 0.0 ? v / s : 1.0 + (-u) / s;
}

int NormalBins::bin_of(double t) {
  return std::min(kBins - 1, std::max(0, static_cast<int>(t * (kBins / 2.0))));
}

void NormalBins::build(const PlaneCandidates& c, const Vector3d& unit_axis) {
  axis = unit_axis;
  e1 = axis.unitOrthogonal();
  e2 = axis.cross(e1);
  const std::size_t n = c.x.size();
  std::vector<int> bin(n);
  std::size_t count[kBins] = {};
  for (std::size_t i = 0; i < n; ++i) {
    const Vector3d nn(c.nx[i], c.ny[i], c.nz[i]);
    const double u = nn.dot(e1), v = nn.dot(e2), a = nn.dot(axis);
    const int b = bin_of(line_pseudo_angle(u, v));
    bin[i] = b;
    ++count[b];
    max_along[b] = std::max(max_along[b], std::abs(a));
    max_across[b] = std::max(max_across[b], std::sqrt(u * u + v * v));
  }
  start[0] = 0;
  for (int b = 0; b < kBins; ++b) start[b + 1] = start[b] + count[b];
  std::size_t next[kBins];
  for (int b = 0; b < kBins; ++b) next[b] = start[b];
  x.resize(n);
  y.resize(n);
  z.resize(n);
  nx.resize(n);
  ny.resize(n);
  nz.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    const std::size_t j = next[bin[i]]++;
    x[j] = c.x[i];
    y[j] = c.y[i];
    z[j] = c.z[i];
    nx[j] = c.nx[i];
    ny[j] = c.ny[i];
    nz[j] = c.nz[i];
  }
  for (int b = 0; b <= kBins; ++b) {  // the direction whose pseudo-angle is the edge's
    const double t = 2.0 * b / kBins;
    const double u = 1.0 - t, v = t <= 1.0 ? t : 2.0 - t;
    const double len = std::sqrt(u * u + v * v);
    edge_u[b] = u / len;
    edge_v[b] = v / len;
  }
}

std::size_t NormalBins::count(const Vector3d& h, float a, float b, float cc, float d, float tau, float cos_max,
                              std::size_t beat) const {
  const double ha = std::abs(h.dot(axis)), hu = h.dot(e1), hv = h.dot(e2);
  const double hp = std::sqrt(hu * hu + hv * hv);
  const int hb = bin_of(line_pseudo_angle(hu, hv));
  const double du = hp > 0.0 ? hu / hp : 0.0, dv = hp > 0.0 ? hv / hp : 0.0;
  // Margin for the float arithmetic of the inlier test (|error| ~1e-6).
  const double need = static_cast<double>(cos_max) - 1e-4;
  int visit[kBins];
  int num_visit = 0;
  std::size_t remaining = 0;
  for (int k = 0; k < kBins; ++k) {
    if (start[k + 1] == start[k]) continue;
    const double cos_max_bin =
        k == hb ? 1.0
                : std::max(std::abs(du * edge_u[k] + dv * edge_v[k]), std::abs(du * edge_u[k + 1] + dv * edge_v[k + 1]));
    if (ha * max_along[k] + hp * max_across[k] * std::min(1.0, cos_max_bin) < need) continue;
    visit[num_visit++] = k;
    remaining += start[k + 1] - start[k];
  }
  std::size_t total = 0;
  for (int v = 0; v < num_visit; ++v) {
    const std::size_t begin = start[visit[v]], end = start[visit[v] + 1];
    std::uint32_t in_bin = 0;
    for (std::size_t i = begin; i < end; ++i) {
      const float dist = std::abs(a * x[i] + b * y[i] + cc * z[i] - d);
      const float agree = std::abs(a * nx[i] + b * ny[i] + cc * nz[i]);
      in_bin += static_cast<std::uint32_t>((dist < tau) & (agree >= cos_max));
    }
    total += in_bin;
    remaining -= end - begin;
    if (total + remaining <= beat) return total;
  }
  return total;
}

/// Whether a unit normal satisfies the axis constraint (axis unit, cos/sin of ε precomputed).
bool plane_constraint_ok(const Vector3d& n, AxisConstraint constraint, const Vector3d& axis,
                         double cos_eps, double sin_eps) {
  switch (constraint) {
    case AxisConstraint::kNone: return true;
    case AxisConstraint::kPerpendicular: return std::abs(n.dot(axis)) >= cos_eps;
    case AxisConstraint::kParallel: return std::abs(n.dot(axis)) <= sin_eps;
  }
  return true;
}

/// Orient a plane's normal toward the origin (D <= 0); through the origin: normal . axis >= 0.
void orient_plane(Plane& p, const Vector3d& axis) {
  const double tol = 1e-9;
  if (p.offset > tol || (std::abs(p.offset) <= tol && p.normal.dot(axis) < 0.0)) {
    p.normal = -p.normal;
    p.offset = -p.offset;
  }
}

/// Checks the settings and the inputs' sizes of fit_plane_ransac().
void check_plane_ransac_inputs(const std::vector<Vector3f>& points, const std::vector<Vector3f>& normals,
                               const PlaneRansacSettings& s) {
  PLUMB_CHECK(std::isfinite(s.distance_threshold) && s.distance_threshold > 0.0,
              "fit_plane_ransac: distance_threshold = " << s.distance_threshold << " must be finite and > 0");
  PLUMB_CHECK(s.max_iterations >= 1, "fit_plane_ransac: max_iterations = " << s.max_iterations << " must be >= 1");
  PLUMB_CHECK(s.confidence >= 0.0 && s.confidence <= 1.0,
              "fit_plane_ransac: confidence = " << s.confidence << " must be in [0, 1]");
  PLUMB_CHECK(s.axis.allFinite() && s.axis.norm() > 0.0, "fit_plane_ransac: settings.axis must be non-zero");
  PLUMB_CHECK(std::isfinite(s.max_axis_angle) && s.max_axis_angle >= 0.0,
              "fit_plane_ransac: max_axis_angle = " << s.max_axis_angle << " must be finite and >= 0");
  PLUMB_CHECK(!std::isnan(s.max_normal_angle), "fit_plane_ransac: max_normal_angle is NaN");
  PLUMB_CHECK(s.min_inliers >= 3, "fit_plane_ransac: min_inliers = " << s.min_inliers << " must be >= 3");
  PLUMB_CHECK(normals.empty() || normals.size() == points.size(),
              "fit_plane_ransac: " << normals.size() << " normals for " << points.size() << " points");
  PLUMB_CHECK(s.sampling != PlaneSampling::kPointNormal || !normals.empty(),
              "fit_plane_ransac: kPointNormal sampling needs normals");
}

/// Gathers the finite candidates into `c` (their normals too when c.has_normals is set) and, for
/// kPointNormal sampling, their normals as given into `sample_normals`.
void gather_plane_candidates(const std::vector<Vector3f>& points, const std::vector<std::size_t>& candidates,
                             const std::vector<Vector3f>& normals, bool point_normal, PlaneCandidates& c,
                             std::vector<Vector3f>& sample_normals) {
  const std::size_t m = candidates.empty() ? points.size() : candidates.size();
  c.x.reserve(m);
  c.y.reserve(m);
  c.z.reserve(m);
  c.index.reserve(m);
  if (c.has_normals) {
    c.nx.reserve(m);
    c.ny.reserve(m);
    c.nz.reserve(m);
  }
  if (point_normal) sample_normals.reserve(m);
  for (std::size_t j = 0; j < m; ++j) {
    const std::size_t i = candidates.empty() ? j : candidates[j];
    PLUMB_CHECK(i < points.size(), "fit_plane_ransac: candidate index " << i << " out of range for "
                                                                        << points.size() << " points");
    const Vector3f& p = points[i];
    if (!p.allFinite()) continue;
    c.x.push_back(p.x());
    c.y.push_back(p.y());
    c.z.push_back(p.z());
    c.index.push_back(i);
    if (point_normal) sample_normals.push_back(normals[i]);
    if (c.has_normals) {
      const Vector3f& nn = normals[i];
      const bool ok = nn.allFinite();
      c.nx.push_back(ok ? nn.x() : 0.0f);
      c.ny.push_back(ok ? nn.y() : 0.0f);
      c.nz.push_back(ok ? nn.z() : 0.0f);  // a zero normal never agrees (cos_normal > -1 ... see below)
    }
  }
}

/// Draws one plane hypothesis (unit normal `nrm` through `p0`): a candidate and its normal
/// (kPointNormal), or three distinct candidates. False when the drawn points give no plane (a bad
/// normal, collinear points); the random draws are the same either way.
bool sample_plane_hypothesis(Rng& rng, const PlaneCandidates& c, const std::vector<Vector3f>& sample_normals,
                             bool point_normal, Vector3d& nrm, Vector3d& p0) {
  const std::size_t n = c.index.size();
  if (point_normal) {
    const std::size_t i0 = static_cast<std::size_t>(rng.uniform_index(n));
    const Vector3f& nf = sample_normals[i0];
    if (!nf.allFinite() || !(nf.squaredNorm() > 0.0f)) return false;
    nrm = nf.cast<double>().normalized();
    p0 = Vector3d(c.x[i0], c.y[i0], c.z[i0]);
    return true;
  }
  const std::size_t i0 = static_cast<std::size_t>(rng.uniform_index(n));
  std::size_t i1 = static_cast<std::size_t>(rng.uniform_index(n - 1));
  if (i1 >= i0) ++i1;
  std::size_t i2 = static_cast<std::size_t>(rng.uniform_index(n - 2));
  // map i2 into [0, n) \ {i0, i1}
  const std::size_t lo = std::min(i0, i1), hi = std::max(i0, i1);
  if (i2 >= lo) ++i2;
  if (i2 >= hi) ++i2;
  p0 = Vector3d(c.x[i0], c.y[i0], c.z[i0]);
  const Vector3d p1(c.x[i1], c.y[i1], c.z[i1]);
  const Vector3d p2(c.x[i2], c.y[i2], c.z[i2]);
  const Vector3d e1 = p1 - p0, e2 = p2 - p0;
  nrm = e1.cross(e2);
  const double len = nrm.norm();
  if (!(len > 1e-12 * std::max(1e-300, e1.squaredNorm() + e2.squaredNorm()))) return false;  // collinear
  nrm /= len;
  return true;
}

/// The cloud indices of the candidates within `tau` of `pl` whose normal agrees (when c.has_normals),
/// in candidate order.
void collect_plane_inliers(const PlaneCandidates& c, const Plane& pl, float tau, float cos_normal,
                           std::vector<std::size_t>& inl) {
  inl.clear();
  const float a = static_cast<float>(pl.normal.x()), b = static_cast<float>(pl.normal.y()),
              cc = static_cast<float>(pl.normal.z()), d = static_cast<float>(pl.offset);
  for (std::size_t j = 0; j < c.index.size(); ++j) {
    const float dist = std::abs(a * c.x[j] + b * c.y[j] + cc * c.z[j] - d);
    bool ok = dist < tau;
    if (ok && c.has_normals) ok = std::abs(a * c.nx[j] + b * c.ny[j] + cc * c.nz[j]) >= cos_normal;
    if (ok) inl.push_back(c.index[j]);
  }
}

/// Lowers `needed`, the iterations after which a hypothesis as good as one with inlier fraction `w`
/// would have been drawn with probability `confidence` (log_fail = log(1 - confidence)).
void update_needed_iterations(double w, bool point_normal, double confidence, double log_fail,
                              double& needed) {
  const double w3 = point_normal ? w : w * w * w;
  if (confidence < 1.0) {
    if (w3 >= 1.0) {
      needed = 0.0;
    } else if (w3 > 0.0) {
      needed = std::min(needed, log_fail / std::log1p(-w3));
    }
  }
}

}  // namespace detail

bool fit_plane_least_squares(const std::vector<Vector3f>& points, const std::vector<std::size_t>& indices,
                             Plane& plane, double* rmse) {
  const bool all = indices.empty();
  const std::size_t m = all ? points.size() : indices.size();
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  std::size_t n = 0;
  for (std::size_t j = 0; j < m; ++j) {
    const std::size_t i = all ? j : indices[j];
    PLUMB_CHECK(i < points.size(), "fit_plane_least_squares: index " << i << " out of range for "
                                                                     << points.size() << " points");
    if (!points[i].allFinite()) continue;
    mean += points[i].cast<double>();
    ++n;
  }
  if (n < 3) return false;
  mean /= static_cast<double>(n);
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (std::size_t j = 0; j < m; ++j) {
    const std::size_t i = all ? j : indices[j];
    if (!points[i].allFinite()) continue;
    const Eigen::Vector3d d = points[i].cast<double>() - mean;
    cov.noalias() += d * d.transpose();
  }
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(cov);
  if (es.info() != Eigen::Success) return false;
  const Eigen::Vector3d ev = es.eigenvalues();  // ascending
  // Collinear (or coincident) points: the two smallest eigenvalues vanish relative to the largest.
  if (!(ev(1) > 1e-12 * std::max(ev(2), 1e-300))) return false;
  plane.normal = es.eigenvectors().col(0).normalized();
  plane.offset = plane.normal.dot(mean);
  if (rmse != nullptr) *rmse = std::sqrt(std::max(0.0, ev(0)) / static_cast<double>(n));
  return plane.normal.allFinite();
}

namespace detail {

/// Least-squares refit of `best` to its `inliers` (settings.refine): the refit replaces the plane
/// and its inliers when it satisfies the axis constraint and keeps at least as many inliers.
void refit_plane(const std::vector<Vector3f>& points, const PlaneCandidates& c, const PlaneRansacSettings& s,
                 const Vector3d& axis, double cos_eps, double sin_eps, float tau, float cos_normal, Plane& best,
                 std::vector<std::size_t>& inliers) {
  Plane refit;
  if (fit_plane_least_squares(points, inliers, refit) &&
      plane_constraint_ok(refit.normal, s.constraint, axis, cos_eps, sin_eps)) {
    std::vector<std::size_t> refit_inliers;
    collect_plane_inliers(c, refit, tau, cos_normal, refit_inliers);
    if (refit_inliers.size() >= inliers.size()) {
      best = refit;
      inliers = std::move(refit_inliers);
    }
  }
}

}  // namespace detail

PlaneRansacResult fit_plane_ransac(const std::vector<Vector3f>& points,
                                   const std::vector<std::size_t>& candidates,
                                   const std::vector<Vector3f>& normals,
                                   const PlaneRansacSettings& settings) {
  const PlaneRansacSettings& s = settings;
  detail::check_plane_ransac_inputs(points, normals, s);
  const bool point_normal = s.sampling == PlaneSampling::kPointNormal;

  PlaneRansacResult out;
  const Vector3d axis = s.axis.normalized();
  const double cos_eps = std::cos(std::min(s.max_axis_angle, 1.5707963267948966));
  const double sin_eps = std::sin(std::min(s.max_axis_angle, 1.5707963267948966));
  const float cos_normal = s.max_normal_angle >= 1.5707963267948966
                               ? -1.0f
                               : static_cast<float>(std::cos(std::max(0.0, s.max_normal_angle)));
  const float tau = static_cast<float>(s.distance_threshold);

  // Gather the finite candidates.
  detail::PlaneCandidates c;
  c.has_normals = !normals.empty() && cos_normal > -1.0f;
  std::vector<Vector3f> sample_normals;  // kPointNormal: the candidates' normals
  detail::gather_plane_candidates(points, candidates, normals, point_normal, c, sample_normals);
  const std::size_t n = c.index.size();
  out.num_candidates = n;
  if (n < 3 || n < s.min_inliers) return out;  // kInsufficientData
  // A zero normal gives agreement 0, which passes only when cos_normal <= 0, i.e. never here.

  // Normal agreement required (cos > 0): count through the bins of normal directions.
  detail::NormalBins bins;
  const bool use_bins = c.has_normals && cos_normal > 0.0f && n >= 128;
  if (use_bins) bins.build(c, axis);

  Rng rng(s.seed);
  std::size_t best_count = 0;
  Plane best;
  bool have_best = false;
  double needed = static_cast<double>(s.max_iterations);
  const double log_fail = std::log(std::max(1e-300, 1.0 - s.confidence));
  int it = 0;
  while (it < s.max_iterations && static_cast<double>(it) < needed) {
    ++it;
    Vector3d nrm;
    Vector3d p0;
    if (!detail::sample_plane_hypothesis(rng, c, sample_normals, point_normal, nrm, p0)) continue;
    if (!detail::plane_constraint_ok(nrm, s.constraint, axis, cos_eps, sin_eps)) continue;
    const double d = nrm.dot(p0);
    const std::size_t count =
        use_bins ? bins.count(nrm, static_cast<float>(nrm.x()), static_cast<float>(nrm.y()),
                              static_cast<float>(nrm.z()), static_cast<float>(d), tau, cos_normal,
                              have_best ? best_count : 0)
                 : detail::count_plane_inliers(c, static_cast<float>(nrm.x()), static_cast<float>(nrm.y()),
                                               static_cast<float>(nrm.z()), static_cast<float>(d), tau, cos_normal,
                                               have_best ? best_count : 0);
    if (!have_best || count > best_count) {
      have_best = true;
      best_count = count;
      best.normal = nrm;
      best.offset = d;
      const double w = static_cast<double>(count) / static_cast<double>(n);
      detail::update_needed_iterations(w, point_normal, s.confidence, log_fail, needed);
    }
  }
  out.iterations = it;
  out.converged = needed < static_cast<double>(s.max_iterations) && static_cast<double>(it) >= needed;
  if (!have_best) {
    out.status = Status::kDegenerate;
    return out;
  }

  std::vector<std::size_t> inliers;
  detail::collect_plane_inliers(c, best, tau, cos_normal, inliers);
  if (s.refine && inliers.size() >= 3) {
    detail::refit_plane(points, c, s, axis, cos_eps, sin_eps, tau, cos_normal, best, inliers);
  }
  std::sort(inliers.begin(), inliers.end());
  detail::orient_plane(best, axis);
  double sum_sq = 0.0;
  for (std::size_t i : inliers) {
    const double dist = best.signed_distance(points[i]);
    sum_sq += dist * dist;
  }
  out.rmse = inliers.empty() ? 0.0 : std::sqrt(sum_sq / static_cast<double>(inliers.size()));
  out.plane = best;
  out.inliers = std::move(inliers);
  out.status = out.inliers.size() >= s.min_inliers ? Status::kOk : Status::kInsufficientData;
  return out;
}

}  // namespace plumb
