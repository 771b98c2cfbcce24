// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <algorithm>
#include <cmath>
#include <limits>
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

inline void check_sac_ia_settings(const SacIaSettings& s) {
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
}

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

  // SEEDS A1.4b: the k most similar target signatures of every usable source point.
  const std::size_t k = std::min(settings.k_correspondences, tgt_ids.size());
  const std::vector<std::uint32_t> candidates = feature_knn(source_features, src_ids, target_features, tgt_ids, k);

  Rng rng(settings.seed);
  // Score points in a fixed random order so that the early exit of a bad hypothesis comes soon.
  for (std::size_t i = score_order.size(); i > 1; --i)
    std::swap(score_order[i - 1], score_order[rng.uniform_index(i)]);

  const double m1 = settings.huber_threshold;
  const double max_d = settings.max_correspondence_distance;
  const float max_d_sq = static_cast<float>(max_d * max_d);
  const double far_cost = huber_penalty(max_d, m1);
  const double min_sep_sq = settings.min_sample_distance * settings.min_sample_distance;
  const double edge_ratio = settings.edge_similarity;

  double best = std::numeric_limits<double>::infinity();
  Eigen::Isometry3d best_T = Eigen::Isometry3d::Identity();
  double needed = static_cast<double>(settings.max_iterations);
  std::vector<std::size_t> sample(s);   // positions in src_ids
  std::vector<Vector3d> P(s), Q(s);
  constexpr int kMaxSampleAttempts = 100;

  auto score = [&](const Eigen::Isometry3d& T, double bound) {
    const Eigen::Matrix3f R = T.linear().cast<float>();
    const Eigen::Vector3f t = T.translation().cast<float>();
    double total = 0.0;
    for (std::size_t i : score_order) {
      const auto nn = target_tree.nearest(R * source.points[i] + t, max_d_sq);
      // SEEDS eq. 2 on the nearest-neighbour distance, truncated at max_correspondence_distance.
      total += nn ? huber_penalty(std::sqrt(static_cast<double>(nn->dist_sq)), m1) : far_cost;
      if (total >= bound) return total;  // exact: penalties are >= 0
    }
    return total;
  };

  int it = 0;
  for (; it < settings.max_iterations; ++it) {
    if (static_cast<double>(it) >= needed) {
      out.converged = true;
      break;
    }
    // SEEDS A1.4a: samples pairwise farther apart than d.
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
        if (ok) sample[a] = c;
      }
    }
    if (!ok) continue;
    // SEEDS A1.4b: one of the k most similar signatures at random.
    for (std::size_t a = 0; a < s; ++a) {
      const std::uint32_t j = candidates[sample[a] * k + rng.uniform_index(k)];
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
    // SEEDS A1.4c: closed form, then the Huber score.
    HornAccumulator acc;
    for (std::size_t a = 0; a < s; ++a) acc.add(P[a], Q[a]);
    const HornResult h = acc.solve();
    if (!h.valid) continue;
    bool close = true;
    for (std::size_t a = 0; a < s && close; ++a) close = (h.T_target_source * P[a] - Q[a]).norm() <= m1;
    if (!close) continue;
    ++out.num_scored;
    const double total = score(h.T_target_source, best);
    if (!(total < best)) continue;
    best = total;
    best_T = h.T_target_source;
    // Early termination: w = chance that a drawn (point, candidate) pair is right under the best
    // hypothesis; an all-correct set of s pairs comes with probability about w^s.
    std::size_t num_good = 0;
    for (std::size_t a = 0; a < src_ids.size(); ++a) {
      const Vector3d x = best_T * source.points[src_ids[a]].cast<double>();
      for (std::size_t m = 0; m < k; ++m)
        num_good += (x - target.points[candidates[a * k + m]].cast<double>()).squaredNorm() < m1 * m1 ? 1 : 0;
    }
    const double w = static_cast<double>(num_good) / static_cast<double>(src_ids.size() * k);
    const double ws = std::pow(w, static_cast<double>(s));
    if (settings.confidence < 1.0 && ws > 0.0) {
      needed = ws >= 1.0 ? 1.0 : std::log(1.0 - settings.confidence) / std::log1p(-ws);
    }
  }
  out.iterations = it;
  if (!std::isfinite(best)) return out;  // no hypothesis survived: kInsufficientData
  out.T_target_source = best_T;
  out.score = best;
  out.status = out.converged ? Status::kOk : Status::kNotConverged;
  // Inliers of the winner.
  const Eigen::Matrix3f R = best_T.linear().cast<float>();
  const Eigen::Vector3f t = best_T.translation().cast<float>();
  const float m1_sq = static_cast<float>(m1 * m1);
  double sum_sq = 0.0;
  for (std::size_t i : score_order) {
    const auto nn = target_tree.nearest(R * source.points[i] + t, m1_sq);
    if (nn && nn->dist_sq < m1_sq) {
      ++out.num_inliers;
      sum_sq += nn->dist_sq;
    }
  }
  out.overlap = static_cast<double>(out.num_inliers) / static_cast<double>(score_order.size());
  if (out.num_inliers > 0) out.rmse = std::sqrt(sum_sq / static_cast<double>(out.num_inliers));
  return out;
}

}  // namespace plumb
