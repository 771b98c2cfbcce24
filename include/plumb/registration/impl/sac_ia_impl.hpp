// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <vector>

#include "plumb/core/error.hpp"
#include "plumb/core/rng.hpp"
#include "plumb/registration/feature_index.hpp"
#include "plumb/registration/horn.hpp"
#include "plumb/registration/kernels.hpp"

namespace plumb {

namespace detail {

inline bool fpfh_valid(const FpfhSignature& f) {
  bool any = false;
  for (float v : f) {
    if (!std::isfinite(v)) return false;
    any = any || v != 0.0f;
  }
  return any;
}

/// True when T is within `distance` (translation) and `angle` (rotation) of one of `poses`.
inline bool near_any(const Eigen::Isometry3d& T, const std::vector<Eigen::Isometry3d>& poses, double distance,
                     double angle) {
  for (const Eigen::Isometry3d& E : poses) {
    if ((T.translation() - E.translation()).norm() >= distance) continue;
    if (Eigen::AngleAxisd(E.linear().transpose() * T.linear()).angle() < angle) return true;
  }
  return false;
}

inline void check_sac_ia_settings(const SacIaSettings& s) {
  PLUMB_CHECK(std::isfinite(s.exclude_distance) && s.exclude_distance >= 0.0 && std::isfinite(s.exclude_angle) &&
                  s.exclude_angle >= 0.0,
              "align_sac_ia: settings.exclude_distance / exclude_angle must be finite and >= 0");
  PLUMB_CHECK(std::isfinite(s.region_radius) && s.region_radius >= 0.0 && s.region_center.allFinite(),
              "align_sac_ia: settings.region_radius must be >= 0 and region_center finite");
  PLUMB_CHECK(s.num_samples >= 3, "align_sac_ia: settings.num_samples = " << s.num_samples << " must be >= 3");
  PLUMB_CHECK(std::isfinite(s.min_sample_distance) && s.min_sample_distance >= 0.0,
              "align_sac_ia: settings.min_sample_distance = " << s.min_sample_distance << " must be >= 0");
  PLUMB_CHECK(s.k_correspondences >= 1,
              "align_sac_ia: settings.k_correspondences = " << s.k_correspondences << " must be >= 1");
  PLUMB_CHECK(s.max_iterations >= 1, "align_sac_ia: settings.max_iterations = " << s.max_iterations << " must be >= 1");
  PLUMB_CHECK(std::isfinite(s.huber_threshold) && s.huber_threshold > 0.0,
              "align_sac_ia: settings.huber_threshold = " << s.huber_threshold << " must be > 0");
  PLUMB_CHECK(std::isfinite(s.max_correspondence_distance) && s.max_correspondence_distance >= s.huber_threshold,
              "align_sac_ia: settings.max_correspondence_distance = " << s.max_correspondence_distance
                                                                      << " must be >= huber_threshold");
  PLUMB_CHECK(s.edge_similarity >= 0.0 && s.edge_similarity < 1.0,
              "align_sac_ia: settings.edge_similarity = " << s.edge_similarity << " must be in [0, 1)");
  PLUMB_CHECK(s.confidence > 0.0 && s.confidence <= 1.0,
              "align_sac_ia: settings.confidence = " << s.confidence << " must be in (0, 1]");
  PLUMB_CHECK(std::isfinite(s.prescore_slack) && s.prescore_slack >= 0.0,
              "align_sac_ia: settings.prescore_slack = " << s.prescore_slack << " must be >= 0");
}

/// Feature-space candidates of SAC-IA (Liu et al. 2022, sec. 1.2, SAC-IA step 2), computed on first
/// use and cached.
class SacIaCandidates {
 public:
  SacIaCandidates(const std::vector<FpfhSignature>& source_features, const std::vector<std::size_t>& src_ids,
                  const std::vector<FpfhSignature>& target_features, const std::vector<std::size_t>& tgt_ids,
                  std::size_t k, bool mutual, bool weighted)
      : sf_(source_features), tf_(target_features), src_ids_(src_ids), k_(k), mutual_(mutual), weighted_(weighted),
        target_tree_(target_features, tgt_ids), cand_(src_ids.size() * k), weight_(src_ids.size() * k),
        count_(src_ids.size(), kUnknown), dist_(k), back_dist_(k) {
    if (mutual_) {
      source_tree_ = std::make_unique<FeatureKdTree<kFpfhBins>>(source_features, src_ids);
      back_.resize(target_features.size() * k);
      back_count_.assign(target_features.size(), kUnknown);
    }
  }
  std::size_t k() const { return k_; }
  bool known(std::size_t a) const { return count_[a] != kUnknown; }
  /// Candidates (target indices) of usable source point a (position in src_ids).
  std::size_t get(std::size_t a, const std::uint32_t*& out) {
    if (count_[a] == kUnknown) compute(a);
    out = &cand_[a * k_];
    return count_[a];
  }
  /// Probability of drawing each candidate of a (after get()), summing to 1.
  const double* probabilities(std::size_t a) const { return &weight_[a * k_]; }
  /// One candidate of a (after get(), count > 0) drawn with probabilities(a).
  std::uint32_t draw(std::size_t a, Rng& rng) const {
    const std::size_t n = count_[a];
    const std::uint32_t* c = &cand_[a * k_];
    if (!weighted_) return c[rng.uniform_index(n)];
    const double* p = &weight_[a * k_];
    double u = rng.uniform();
    for (std::size_t m = 0; m + 1 < n; ++m) {
      if (u < p[m]) return c[m];
      u -= p[m];
    }
    return c[n - 1];
  }
  std::size_t num_known() const { return known_.size(); }
  const std::vector<std::size_t>& known_points() const { return known_; }

 private:
  static constexpr std::uint32_t kUnknown = std::numeric_limits<std::uint32_t>::max();
  void compute(std::size_t a) {
    std::uint32_t* c = &cand_[a * k_];
    std::size_t n = target_tree_.knn(sf_[src_ids_[a]].data(), k_, c, dist_.data());
    if (mutual_) {
      const std::uint32_t i = static_cast<std::uint32_t>(src_ids_[a]);
      std::size_t kept = 0;
      for (std::size_t m = 0; m < n; ++m) {
        const std::uint32_t j = c[m];
        if (back_count_[j] == kUnknown) {
          back_count_[j] =
              static_cast<std::uint32_t>(source_tree_->knn(tf_[j].data(), k_, &back_[j * k_], back_dist_.data()));
        }
        const std::uint32_t* b = &back_[j * k_];
        if (std::find(b, b + back_count_[j], i) != b + back_count_[j]) {
          dist_[kept] = dist_[m];  // dist_ is the target query's, kept in step with c
          c[kept++] = j;
        }
      }
      n = kept;
    }
    // Drawing probabilities: uniform, or a Gaussian likelihood in the feature distance whose
    // spread is the closest candidate's own distance (so only the relative similarity counts).
    double* p = &weight_[a * k_];
    double f1_sq = std::numeric_limits<double>::infinity(), sum = 0.0;
    for (std::size_t m = 0; m < n; ++m) {
      p[m] = static_cast<double>(dist_[m]);  // squared feature distance from the knn query
      f1_sq = std::min(f1_sq, p[m]);
    }
    for (std::size_t m = 0; m < n; ++m) {
      if (!weighted_) {
        p[m] = 1.0;
      } else if (f1_sq > 0.0) {
        p[m] = std::exp(-(p[m] - f1_sq) / (2.0 * f1_sq));
      } else {
        p[m] = p[m] == 0.0 ? 1.0 : 0.0;  // identical signatures: only those
      }
      sum += p[m];
    }
    for (std::size_t m = 0; m < n; ++m) p[m] /= sum;
    count_[a] = static_cast<std::uint32_t>(n);
    known_.push_back(a);
  }

  const std::vector<FpfhSignature>& sf_;
  const std::vector<FpfhSignature>& tf_;
  const std::vector<std::size_t>& src_ids_;
  std::size_t k_;
  bool mutual_;
  bool weighted_;
  FeatureKdTree<kFpfhBins> target_tree_;
  std::unique_ptr<FeatureKdTree<kFpfhBins>> source_tree_;
  std::vector<std::uint32_t> cand_;
  std::vector<double> weight_;
  std::vector<std::uint32_t> count_;
  std::vector<std::uint32_t> back_, back_count_;
  std::vector<float> dist_, back_dist_;  // squared feature distances of the last target / source query
  std::vector<std::size_t> known_;
};

}  // namespace detail

inline SacIaResult align_sac_ia(const PointCloud& source, const std::vector<FpfhSignature>& source_features,
                                const PointCloud& target, const std::vector<FpfhSignature>& target_features,
                                const KdTree3f& target_tree, const SacIaSettings& settings) {
  detail::check_sac_ia_settings(settings);
  PLUMB_CHECK(source_features.size() == source.size(),
              "align_sac_ia: " << source_features.size() << " source features for " << source.size() << " source points");
  PLUMB_CHECK(target_features.size() == target.size(),
              "align_sac_ia: " << target_features.size() << " target features for " << target.size() << " target points");
  PLUMB_CHECK(target_tree.num_input_points() == target.size(),
              "align_sac_ia: target_tree was built from " << target_tree.num_input_points()
                                                          << " points but the target has " << target.size());
  SacIaResult out;
  const std::size_t s = settings.num_samples;

  // Usable points: finite, with a valid signature.
  std::vector<std::size_t> src_ids, tgt_ids, score_order;
  for (std::size_t i = 0; i < source.size(); ++i) {
    if (!source.points[i].allFinite()) continue;
    score_order.push_back(i);
    if (detail::fpfh_valid(source_features[i])) src_ids.push_back(i);
  }
  for (std::size_t j = 0; j < target.size(); ++j)
    if (target.points[j].allFinite() && detail::fpfh_valid(target_features[j])) tgt_ids.push_back(j);
  if (src_ids.size() < s || tgt_ids.size() < 3) return out;

  // Liu et al. 2022, sec. 1.2, SAC-IA step 2: the k most similar target signatures, computed for a
  // source point when it is first sampled.
  const std::size_t k = std::min(settings.k_correspondences, tgt_ids.size());
  detail::SacIaCandidates candidates(source_features, src_ids, target_features, tgt_ids, k, settings.mutual_filter,
                                     settings.similarity_weighted);

  Rng rng(settings.seed);
  // Score points in a fixed random order: its first points are the pre-scoring subset, and the
  // early exit of a bad hypothesis comes soon.
  for (std::size_t i = score_order.size(); i > 1; --i)
    std::swap(score_order[i - 1], score_order[rng.uniform_index(i)]);
  const std::size_t num_pre = std::min(settings.num_prescore_points, score_order.size());

  const double m1 = settings.huber_threshold;
  const double m1_sq = m1 * m1;
  const double max_d = settings.max_correspondence_distance;
  const float max_d_sq = static_cast<float>(max_d * max_d);
  const double far_cost = huber_penalty(max_d, m1);
  const double min_sep_sq = settings.min_sample_distance * settings.min_sample_distance;
  const double edge_ratio = settings.edge_similarity;
  const double pre_factor = 1.0 + settings.prescore_slack;

  double best = std::numeric_limits<double>::infinity();
  double best_pre = std::numeric_limits<double>::infinity();
  Eigen::Isometry3d best_T = Eigen::Isometry3d::Identity();
  double needed = static_cast<double>(settings.max_iterations);
  std::vector<std::size_t> sample(s);   // positions in src_ids
  std::vector<Vector3d> P(s), Q(s);
  std::vector<const std::uint32_t*> cp(s);  // candidates of each sample
  std::vector<std::size_t> np(s);           // and their number
  constexpr int kMaxSampleAttempts = 100;

  // Huber total (Liu et al. 2022, eq. 2, distances truncated at max_correspondence_distance) over
  // score_order[begin, end), added to `total`; stops early once total >= bound (exact: every
  // penalty is >= 0). Also counts the points within m1 (inliers) and their squared distances, so
  // that the winner's statistics need no extra pass.
  struct Inliers {
    std::size_t count = 0;
    double sum_sq = 0.0;
  };
  const float m1_sq_f = static_cast<float>(m1_sq);
  auto score_range = [&](const Eigen::Matrix3f& R, const Eigen::Vector3f& t, std::size_t begin, std::size_t end,
                         double total, double bound, Inliers& inliers) {
    for (std::size_t n = begin; n < end && total < bound; ++n) {
      const auto nn = target_tree.nearest(R * source.points[score_order[n]] + t, max_d_sq);
      if (!nn) {
        total += far_cost;
        continue;
      }
      total += huber_penalty(std::sqrt(static_cast<double>(nn->dist_sq)), m1);
      if (nn->dist_sq < m1_sq_f) {
        ++inliers.count;
        inliers.sum_sq += static_cast<double>(nn->dist_sq);
      }
    }
    return total;
  };
  Inliers best_inliers;
  // Early termination (RANSAC-style): w = the chance that the pair drawn for a sampled point is
  // one the best hypothesis maps within m1, averaged over the points whose candidates are known;
  // an all-correct set of s pairs then comes with probability about w^s per hypothesis.
  auto update_needed = [&] {
    double sum_good = 0.0;
    std::size_t num_points = 0;
    for (std::size_t a : candidates.known_points()) {
      const std::uint32_t* c = nullptr;
      const std::size_t n = candidates.get(a, c);
      if (n == 0) continue;
      const double* p = candidates.probabilities(a);
      const Vector3d x = best_T * source.points[src_ids[a]].cast<double>();
      ++num_points;
      for (std::size_t m = 0; m < n; ++m)
        if ((x - target.points[c[m]].cast<double>()).squaredNorm() < m1_sq) sum_good += p[m];
    }
    if (settings.confidence >= 1.0 || num_points == 0) return;
    const double w = std::min(1.0, sum_good / static_cast<double>(num_points));
    const double ws = std::pow(w, static_cast<double>(s));
    needed = ws >= 1.0 ? 1.0 : ws > 0.0 ? std::log(1.0 - settings.confidence) / std::log1p(-ws)
                                        : static_cast<double>(settings.max_iterations);
  };

  int it = 0;
  for (; it < settings.max_iterations; ++it) {
    if (static_cast<double>(it) >= needed && std::isfinite(best)) {
      // Re-estimate with every pair computed so far (more points than when `needed` was set).
      update_needed();
      if (static_cast<double>(it) >= needed) {
        out.converged = true;
        break;
      }
    }
    // Liu et al. 2022, sec. 1.2, SAC-IA step 1: samples pairwise farther apart than d (and with at
    // least one candidate).
    bool ok = true;
    for (std::size_t a = 0; a < s && ok; ++a) {
      ok = false;
      for (int attempt = 0; attempt < kMaxSampleAttempts && !ok; ++attempt) {
        const std::size_t c = static_cast<std::size_t>(rng.uniform_index(src_ids.size()));
        const Vector3f& pc = source.points[src_ids[c]];
        ok = true;
        for (std::size_t b = 0; b < a && ok; ++b) {
          ok = sample[b] != c && (source.points[src_ids[sample[b]]] - pc).squaredNorm() >= min_sep_sq;
        }
        if (ok) {
          np[a] = candidates.get(c, cp[a]);
          ok = np[a] > 0;
        }
        if (ok) sample[a] = c;
      }
    }
    if (!ok) continue;
    // Liu et al. 2022, sec. 1.2, SAC-IA step 2: one of the k most similar signatures at random.
    for (std::size_t a = 0; a < s; ++a) {
      const std::uint32_t j = candidates.draw(sample[a], rng);
      P[a] = source.points[src_ids[sample[a]]].cast<double>();
      Q[a] = target.points[j].cast<double>();
    }
    // Pre-rejection: a rigid motion keeps every edge length of the sampled polygon.
    bool similar = true;
    if (edge_ratio > 0.0) {
      for (std::size_t a = 0; a < s && similar; ++a) {
        const std::size_t b = (a + 1) % s;
        const double lp = (P[a] - P[b]).norm();
        const double lq = (Q[a] - Q[b]).norm();
        similar = std::min(lp, lq) >= edge_ratio * std::max(lp, lq);
      }
    }
    if (!similar) continue;
    // Liu et al. 2022, sec. 1.2, SAC-IA step 3: closed form, then the Huber score.
    HornAccumulator acc;
    for (std::size_t a = 0; a < s; ++a) acc.add(P[a], Q[a]);
    const HornResult h = acc.solve();
    if (!h.valid) continue;
    bool close = true;
    for (std::size_t a = 0; a < s && close; ++a) close = (h.T_target_source * P[a] - Q[a]).squaredNorm() <= m1_sq;
    if (!close) continue;
    if (settings.region_radius > 0.0 &&
        (h.T_target_source.translation() - settings.region_center).head<2>().norm() > settings.region_radius) {
      continue;
    }
    if (!settings.excluded.empty() && detail::near_any(h.T_target_source, settings.excluded, settings.exclude_distance,
                                                       settings.exclude_angle)) {
      continue;
    }
    ++out.num_scored;
    const Eigen::Matrix3f R = h.T_target_source.linear().cast<float>();
    const Eigen::Vector3f t = h.T_target_source.translation().cast<float>();
    const double pre_bound = std::min(best, std::isfinite(best_pre) ? pre_factor * best_pre : best);
    Inliers inliers;
    const double pre = score_range(R, t, 0, num_pre, 0.0, pre_bound, inliers);
    if (!(pre <= pre_factor * best_pre) && std::isfinite(best_pre)) continue;  // not promising
    if (!(pre < best)) continue;
    ++out.num_fully_scored;
    const double total = score_range(R, t, num_pre, score_order.size(), pre, best, inliers);
    if (!(total < best)) continue;  // (a hypothesis that gets here was scored on every point)
    best = total;
    best_inliers = inliers;
    best_pre = pre;
    best_T = h.T_target_source;
    update_needed();
  }
  out.iterations = it;
  out.num_feature_queries = candidates.num_known();
  if (!std::isfinite(best)) return out;  // no hypothesis survived: kInsufficientData
  out.T_target_source = best_T;
  out.score = best;
  out.status = out.converged ? Status::kOk : Status::kNotConverged;
  out.num_inliers = best_inliers.count;
  const double sum_sq = best_inliers.sum_sq;
  out.overlap = static_cast<double>(out.num_inliers) / static_cast<double>(score_order.size());
  if (out.num_inliers > 0) out.rmse = std::sqrt(sum_sq / static_cast<double>(out.num_inliers));
  return out;
}

}  // namespace plumb
