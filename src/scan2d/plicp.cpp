// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/scan2d/plicp.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Eigenvalues>
#include <Eigen/LU>

#include "plumb/core/error.hpp"

#include "core/eigen_instantiations.hpp"

namespace plumb {

namespace {

/// Whether consecutive chain points a, b (seen from `origin`) lie on one surface: closer than
/// `max_gap`, or, at grazing incidence far away, closer than `grazing_factor` times the spacing
/// the beams' angle would give at normal incidence (|a - origin| * angle between the beams).
bool linked(const Vector2d& a, const Vector2d& b, const Vector2d* origin, double max_gap, double grazing_factor) {
  const double gap_sq = (a - b).squaredNorm();
  if (gap_sq < max_gap * max_gap) return true;
  if (origin == nullptr || !(grazing_factor > 0.0)) return false;
  const Vector2d ra = a - *origin, rb = b - *origin;
  const double r = std::min(ra.norm(), rb.norm());
  const double angle = std::atan2(std::abs(ra.x() * rb.y() - ra.y() * rb.x()), ra.dot(rb));
  const double allowed = grazing_factor * r * angle;
  return gap_sq < allowed * allowed;
}

/// link[k] != 0 when points k - 1 and k are neighbours on one surface (link[0] = 0).
std::vector<char> chain_links(const std::vector<Vector2d>& pts, const Vector2d* origin, double max_gap,
                              double grazing_factor) {
  std::vector<char> link(pts.size(), 0);
  for (std::size_t k = 1; k < pts.size(); ++k) link[k] = linked(pts[k - 1], pts[k], origin, max_gap, grazing_factor) ? 1 : 0;
  return link;
}

/// Unit normals of an ordered point chain: the chord between the nearest chain points at least
/// `baseline` away on either side (walking along linked points), so
/// that range noise on densely sampled scans does not randomise them; zero where none exists.
/// The walk steps one point at a time for 16 points, then by 1/16 of the way walked: on scans of
/// very many beams (a CARMEN log may carry 10^6) the cost per point stays logarithmic in the
/// number of points within the baseline instead of linear, and the chord at most ~6 % longer.
std::vector<Vector2d> chain_normals(const std::vector<Vector2d>& pts, const std::vector<char>& link, double baseline) {
  const std::size_t n = pts.size();
  std::vector<Vector2d> normals(n, Vector2d::Zero());
  const double base_sq = baseline * baseline;
  // first[i] / last[i]: the ends of the run of linked points around i.
  std::vector<std::size_t> first(n), last(n);
  for (std::size_t i = 0; i < n; ++i) first[i] = i > 0 && link[i] ? first[i - 1] : i;
  for (std::size_t i = n; i-- > 0;) last[i] = i + 1 < n && link[i + 1] ? last[i + 1] : i;
  constexpr std::size_t kUnitSteps = 16;
  for (std::size_t i = 0; i < n; ++i) {
    std::size_t lo = i, hi = i;
    for (std::size_t off = 0; lo > first[i] && (pts[lo] - pts[i]).squaredNorm() < base_sq;) {
      off += off < kUnitSteps ? 1 : off / kUnitSteps;
      lo = off >= i - first[i] ? first[i] : i - off;
    }
    for (std::size_t off = 0; hi < last[i] && (pts[hi] - pts[i]).squaredNorm() < base_sq;) {
      off += off < kUnitSteps ? 1 : off / kUnitSteps;
      hi = off >= last[i] - i ? last[i] : i + off;
    }
    const Vector2d d = pts[hi] - pts[lo];
    const double len = d.norm();
    if (hi > lo && len > 1e-9) normals[i] = Vector2d(-d.y() / len, d.x() / len);
  }
  return normals;
}

}  // namespace

// ---- reference -----------------------------------------------------------------------------------

PlicpReference::PlicpReference(const LaserScan& scan, const PlicpReferenceSettings& settings) {
  scan.check_consistent("PlicpReference");
  const Vector2d origin = Vector2d::Zero();
  add_chain(scan.to_points(), &origin, settings);
  build();
}

PlicpReference::PlicpReference(const std::vector<const LaserScan*>& scans,
                               const std::vector<Pose2>& T_ref_scans,
                               const PlicpReferenceSettings& settings) {
  PLUMB_CHECK(scans.size() == T_ref_scans.size(),
              "PlicpReference: " << scans.size() << " scans but " << T_ref_scans.size() << " poses");
  for (std::size_t k = 0; k < scans.size(); ++k) {
    PLUMB_CHECK(scans[k] != nullptr, "PlicpReference: scan " << k << " is null");
    scans[k]->check_consistent("PlicpReference");
    std::vector<Vector2d> chain = scans[k]->to_points();
    for (auto& p : chain) p = T_ref_scans[k] * p;
    const Vector2d origin(T_ref_scans[k].x, T_ref_scans[k].y);
    add_chain(chain, &origin, settings);
  }
  build();
}

PlicpReference::PlicpReference(const std::vector<std::vector<Vector2d>>& chains,
                               const PlicpReferenceSettings& settings) {
  for (const auto& chain : chains) add_chain(chain, nullptr, settings);
  build();
}

void PlicpReference::add_chain(const std::vector<Vector2d>& chain, const Vector2d* origin,
                               const PlicpReferenceSettings& settings) {
  std::vector<Vector2d> pts;
  pts.reserve(chain.size());
  for (const Vector2d& p : chain) {
    if (p.allFinite()) pts.push_back(p);
  }
  normal_baseline_ = settings.normal_baseline;
  const std::vector<char> link = chain_links(pts, origin, settings.max_neighbor_distance, settings.grazing_factor);
  const std::vector<Vector2d> normals = chain_normals(pts, link, settings.normal_baseline);
  const int first = static_cast<int>(points_.size());
  for (std::size_t k = 0; k < pts.size(); ++k) {
    const int i = first + static_cast<int>(k);
    points_.push_back(pts[k]);
    normals_.push_back(normals[k]);
    prev_.push_back(-1);
    next_.push_back(-1);
    if (link[k]) {
      prev_.back() = i - 1;
      next_[static_cast<std::size_t>(i - 1)] = i;
    }
  }
}

void PlicpReference::build() {
  tree_.clear();
  if (points_.empty()) return;
  std::vector<Eigen::Vector2f> pts(points_.size());
  for (std::size_t i = 0; i < points_.size(); ++i) pts[i] = points_[i].cast<float>();
  KdTreeSettings ks;
  ks.leaf_size = 8;
  tree_.emplace_back(pts, ks);
}

// ---- the closed-form solver of eq. 17 -------------------------------------------------------------
//
// With x = (t_x, t_y, c, s), c = cos θ, s = sin θ, each residual is linear in x:
//   e_i = n_i^T (R(θ) p_i + t - q_i) = m_i^T x - b_i,
//   m_i = (n_x, n_y, n_x p_x + n_y p_y, n_y p_x - n_x p_y),  b_i = n_i^T q_i,
// so J = Σ w_i e_i^2 = x^T M x - 2 g^T x + const with M = Σ w m m^T, g = Σ w b m, to be minimised
// under the constraint c^2 + s^2 = 1 (Censi 2008 solves this with a Lagrange multiplier, which
// leads to a quartic in λ). Our derivation: split M = [A B; B^T D], g = (g_t, g_y), y = (c, s).
// For fixed y the best translation is t(y) = A^-1 (g_t - B y); substituting gives
//   J(y) = y^T S y - 2 h^T y + const,  S = D - B^T A^-1 B,  h = g_y - B^T A^-1 g_t,
// minimised on the unit circle. Stationarity of y^T S y - 2 h^T y + λ (y^T y - 1) gives
// (S + λ I) y = h, and the global minimum is the one with S + λ I positive semi-definite, i.e.
// λ >= -σ1 (σ1 <= σ2 the eigenvalues of S). With S = V diag(σ) V^T and h' = V^T h the constraint
// becomes the secular equation φ(λ) = h1'^2 / (σ1 + λ)^2 + h2'^2 / (σ2 + λ)^2 = 1 (multiplied
// out it is Censi's quartic; our root is its largest real root). φ decreases from +inf
// to 0 on (-σ1, inf) and φ(λ) <= |h|^2 / (σ1 + λ)^2, so the root lies in (-σ1, -σ1 + |h|]; we find
// it to machine precision by Newton steps safeguarded with bisection. If h1' = 0 (the "hard case")
// the root may sit at λ = -σ1: then y2' = h2' / (σ2 - σ1) and y1' = ±sqrt(1 - y2'^2).

namespace {

/// Unit vector y minimising y^T S y - 2 h^T y on the unit circle.
Vector2d min_on_circle(const Eigen::Matrix2d& S, const Vector2d& h) {
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> es(S);
  const double s1 = es.eigenvalues()(0), s2 = es.eigenvalues()(1);
  const Vector2d hp = es.eigenvectors().transpose() * h;
  const double scale = std::max({std::abs(s1), std::abs(s2), h.norm(), 1e-300});
  const double h1 = hp(0), h2 = hp(1);
  Vector2d yp;
  // Hard case: the secular function stays below 1 at λ -> -σ1.
  const double gap = s2 - s1;
  const bool tiny_h1 = std::abs(h1) <= 1e-14 * scale;
  if (tiny_h1 && (gap <= 0.0 || std::abs(h2) < gap)) {
    const double y2 = gap > 0.0 ? h2 / gap : 0.0;
    yp = Vector2d(std::sqrt(std::max(0.0, 1.0 - y2 * y2)), y2);
    if (h1 < 0.0) yp(0) = -yp(0);
  } else {
    auto phi = [&](double lambda, double& dphi) {
      const double a = s1 + lambda, b = s2 + lambda;
      const double ta = h1 * h1 / (a * a), tb = h2 * h2 / (b * b);
      dphi = -2.0 * (ta / a + tb / b);
      return ta + tb - 1.0;
    };
    double lo = -s1, hi = -s1 + h.norm();
    double lambda = hi;
    for (int it = 0; it < 200; ++it) {
      double d = 0.0;
      const double f = phi(lambda, d);
      if (f > 0.0) lo = lambda; else hi = lambda;
      if (f == 0.0 || hi - lo <= 4.0 * std::numeric_limits<double>::epsilon() * (std::abs(lo) + scale)) {
        break;
      }
      double next = lambda - f / d;
      if (!(next > lo && next < hi)) next = 0.5 * (lo + hi);
      if (next == lambda) break;
      lambda = next;
    }
    yp = Vector2d(h1 / (s1 + lambda), h2 / (s2 + lambda));
  }
  Vector2d y = es.eigenvectors() * yp;
  const double n = y.norm();
  return n > 0.0 ? Vector2d(y / n) : Vector2d(1.0, 0.0);
}

}  // namespace

namespace {

/// Normal equations of eq. 17 in x = (t_x, t_y, cos θ, sin θ): J = x^T M x - 2 g^T x + const.
struct NormalEquations {
  Eigen::Matrix4d M = Eigen::Matrix4d::Zero();
  Eigen::Vector4d g = Eigen::Vector4d::Zero();
};

NormalEquations accumulate(const std::vector<PointToLinePair>& pairs) {
  NormalEquations ne;
  for (const PointToLinePair& pr : pairs) {
    const Vector2d& n = pr.normal;
    const Eigen::Vector4d m(n.x(), n.y(), n.x() * pr.p.x() + n.y() * pr.p.y(),
                            n.y() * pr.p.x() - n.x() * pr.p.y());
    ne.M.noalias() += pr.weight * m * m.transpose();
    ne.g.noalias() += pr.weight * n.dot(pr.q) * m;
  }
  return ne;
}

/// Exact constrained minimiser of J plus an optional proximal term
/// mu_t |t - t0|^2 + mu_r |y - y0|^2 around T0 (on the circle the second is linear in y, so the
/// problem keeps its form). mu = 0 gives eq. 17 alone.
bool solve_normal_equations(const NormalEquations& ne, const Pose2& T0, double mu_t, double mu_r,
                            Pose2& T) {
  if (!ne.M.allFinite() || !ne.g.allFinite()) return false;
  Eigen::Matrix2d A = ne.M.topLeftCorner<2, 2>();
  const Eigen::Matrix2d B = ne.M.topRightCorner<2, 2>();
  const Eigen::Matrix2d D = ne.M.bottomRightCorner<2, 2>();
  Vector2d gt = ne.g.head<2>();
  Vector2d gy = ne.g.tail<2>();
  const double trace_a = A.trace();
  if (!(trace_a > 0.0)) return false;
  A += mu_t * Eigen::Matrix2d::Identity();
  gt += mu_t * Vector2d(T0.x, T0.y);
  gy += mu_r * Vector2d(std::cos(T0.theta), std::sin(T0.theta));
  // A singular A (all normals parallel: a corridor) leaves a translation direction free; a tiny
  // pull towards T0 keeps that component where it was instead of failing.
  if (A.determinant() < 1e-10 * trace_a * trace_a) {
    const double eps = 1e-9 * trace_a;
    A += eps * Eigen::Matrix2d::Identity();
    gt += eps * Vector2d(T0.x, T0.y);
  }
  const Eigen::Matrix2d A_inv = A.inverse();
  const Eigen::Matrix2d S = D - B.transpose() * A_inv * B;
  const Vector2d h = gy - B.transpose() * A_inv * gt;
  const Vector2d y = min_on_circle(0.5 * (S + S.transpose()), h);
  const Vector2d t = A_inv * (gt - B * y);
  if (!t.allFinite() || !y.allFinite()) return false;
  T = Pose2{t.x(), t.y(), std::atan2(y.y(), y.x())};
  return true;
}

}  // namespace

bool solve_point_to_line(const std::vector<PointToLinePair>& pairs, Pose2& T) {
  if (pairs.size() < 3) return false;
  return solve_normal_equations(accumulate(pairs), T, 0.0, 0.0, T);
}

// ---- the ICP loop -------------------------------------------------------------------------------

namespace {

struct Candidate {
  PointToLinePair pair;
  double dist = 0.0;  ///< |point-to-line distance| at the current estimate [m]
};

/// Find, gate and trim the correspondences of `points` under T (Liu et al. 2022, sec. 3.2, steps 1-2).
void find_pairs(const std::vector<Vector2d>& points, const std::vector<Vector2d>& normals,
                const PlicpReference& ref, const Pose2& T, const PlicpSettings& s,
                std::vector<Candidate>& cands, std::vector<PointToLinePair>& pairs) {
  cands.clear();
  pairs.clear();
  const KdTree2f& tree = *ref.tree();
  const float gate_sq = static_cast<float>(s.max_correspondence_distance * s.max_correspondence_distance);
  const double min_cos = s.max_normal_angle < 3.14159 ? std::cos(s.max_normal_angle) : -1.0;
  const double c = std::cos(T.theta), sn = std::sin(T.theta);
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Vector2d& p = points[i];
    const Vector2d pw(c * p.x() - sn * p.y() + T.x, sn * p.x() + c * p.y() + T.y);  // eq. 16
    const auto nb = tree.nearest(Eigen::Vector2f(static_cast<float>(pw.x()), static_cast<float>(pw.y())),
                                 gate_sq);
    if (!nb) continue;
    const std::size_t j1 = nb->index;
    const int jp = ref.prev(j1), jn = ref.next(j1);
    if (jp < 0 && jn < 0) continue;
    int j2 = jp >= 0 ? jp : jn;
    if (jp >= 0 && jn >= 0) {
      const double dp = (ref.point(static_cast<std::size_t>(jp)) - pw).squaredNorm();
      const double dn = (ref.point(static_cast<std::size_t>(jn)) - pw).squaredNorm();
      j2 = dn < dp ? jn : jp;
    }
    const Vector2d& q1 = ref.point(j1);
    const Vector2d seg = ref.point(static_cast<std::size_t>(j2)) - q1;
    const double len = seg.norm();
    if (!(len > 1e-9)) continue;
    // The line through j1: the chord to j2, or, where that chord is shorter than the normal
    // baseline (dense beams, whose range noise would turn a short chord), j1's smoothed normal.
    Vector2d n(-seg.y() / len, seg.x() / len);
    if (len < ref.normal_baseline() && ref.normal(j1).squaredNorm() > 0.0) n = ref.normal(j1);
    if (min_cos > -1.0 && normals[i].squaredNorm() > 0.0 && ref.normal(j1).squaredNorm() > 0.0) {
      const Vector2d& m = normals[i];
      const Vector2d mw(c * m.x() - sn * m.y(), sn * m.x() + c * m.y());
      if (std::abs(mw.dot(ref.normal(j1))) < min_cos) continue;  // differently oriented surfaces
    }
    Candidate cand;
    cand.pair.p = p;
    cand.pair.q = q1;
    cand.pair.normal = n;
    cand.dist = std::abs(n.dot(pw - q1));
    if (cand.dist > s.max_correspondence_distance) continue;
    cands.push_back(cand);
  }
  if (cands.empty()) return;
  // Trim: keep the best fraction, then the adaptive gate relative to their median.
  const double frac = std::clamp(s.trim_fraction, 0.0, 1.0);
  std::size_t keep = static_cast<std::size_t>(std::floor(frac * static_cast<double>(cands.size())));
  keep = std::max<std::size_t>(1, std::min(keep, cands.size()));
  std::sort(cands.begin(), cands.end(),
            [](const Candidate& a, const Candidate& b) { return a.dist < b.dist; });
  double limit = std::numeric_limits<double>::infinity();
  if (s.outlier_median_factor > 0.0) {
    const double median = cands[(keep - 1) / 2].dist;
    limit = std::max(s.outlier_median_factor * median, s.outlier_min_distance);
  }
  for (std::size_t i = 0; i < keep && cands[i].dist <= limit; ++i) pairs.push_back(cands[i].pair);
}

}  // namespace

PlicpResult plicp(const std::vector<Vector2d>& current_points, const PlicpReference& reference,
                  const Pose2& T_ref_cur_guess, const PlicpSettings& settings) {
  PlicpResult result;
  result.T_ref_cur = T_ref_cur_guess;
  PLUMB_CHECK(settings.max_iterations > 0, "plicp: max_iterations must be positive");
  PLUMB_CHECK(settings.max_correspondence_distance > 0.0,
              "plicp: max_correspondence_distance must be positive");
  if (!std::isfinite(T_ref_cur_guess.x) || !std::isfinite(T_ref_cur_guess.y) ||
      !std::isfinite(T_ref_cur_guess.theta)) {
    result.status = Status::kInvalidInput;
    return result;
  }
  std::vector<Vector2d> points;
  points.reserve(current_points.size());
  for (const auto& p : current_points) {
    if (p.allFinite()) points.push_back(p);
  }
  result.num_points = points.size();
  if (points.size() < 3 || reference.tree() == nullptr) {
    result.status = points.empty() || reference.tree() == nullptr ? Status::kInvalidInput
                                                                  : Status::kInsufficientData;
    return result;
  }

  const Vector2d origin = Vector2d::Zero();
  const std::vector<Vector2d> normals = chain_normals(
      points, chain_links(points, &origin, settings.max_neighbor_distance, settings.grazing_factor),
      settings.normal_baseline);
  std::vector<Candidate> cands;
  std::vector<PointToLinePair> pairs;
  cands.reserve(points.size());
  pairs.reserve(points.size());
  Pose2 T = T_ref_cur_guess;
  const std::size_t min_pairs = std::max<std::size_t>(settings.min_valid_pairs, 3);
  result.status = Status::kNotConverged;
  for (int it = 0; it < settings.max_iterations; ++it) {
    find_pairs(points, normals, reference, T, settings, cands, pairs);
    result.iterations = it + 1;
    if (pairs.size() < min_pairs) {
      result.status = Status::kInsufficientData;
      break;
    }
    // Exact solve of eq. 17; when the step leaves the region where the correspondences can be
    // trusted, add a growing proximal term around T (still solved exactly) until it does not.
    const NormalEquations ne = accumulate(pairs);
    const double mu_scale = 0.5 * (ne.M(0, 0) + ne.M(1, 1));
    const double mu_scale_r = 0.5 * (ne.M(2, 2) + ne.M(3, 3));
    Pose2 T_new = T;
    bool solved = false;
    double kappa = 0.0;
    for (int damp = 0; damp < 30; ++damp) {
      Pose2 T_try = T;
      if (!solve_normal_equations(ne, T, kappa * mu_scale, kappa * mu_scale_r, T_try)) break;
      solved = true;
      T_new = T_try;
      if (std::hypot(T_try.x - T.x, T_try.y - T.y) <= settings.max_step_xy &&
          std::abs(wrap_angle(T_try.theta - T.theta)) <= settings.max_step_theta) {
        break;
      }
      kappa = kappa == 0.0 ? 0.01 : 4.0 * kappa;
    }
    if (!solved) {
      result.status = Status::kInsufficientData;
      break;
    }
    const double dxy = std::hypot(T_new.x - T.x, T_new.y - T.y);
    const double dth = std::abs(wrap_angle(T_new.theta - T.theta));
    T = T_new;
    if (kappa == 0.0 && dxy < settings.epsilon_xy && dth < settings.epsilon_theta) {
      result.converged = true;
      result.status = Status::kOk;
      break;
    }
  }
  T.theta = wrap_angle(T.theta);
  result.T_ref_cur = T;
  result.num_valid_pairs = pairs.size();
  result.valid_fraction = static_cast<double>(pairs.size()) / static_cast<double>(points.size());
  if (pairs.size() < 3) return result;

  // Error (eq. 18), Hessian-based covariance and degeneracy at the solution.
  const double c = std::cos(T.theta), sn = std::sin(T.theta);
  Matrix3d H = Matrix3d::Zero();
  double sum_sq = 0.0, sum_r2 = 0.0;
  for (const PointToLinePair& pr : pairs) {
    const Vector2d Rp(c * pr.p.x() - sn * pr.p.y(), sn * pr.p.x() + c * pr.p.y());
    const double e = pr.normal.dot(Rp + Vector2d(T.x, T.y) - pr.q);
    const Vector2d dRp(-Rp.y(), Rp.x());  // d(R p)/dθ
    const Vector3d J(pr.normal.x(), pr.normal.y(), pr.normal.dot(dRp));
    H.noalias() += J * J.transpose();
    sum_sq += e * e;
    sum_r2 += pr.p.squaredNorm();
  }
  const double n = static_cast<double>(pairs.size());
  result.mse = sum_sq / n;
  const double s2 = std::max(n > 3.0 ? sum_sq / (n - 3.0) : sum_sq, settings.sigma * settings.sigma);
  const Eigen::SelfAdjointEigenSolver<Matrix3d> es(H);
  const double lmax = std::max(es.eigenvalues()(2), 1e-300);
  Vector3d inv = Vector3d::Zero();
  for (int k = 0; k < 3; ++k) inv(k) = 1.0 / std::max(es.eigenvalues()(k), 1e-12 * lmax);
  result.covariance = s2 * es.eigenvectors() * inv.asDiagonal() * es.eigenvectors().transpose();
  const double L = std::max(std::sqrt(sum_r2 / n), 1e-6);
  result.characteristic_length = L;
  const Vector3d d(1.0, 1.0, 1.0 / L);
  const Matrix3d Hn = d.asDiagonal() * H * d.asDiagonal() / n;
  const Eigen::SelfAdjointEigenSolver<Matrix3d> esn(Hn);
  result.min_normalized_eigenvalue = esn.eigenvalues()(0);
  result.weakest_direction = esn.eigenvectors().col(0);
  result.degenerate = result.min_normalized_eigenvalue < settings.degeneracy_threshold;
  return result;
}

PlicpResult plicp(const LaserScan& current, const PlicpReference& reference,
                  const Pose2& T_ref_cur_guess, const PlicpSettings& settings) {
  current.check_consistent("plicp");
  return plicp(current.to_points(), reference, T_ref_cur_guess, settings);
}

PlicpResult plicp(const LaserScan& current, const LaserScan& reference, const Pose2& T_ref_cur_guess,
                  const PlicpSettings& settings) {
  return plicp(current, PlicpReference(reference), T_ref_cur_guess, settings);
}

}  // namespace plumb
