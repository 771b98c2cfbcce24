// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/loam/odometry.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

#include "plumb/core/error.hpp"
#include "plumb/core/levenberg_marquardt.hpp"
#include "plumb/core/parallel.hpp"
#include "core/eigen_instantiations.hpp"
#include "plumb/core/robust_kernel.hpp"

namespace plumb {

namespace loam_detail {

using Factor = LoamCorrespondence;

struct FactorCounts {
  std::size_t edge = 0, plane = 0, point = 0;
  std::size_t total() const { return edge + plane + point; }
};

FactorCounts count(const std::vector<Factor>& factors) {
  FactorCounts c;
  for (const Factor& f : factors) {
    if (f.kind == Factor::Kind::kEdge) ++c.edge;
    else if (f.kind == Factor::Kind::kPlane) ++c.plane;
    else ++c.point;
  }
  return c;
}

/// The kernel of settings.huber_scale: Huber on the residual norm, or plain least squares at 0.
RobustLoss odometry_kernel(const LoamSettings& s) {
  return s.huber_scale > 0.0 ? RobustLoss::huber(s.huber_scale) : RobustLoss::none();
}

// Residual (norm) and, optionally, its weighted contribution to H and g.
double evaluate(const std::vector<Factor>& factors, const Eigen::Isometry3d& T, const RobustLoss& kernel,
                       Matrix6d* H, Vector6d* g, Matrix6d* H_plain, double* sum_sq) {
  double cost = 0.0;
  if (H != nullptr) { H->setZero(); g->setZero(); H_plain->setZero(); *sum_sq = 0.0; }
  Matrix36d J3;
  Matrix16d J1;
  for (const Factor& f : factors) {
    if (f.kind == Factor::Kind::kPlane) {
      const double r = f.weight * point_to_plane_residual(T, f.p, f.a, f.dir, H != nullptr ? &J1 : nullptr);
      if (H != nullptr) J1 *= f.weight;
      const double e = std::abs(r);
      cost += kernel.loss(e);
      if (H != nullptr) {
        const double w = kernel.weight(e);
        const Matrix6d JtJ = J1.transpose() * J1;
        *H += w * JtJ;
        *H_plain += JtJ;
        *g += w * J1.transpose() * r;
        *sum_sq += e * e;
      }
    } else {
      const Vector3d r = f.weight * (f.kind == Factor::Kind::kEdge
                                         ? point_to_edge_residual(T, f.p, f.a, f.dir, H != nullptr ? &J3 : nullptr)
                                         : point_to_point_residual(T, f.p, f.a, H != nullptr ? &J3 : nullptr));
      if (H != nullptr) J3 *= f.weight;
      const double e = r.norm();
      cost += kernel.loss(e);
      if (H != nullptr) {
        const double w = kernel.weight(e);
        const Matrix6d JtJ = J3.transpose() * J3;
        *H += w * JtJ;
        *H_plain += JtJ;
        *g += w * J3.transpose() * r;
        *sum_sq += e * e;
      }
    }
  }
  return cost;
}

void check_settings(const LoamSettings& s, const Eigen::Isometry3d& guess, const char* where) {
  PLUMB_CHECK(guess.matrix().allFinite(), where << ": the initial guess is not finite");
  PLUMB_CHECK(s.max_iterations >= 1, where << ": max_iterations must be >= 1, got " << s.max_iterations);
  PLUMB_CHECK(std::isfinite(s.max_correspondence_distance) && s.max_correspondence_distance > 0.0,
              where << ": max_correspondence_distance must be > 0, got " << s.max_correspondence_distance);
  PLUMB_CHECK(s.ring_window >= 1, where << ": ring_window must be >= 1, got " << s.ring_window);
  PLUMB_CHECK(s.threads >= 0, where << ": threads must be >= 0 (0 = every core), got " << s.threads);
  PLUMB_CHECK(std::isfinite(s.huber_scale) && s.huber_scale >= 0.0,
              where << ": huber_scale must be >= 0, got " << s.huber_scale);
  PLUMB_CHECK(s.min_step_translation >= 0.0 && s.min_step_rotation >= 0.0,
              where << ": min_step_translation / min_step_rotation must be >= 0");
  PLUMB_CHECK(s.min_correspondences >= 6, where << ": min_correspondences must be >= 6, got "
                                                << s.min_correspondences);
  PLUMB_CHECK(std::isfinite(s.degeneracy_threshold) && s.degeneracy_threshold >= 0.0,
              where << ": degeneracy_threshold must be >= 0");
  PLUMB_CHECK(std::isfinite(s.initial_lambda) && s.initial_lambda >= 0.0,
              where << ": initial_lambda must be >= 0");
  PLUMB_CHECK(s.map_neighbors >= 3, where << ": map_neighbors must be >= 3, got " << s.map_neighbors);
  PLUMB_CHECK(std::isfinite(s.map_plane_tolerance) && s.map_plane_tolerance > 0.0,
              where << ": map_plane_tolerance must be > 0");
  PLUMB_CHECK(std::isfinite(s.map_edge_ratio) && s.map_edge_ratio >= 1.0,
              where << ": map_edge_ratio must be >= 1");
  PLUMB_CHECK(std::isfinite(s.map_plane_ratio) && s.map_plane_ratio >= 1.0,
              where << ": map_plane_ratio must be >= 1");
}

/// The shared solver: per round, associate at T (fills factors), then one Levenberg-Marquardt step
/// on the cost of these factors (core/levenberg_marquardt.hpp).
template <typename Associate>
LoamResult solve_se3(const Eigen::Isometry3d& guess, const LoamSettings& s, Associate&& associate) {
  LoamResult res;
  res.T_prev_cur = guess;
  Eigen::Isometry3d T = guess;
  std::vector<Factor> factors;
  LevenbergMarquardtSettings lm_settings;
  lm_settings.initial_lambda = s.initial_lambda;
  LevenbergMarquardt lm(lm_settings);
  Matrix6d H, H_plain;
  Vector6d g;
  double sum_sq = 0.0;
  const RobustLoss kernel = odometry_kernel(s);
  for (int it = 0; it < s.max_iterations; ++it) {
    factors.clear();
    associate(T, factors);
    const FactorCounts c = count(factors);
    res.iterations = it + 1;
    res.num_edge = c.edge;
    res.num_plane = c.plane;
    res.num_point = c.point;
    if (c.total() < s.min_correspondences) {
      res.status = Status::kInsufficientData;
      res.converged = false;
      res.T_prev_cur = T;
      return res;
    }
    const double cost = evaluate(factors, T, kernel, &H, &g, &H_plain, &sum_sq);
    const double n = static_cast<double>(c.total());
    res.rmse = std::sqrt(sum_sq / n);
    const Eigen::SelfAdjointEigenSolver<Matrix6d> eig(H_plain / n, Eigen::EigenvaluesOnly);
    res.degeneracy = std::max(0.0, eig.eigenvalues()(0));

    Vector6d delta = Vector6d::Zero();
    const bool accepted = lm.step(H, g, cost, [&](const Vector6d& d) {
      return evaluate(factors, T * se3::exp(d), kernel, nullptr, nullptr, nullptr, nullptr);
    }, delta);
    if (accepted) T = T * se3::exp(delta);
    if (!accepted || (delta.head<3>().norm() < s.min_step_translation &&
                      delta.tail<3>().norm() < s.min_step_rotation)) {
      res.converged = true;
      break;
    }
  }
  res.T_prev_cur = T;
  if (!res.converged) {
    res.status = Status::kNotConverged;
  } else if (s.degeneracy_threshold > 0.0 && res.degeneracy < s.degeneracy_threshold) {
    res.status = Status::kDegenerate;
  } else {
    res.status = Status::kOk;
  }
  return res;
}

/// The points of one feature set (e.g. edges + edge candidates), all together and per ring, each
/// with a kd-tree; non-finite points are left out.
struct RingFeatureIndex {
  std::vector<Vector3f> points;               // all, finite
  std::vector<std::uint16_t> rings;           // ring of points[i]
  std::vector<std::size_t> local;             // index of points[i] in its ring's vector
  std::optional<KdTree3f> tree;               // over points
  std::vector<std::vector<Vector3f>> ring_points;
  std::vector<std::optional<KdTree3f>> ring_trees;

  RingFeatureIndex(const PointCloud& a, const PointCloud& b, const char* what) {
    int num_rings = 0;
    for (const PointCloud* c : {&a, &b}) {
      PLUMB_CHECK(c->empty() || c->rings.size() == c->size(),
                  "loam_scan_to_scan: the previous frame's " << what << " points have no ring field");
      for (std::size_t i = 0; i < c->size(); ++i) {
        if (!c->points[i].allFinite()) continue;
        points.push_back(c->points[i]);
        rings.push_back(c->rings[i]);
        num_rings = std::max(num_rings, static_cast<int>(c->rings[i]) + 1);
      }
    }
    ring_points.resize(static_cast<std::size_t>(num_rings));
    local.resize(points.size());
    for (std::size_t i = 0; i < points.size(); ++i) {
      auto& rp = ring_points[rings[i]];
      local[i] = rp.size();
      rp.push_back(points[i]);
    }
    if (!points.empty()) tree.emplace(points);
    ring_trees.resize(ring_points.size());
    for (std::size_t r = 0; r < ring_points.size(); ++r) {
      if (!ring_points[r].empty()) ring_trees[r].emplace(ring_points[r]);
    }
  }

  // Nearest point to q on rings ring +- 1 .. ring +- window (not ring itself), within max_sq.
  std::optional<Vector3d> nearest_other_ring(const Vector3f& q, int ring, int window, float max_sq) const {
    float best = max_sq;
    std::optional<Vector3d> out;
    for (int r = ring - window; r <= ring + window; ++r) {
      if (r == ring || r < 0 || r >= static_cast<int>(ring_trees.size()) ||
          !ring_trees[static_cast<std::size_t>(r)]) {
        continue;
      }
      const auto nb = ring_trees[static_cast<std::size_t>(r)]->nearest(q, best);
      if (nb && nb->dist_sq <= best) {
        best = nb->dist_sq;
        out = ring_points[static_cast<std::size_t>(r)][nb->index].cast<double>();
      }
    }
    return out;
  }
};

}  // namespace loam_detail

LoamMap::LoamMap(PointCloud edges, PointCloud planes)
    : edges_(std::move(edges)), planes_(std::move(planes)) {
  edges_.check_consistent("LoamMap edges");
  planes_.check_consistent("LoamMap planes");
  auto has_finite = [](const PointCloud& c) {
    return std::any_of(c.points.begin(), c.points.end(), [](const Vector3f& p) { return p.allFinite(); });
  };
  if (has_finite(edges_)) edge_tree_.emplace(edges_.points);
  if (has_finite(planes_)) plane_tree_.emplace(planes_.points);
}

LoamResult loam_scan_to_scan(const LoamFeatures& prev, const LoamFeatures& cur,
                                    const Eigen::Isometry3d& T_prev_cur_guess, const LoamSettings& settings) {
  using loam_detail::Factor;
  loam_detail::check_settings(settings, T_prev_cur_guess, "loam_scan_to_scan");
  // The previous frame's pools when present (dense, LOAM's less-sharp / less-flat sets), else its
  // selected features and candidates.
  const PointCloud none;
  const loam_detail::RingFeatureIndex edges(prev.edge_pool.empty() ? prev.edges : prev.edge_pool,
                                            prev.edge_pool.empty() ? prev.edge_candidates : none, "edge");
  const loam_detail::RingFeatureIndex planes(prev.plane_pool.empty() ? prev.planes : prev.plane_pool,
                                             prev.plane_pool.empty() ? prev.plane_candidates : none, "plane");
  const float max_sq = static_cast<float>(settings.max_correspondence_distance * settings.max_correspondence_distance);
  const int window = settings.ring_window;

  auto associate = [&](const Eigen::Isometry3d& T, std::vector<Factor>& factors) {
    const Eigen::Matrix3f R = T.linear().cast<float>();
    const Eigen::Vector3f t = T.translation().cast<float>();
    if (edges.tree) {
      for (const Vector3f& p : cur.edges.points) {
        if (!p.allFinite()) continue;
        const Vector3f q = R * p + t;
        const auto j = edges.tree->nearest(q, max_sq);  // Zhou et al. 2021, eq. 6: nearest edge point j
        if (!j) continue;
        const int ring_j = edges.rings[j->index];
        const auto l = edges.nearest_other_ring(q, ring_j, window, max_sq);  // l on another ring
        if (!l) continue;
        const Vector3d pj = edges.points[j->index].cast<double>();
        const auto u = make_edge_line(pj, *l);
        if (!u) continue;
        factors.push_back({Factor::Kind::kEdge, p.cast<double>(), pj, *u});
      }
    }
    if (planes.tree) {
      std::size_t nb_idx[3];
      float nb_d[3];
      for (const Vector3f& p : cur.planes.points) {
        if (!p.allFinite()) continue;
        const Vector3f q = R * p + t;
        const auto j = planes.tree->nearest(q, max_sq);  // Zhou et al. 2021, eq. 7: nearest plane point j
        if (!j) continue;
        const int ring_j = planes.rings[j->index];
        const auto& ring_tree = planes.ring_trees[static_cast<std::size_t>(ring_j)];
        // l: nearest on j's ring other than j itself
        const std::size_t found = ring_tree->knn(q, 2, nb_idx, nb_d);
        std::optional<Vector3d> l;
        for (std::size_t k = 0; k < found; ++k) {
          if (nb_idx[k] != planes.local[j->index] && nb_d[k] <= max_sq) {
            l = planes.ring_points[static_cast<std::size_t>(ring_j)][nb_idx[k]].cast<double>();
            break;
          }
        }
        if (!l) continue;
        const auto m = planes.nearest_other_ring(q, ring_j, window, max_sq);  // m on another ring
        if (!m) continue;
        const Vector3d pj = planes.points[j->index].cast<double>();
        const auto n = make_plane_normal(pj, *l, *m);
        if (!n) continue;
        factors.push_back({Factor::Kind::kPlane, p.cast<double>(), pj, *n});
      }
    }
  };
  return loam_detail::solve_se3(T_prev_cur_guess, settings, associate);
}

std::size_t LoamMapCache::hits() const {
  std::size_t n = 0;
  for (const Slot& s : slots_) n += s.hits;
  return n;
}

std::size_t LoamMapCache::searches() const {
  std::size_t n = 0;
  for (const Slot& s : slots_) n += s.searches;
  return n;
}

LoamMapCache::Slot& LoamMapCache::slot(std::size_t i, const void* queries, const void* tree, std::size_t size) {
  if (slots_.size() <= i) slots_.resize(i + 1);
  Slot& s = slots_[i];
  if (s.queries != queries || s.tree != tree || s.size != size) {
    s = Slot{};
    s.queries = queries;
    s.tree = tree;
    s.size = size;
    s.entries.assign(size, Entry{});
  }
  return s;
}

namespace {

// The map points nearest the moved query `q` from a cache entry, when they are provably the k
// nearest within the gate (or provably fewer than k lie within it): true, with the count in
// `found` and the points in idx / d, ascending. False when a tree search is needed.
bool nearest_from_cache(const LoamMapCache::Entry& e, const Vector3f& q, std::size_t k, float max_sq,
                        const PointCloud& features, std::size_t* idx, float* d, std::size_t& found) {
  if (e.radius_sq < 0.0f) return false;
  // Every point not in e.near lies at least sqrt(radius_sq) from e.at, so at least
  // sqrt(radius_sq) - |q - e.at| from q; 1e-4 of margin covers the rounding of float distances.
  const double moved = (q - e.at).cast<double>().norm();
  const double reach = std::sqrt(static_cast<double>(e.radius_sq)) - moved;
  if (!(reach > 0.0)) return false;
  const double beyond_sq = reach * reach * (1.0 - 1e-4);
  found = 0;
  float all[16] = {};
  for (std::size_t j = 0; j < e.num_near; ++j) {
    const Vector3f& p = features.points[e.near[j]];
    // Summed as the kd-tree sums (dimension order, float): the same distances.
    const float dx = p.x() - q.x(), dy = p.y() - q.y(), dz = p.z() - q.z();
    const float dj = dx * dx + dy * dy + dz * dz;
    all[j] = dj;
    if (!(dj <= max_sq) || (found == k && !(dj < d[k - 1]))) continue;
    detail::insert_k_best(d, idx, found, k, dj, e.near[j]);
  }
  if (found < k) return static_cast<double>(max_sq) < beyond_sq;  // none beyond the radius is within the gate
  if (!(static_cast<double>(d[k - 1]) < beyond_sq)) return false;
  // Two points at exactly the same distance are ordered by the tree's visiting order, which the
  // cache does not know: such a query is searched.
  for (std::size_t j = 0; j + 1 < k; ++j) {
    if (d[j] == d[j + 1]) return false;
  }
  std::size_t within = 0;
  for (std::size_t j = 0; j < e.num_near; ++j) within += all[j] <= d[k - 1] ? 1 : 0;
  return within == k;
}

}  // namespace

void loam_associate_map(const LoamMap& map, const LoamFeatures& cur, const Eigen::Isometry3d& T,
                        const LoamSettings& settings, std::vector<LoamCorrespondence>& factors) {
  loam_associate_map(map, cur, T, settings, factors, nullptr);
}

void loam_associate_map(const LoamMap& map, const LoamFeatures& cur, const Eigen::Isometry3d& T,
                        const LoamSettings& settings, std::vector<LoamCorrespondence>& factors, LoamMapCache* cache) {
  using loam_detail::Factor;
  PLUMB_CHECK(settings.map_neighbors >= 3, "loam_associate_map: map_neighbors must be >= 3, got " << settings.map_neighbors);
  PLUMB_CHECK(settings.threads >= 0, "loam_associate_map: threads must be >= 0 (0 = every core), got " << settings.threads);
  const float max_sq = static_cast<float>(settings.max_correspondence_distance * settings.max_correspondence_distance);
  const std::size_t k = static_cast<std::size_t>(settings.map_neighbors);
  const Eigen::Matrix3f R = T.linear().cast<float>();
  const Eigen::Vector3f t = T.translation().cast<float>();
  const std::size_t kk = std::min<std::size_t>(k, 64);
  // With a cache, a tree search asks for twice the neighbours needed (at most 16), so that the
  // next rounds can be answered from them.
  constexpr std::size_t kMaxCached = sizeof(LoamMapCache::Entry::near) / sizeof(std::uint32_t);
  const bool caching = cache != nullptr && kk < kMaxCached;
  const std::size_t k_search = caching ? std::min(2 * kk, kMaxCached) : kk;
  // The queries are independent: chunks of them run on settings.threads threads, their factors
  // appended in query order (the same list for any thread count); each query has its own entry
  // in the cache.
  constexpr std::size_t kGrain = 256;
  // For each finite query moved by T: the mean and eigen-decomposed covariance of its k nearest
  // map features (none farther than the gate), handed to `accept`, which appends its factor or not.
  std::size_t slot_index = 0;
  auto associate = [&](const PointCloud& queries, const std::optional<KdTree3f>& tree, const PointCloud& features,
                       auto accept) {
    LoamMapCache::Slot* slot =
        caching && tree ? &cache->slot(slot_index, &queries, &*tree, queries.size()) : nullptr;
    ++slot_index;
    if (!tree) return;
    // Per chunk: queries answered from the cache, and by a tree search.
    std::vector<std::size_t> hits(slot ? chunk_count(queries.size(), kGrain) : 0, 0), searches(hits);
    parallel_append(settings.threads, queries.size(), kGrain, factors,
                    [&](std::size_t begin, std::size_t end, std::vector<LoamCorrespondence>& out) {
      std::size_t idx[64];
      float d[64];
      std::size_t chunk_hits = 0, chunk_searches = 0;  // written once: the chunks' counters share cache lines
      Vector3d mean;
      Eigen::SelfAdjointEigenSolver<Matrix3d> eig;
      for (std::size_t i = begin; i < end; ++i) {
        const Vector3f& p = queries.points[i];
        if (!p.allFinite()) continue;
        const Vector3f q = R * p + t;
        std::size_t found = 0;
        LoamMapCache::Entry* e = slot ? &slot->entries[i] : nullptr;
        if (e != nullptr && nearest_from_cache(*e, q, kk, max_sq, features, idx, d, found)) {
          ++chunk_hits;
        } else {
          // Bounded by the gate: a query whose k-th neighbour lies beyond it finds fewer than k
          // (and is dropped, as it would be), and the search prunes what lies beyond from the start.
          found = tree->knn(q, k_search, idx, d, max_sq);
          if (e != nullptr) {
            ++chunk_searches;
            e->at = q;
            e->num_near = static_cast<std::uint8_t>(found);
            for (std::size_t j = 0; j < found; ++j) e->near[j] = static_cast<std::uint32_t>(idx[j]);
            // Fewer found than asked for: every other point lies beyond the gate.
            e->radius_sq = found == k_search ? d[found - 1] : max_sq;
          }
          found = std::min(found, kk);
        }
        if (found < kk) continue;
        if (e != nullptr && e->num_used == kk &&
            std::equal(idx, idx + kk, e->used, [](std::size_t a, std::uint32_t b) { return a == b; })) {
          if (e->has_factor) out.push_back(e->factor);  // the same neighbours: the same correspondence
          continue;
        }
        Matrix3d C;
        loam_neighbour_moments(features, idx, found, mean, C);
        eig.computeDirect(C);
        const std::size_t before = out.size();
        accept(p, idx, mean, eig, out);
        if (e != nullptr) {
          e->num_used = static_cast<std::uint8_t>(kk);
          for (std::size_t j = 0; j < kk; ++j) e->used[j] = static_cast<std::uint32_t>(idx[j]);
          e->has_factor = out.size() > before;
          if (e->has_factor) e->factor = out.back();
        }
      }
      if (slot != nullptr) {
        hits[begin / kGrain] = chunk_hits;
        searches[begin / kGrain] = chunk_searches;
      }
    });
    if (slot != nullptr) {
      for (std::size_t c = 0; c < hits.size(); ++c) {
        slot->hits += hits[c];
        slot->searches += searches[c];
      }
    }
  };
  auto edge = [&](const Vector3f& p, const std::size_t*, const Vector3d& mean,
                  const Eigen::SelfAdjointEigenSolver<Matrix3d>& eig, std::vector<LoamCorrespondence>& out) {
    const Vector3d ev = eig.eigenvalues();  // ascending
    if (!(ev(2) > 0.0) || ev(2) < settings.map_edge_ratio * ev(1)) return;
    out.push_back({Factor::Kind::kEdge, p.cast<double>(), mean, eig.eigenvectors().col(2).normalized()});
  };
  auto plane = [&](const Vector3f& p, const std::size_t* idx, const Vector3d& mean,
                   const Eigen::SelfAdjointEigenSolver<Matrix3d>& eig, std::vector<LoamCorrespondence>& out) {
    const Vector3d ev = eig.eigenvalues();  // ascending
    if (!(ev(1) > 0.0) || ev(1) < settings.map_plane_ratio * ev(0)) return;
    const Vector3d n = eig.eigenvectors().col(0).normalized();
    for (std::size_t j = 0; j < kk; ++j) {
      if (std::abs(n.dot(map.planes().points[idx[j]].cast<double>() - mean)) > settings.map_plane_tolerance) return;
    }
    out.push_back({Factor::Kind::kPlane, p.cast<double>(), mean, n});
  };
  associate(cur.edges, map.edge_tree(), map.edges(), edge);
  associate(cur.edge_candidates, map.edge_tree(), map.edges(), edge);
  associate(cur.planes, map.plane_tree(), map.planes(), plane);
  associate(cur.plane_candidates, map.plane_tree(), map.planes(), plane);
}

LoamResult loam_scan_to_map(const LoamMap& map, const LoamFeatures& cur,
                                   const Eigen::Isometry3d& T_map_cur_guess, const LoamSettings& settings) {
  using loam_detail::Factor;
  loam_detail::check_settings(settings, T_map_cur_guess, "loam_scan_to_map");
  PLUMB_CHECK(settings.map_neighbors <= 64, "loam_scan_to_map: map_neighbors must be <= 64, got " << settings.map_neighbors);
  LoamMapCache cache;  // the rounds of this solve move the queries little: most reuse their neighbours
  auto associate = [&](const Eigen::Isometry3d& T, std::vector<Factor>& factors) {
    loam_associate_map(map, cur, T, settings, factors, &cache);
  };
  return loam_detail::solve_se3(T_map_cur_guess, settings, associate);
}

void loam_associate_points(const PointCloud& prev, const KdTree3f& prev_tree, const PointCloud& cur,
                                  const Eigen::Isometry3d& T, double max_correspondence_distance,
                                  std::vector<LoamCorrespondence>& factors) {
  using loam_detail::Factor;
  PLUMB_CHECK(prev_tree.num_input_points() == prev.size(),
              "loam_associate_points: the kd-tree was built on " << prev_tree.num_input_points()
                  << " points but the target cloud has " << prev.size());
  const float max_sq = static_cast<float>(max_correspondence_distance * max_correspondence_distance);
  const Eigen::Matrix3f R = T.linear().cast<float>();
  const Eigen::Vector3f t = T.translation().cast<float>();
  for (const Vector3f& p : cur.points) {
    if (!p.allFinite()) continue;
    const auto nb = prev_tree.nearest(R * p + t, max_sq);
    if (!nb) continue;
    factors.push_back({Factor::Kind::kPoint, p.cast<double>(), prev.points[nb->index].cast<double>(),
                       Vector3d::Zero()});
  }
}

LoamResult loam_icp_scan_to_scan(const PointCloud& prev, const KdTree3f& prev_tree,
                                        const PointCloud& cur, const Eigen::Isometry3d& T_prev_cur_guess,
                                        const LoamSettings& settings) {
  using loam_detail::Factor;
  loam_detail::check_settings(settings, T_prev_cur_guess, "loam_icp_scan_to_scan");
  PLUMB_CHECK(prev_tree.num_input_points() == prev.size(),
              "loam_icp_scan_to_scan: the kd-tree was built on " << prev_tree.num_input_points()
                  << " points but the previous cloud has " << prev.size());
  auto associate = [&](const Eigen::Isometry3d& T, std::vector<Factor>& factors) {
    loam_associate_points(prev, prev_tree, cur, T, settings.max_correspondence_distance, factors);
  };
  return loam_detail::solve_se3(T_prev_cur_guess, settings, associate);
}

}  // namespace plumb
