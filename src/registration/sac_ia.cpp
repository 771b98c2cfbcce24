// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/registration/sac_ia.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <optional>
#include <vector>

#include "plumb/core/error.hpp"
#include "plumb/core/rng.hpp"
#include "plumb/core/robust_kernel.hpp"
#include "plumb/registration/feature_index.hpp"
#include "plumb/registration/horn.hpp"

#include "core/eigen_instantiations.hpp"
#include "registration/sac_ia_detail.hpp"

namespace plumb {

namespace detail {

bool fpfh_valid(const FpfhSignature& f) {
  bool any = false;
  for (float v : f) {
    if (!std::isfinite(v)) return false;
    any = any || v != 0.0f;
  }
  return any;
}

bool near_any(const Eigen::Isometry3d& T, const std::vector<Eigen::Isometry3d>& poses, double distance,
              double angle) {
  for (const Eigen::Isometry3d& E : poses) {
    if ((T.translation() - E.translation()).norm() >= distance) continue;
    if (Eigen::AngleAxisd(E.linear().transpose() * T.linear()).angle() < angle) return true;
  }
  return false;
}

void check_sac_ia_settings(const SacIaSettings& s) {
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

/// Usable points of a SAC-IA problem: finite, with a valid signature (samples and candidates), and
/// every finite source point (scored).
struct SacIaPoints {
  std::vector<std::size_t> src_ids, tgt_ids, score_order;
};

SacIaPoints sac_ia_usable_points(const PointCloud& source, const std::vector<FpfhSignature>& source_features,
                                 const PointCloud& target, const std::vector<FpfhSignature>& target_features) {
  SacIaPoints out;
  for (std::size_t i = 0; i < source.size(); ++i) {
    if (!source.points[i].allFinite()) continue;
    out.score_order.push_back(i);
    if (fpfh_valid(source_features[i])) out.src_ids.push_back(i);
  }
  for (std::size_t j = 0; j < target.size(); ++j)
    if (target.points[j].allFinite() && fpfh_valid(target_features[j])) out.tgt_ids.push_back(j);
  return out;
}

/// Points within the Huber threshold m1 of the target (inliers) and their squared distances.
struct SacIaInliers {
  std::size_t count = 0;
  double sum_sq = 0.0;
};

/// The score of a hypothesis: the source points, in score order, against the target.
class SacIaScorer {
 public:
  SacIaScorer(const PointCloud& source, const KdTree3f& target_tree, const std::vector<std::size_t>& score_order,
              const SacIaSettings& settings)
      : source_(source),
        target_tree_(target_tree),
        score_order_(score_order),
        m1_(settings.huber_threshold),
        huber_(RobustLoss::huber(m1_)),
        m1_sq_f_(static_cast<float>(m1_ * m1_)),
        max_d_sq_(static_cast<float>(settings.max_correspondence_distance * settings.max_correspondence_distance)),
        far_cost_(huber_.loss(settings.max_correspondence_distance)) {}

  // Huber total (Liu et al. 2022, eq. 2, distances truncated at max_correspondence_distance) over
  // score_order[begin, end), added to `total`; stops early once total >= bound (exact: every
  // penalty is >= 0). Also counts the points within m1 (inliers) and their squared distances, so
  // that the winner's statistics need no extra pass.
  double score_range(const Eigen::Matrix3f& R, const Eigen::Vector3f& t, std::size_t begin, std::size_t end,
                     double total, double bound, SacIaInliers& inliers) const {
    for (std::size_t n = begin; n < end && total < bound; ++n) {
      const auto nn = target_tree_.nearest(R * source_.points[score_order_[n]] + t, max_d_sq_);
      if (!nn) {
        total += far_cost_;
        continue;
      }
      total += huber_.loss(std::sqrt(static_cast<double>(nn->dist_sq)));
      if (nn->dist_sq < m1_sq_f_) {
        ++inliers.count;
        inliers.sum_sq += static_cast<double>(nn->dist_sq);
      }
    }
    return total;
  }

 private:
  const PointCloud& source_;
  const KdTree3f& target_tree_;
  const std::vector<std::size_t>& score_order_;
  const double m1_;
  const RobustLoss huber_;  // Liu et al. 2022, eq. 2, m1 = the scale
  const float m1_sq_f_;
  const float max_d_sq_;
  const double far_cost_;
};

/// Hypotheses of SAC-IA (Liu et al. 2022, sec. 1.2, steps 1 to 3 up to the score), and how many of
/// them the best one found so far makes necessary.
class SacIaSampler {
 public:
  SacIaSampler(const PointCloud& source, const PointCloud& target, const std::vector<std::size_t>& src_ids,
               SacIaCandidates& candidates, const SacIaSettings& settings)
      : source_(source),
        target_(target),
        src_ids_(src_ids),
        candidates_(candidates),
        settings_(settings),
        s_(settings.num_samples),
        m1_sq_(settings.huber_threshold * settings.huber_threshold),
        min_sep_sq_(settings.min_sample_distance * settings.min_sample_distance),
        sample_(s_),
        P_(s_),
        Q_(s_),
        cp_(s_),
        np_(s_) {}

  /// The next hypothesis T_target_source, or none when its sample or pairs fail a test.
  std::optional<Eigen::Isometry3d> next(Rng& rng) {
    if (!draw_sample(rng)) return std::nullopt;
    // Liu et al. 2022, sec. 1.2, SAC-IA step 2: one of the k most similar signatures at random.
    for (std::size_t a = 0; a < s_; ++a) {
      const std::uint32_t j = candidates_.draw(sample_[a], rng);
      P_[a] = source_.points[src_ids_[sample_[a]]].cast<double>();
      Q_[a] = target_.points[j].cast<double>();
    }
    // Pre-rejection: a rigid motion keeps every edge length of the sampled polygon.
    bool similar = true;
    const double edge_ratio = settings_.edge_similarity;
    if (edge_ratio > 0.0) {
      for (std::size_t a = 0; a < s_ && similar; ++a) {
        const std::size_t b = (a + 1) % s_;
        const double lp = (P_[a] - P_[b]).norm();
        const double lq = (Q_[a] - Q_[b]).norm();
        similar = std::min(lp, lq) >= edge_ratio * std::max(lp, lq);
      }
    }
    if (!similar) return std::nullopt;
    // Liu et al. 2022, sec. 1.2, SAC-IA step 3: closed form (the Huber score is the caller's).
    HornAccumulator acc;
    for (std::size_t a = 0; a < s_; ++a) acc.add(P_[a], Q_[a]);
    const HornResult h = acc.solve();
    if (!h.valid) return std::nullopt;
    bool close = true;
    for (std::size_t a = 0; a < s_ && close; ++a) close = (h.T_target_source * P_[a] - Q_[a]).squaredNorm() <= m1_sq_;
    if (!close) return std::nullopt;
    if (settings_.region_radius > 0.0 &&
        (h.T_target_source.translation() - settings_.region_center).head<2>().norm() > settings_.region_radius) {
      return std::nullopt;
    }
    if (!settings_.excluded.empty() && near_any(h.T_target_source, settings_.excluded, settings_.exclude_distance,
                                                settings_.exclude_angle)) {
      return std::nullopt;
    }
    return h.T_target_source;
  }

  // Early termination (RANSAC-style): w = the chance that the pair drawn for a sampled point is
  // one the best hypothesis maps within m1, averaged over the points whose candidates are known;
  // an all-correct set of s pairs then comes with probability about w^s per hypothesis.
  /// Hypotheses needed with `best_T` the best so far; `needed` unchanged when that cannot be told.
  double iterations_needed(const Eigen::Isometry3d& best_T, double needed) const {
    double sum_good = 0.0;
    std::size_t num_points = 0;
    for (std::size_t a : candidates_.known_points()) {
      const std::uint32_t* c = nullptr;
      const std::size_t n = candidates_.get(a, c);
      if (n == 0) continue;
      const double* p = candidates_.probabilities(a);
      const Vector3d x = best_T * source_.points[src_ids_[a]].cast<double>();
      ++num_points;
      for (std::size_t m = 0; m < n; ++m)
        if ((x - target_.points[c[m]].cast<double>()).squaredNorm() < m1_sq_) sum_good += p[m];
    }
    if (settings_.confidence >= 1.0 || num_points == 0) return needed;
    const double w = std::min(1.0, sum_good / static_cast<double>(num_points));
    const double ws = std::pow(w, static_cast<double>(s_));
    return ws >= 1.0 ? 1.0 : ws > 0.0 ? std::log(1.0 - settings_.confidence) / std::log1p(-ws)
                                      : static_cast<double>(settings_.max_iterations);
  }

 private:
  static constexpr int kMaxSampleAttempts = 100;

  // Liu et al. 2022, sec. 1.2, SAC-IA step 1: samples pairwise farther apart than d (and with at
  // least one candidate).
  bool draw_sample(Rng& rng) {
    bool ok = true;
    for (std::size_t a = 0; a < s_ && ok; ++a) {
      ok = false;
      for (int attempt = 0; attempt < kMaxSampleAttempts && !ok; ++attempt) {
        const std::size_t c = static_cast<std::size_t>(rng.uniform_index(src_ids_.size()));
        const Vector3f& pc = source_.points[src_ids_[c]];
        ok = true;
        for (std::size_t b = 0; b < a && ok; ++b) {
          ok = sample_[b] != c && (source_.points[src_ids_[sample_[b]]] - pc).squaredNorm() >= min_sep_sq_;
        }
        if (ok) {
          np_[a] = candidates_.get(c, cp_[a]);
          ok = np_[a] > 0;
        }
        if (ok) sample_[a] = c;
      }
    }
    return ok;
  }

  const PointCloud& source_;
  const PointCloud& target_;
  const std::vector<std::size_t>& src_ids_;
  SacIaCandidates& candidates_;
  const SacIaSettings& settings_;
  const std::size_t s_;
  const double m1_sq_;
  const double min_sep_sq_;
  std::vector<std::size_t> sample_;  // positions in src_ids
  std::vector<Vector3d> P_, Q_;
  std::vector<const std::uint32_t*> cp_;  // candidates of each sample
  std::vector<std::size_t> np_;           // and their number
};

}  // namespace detail

SacIaResult align_sac_ia(const PointCloud& source, const std::vector<FpfhSignature>& source_features,
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
  detail::SacIaPoints points = detail::sac_ia_usable_points(source, source_features, target, target_features);
  std::vector<std::size_t>& score_order = points.score_order;
  if (points.src_ids.size() < s || points.tgt_ids.size() < 3) return out;

  // Liu et al. 2022, sec. 1.2, SAC-IA step 2: the k most similar target signatures, computed for a
  // source point when it is first sampled.
  const std::size_t k = std::min(settings.k_correspondences, points.tgt_ids.size());
  detail::SacIaCandidates candidates(source_features, points.src_ids, target_features, points.tgt_ids, k,
                                     settings.mutual_filter, settings.similarity_weighted);

  Rng rng(settings.seed);
  // Score points in a fixed random order: its first points are the pre-scoring subset, and the
  // early exit of a bad hypothesis comes soon.
  for (std::size_t i = score_order.size(); i > 1; --i)
    std::swap(score_order[i - 1], score_order[rng.uniform_index(i)]);
  const std::size_t num_pre = std::min(settings.num_prescore_points, score_order.size());
  const double pre_factor = 1.0 + settings.prescore_slack;
  detail::SacIaSampler sampler(source, target, points.src_ids, candidates, settings);
  const detail::SacIaScorer scorer(source, target_tree, score_order, settings);

  double best = std::numeric_limits<double>::infinity();
  double best_pre = std::numeric_limits<double>::infinity();
  Eigen::Isometry3d best_T = Eigen::Isometry3d::Identity();
  detail::SacIaInliers best_inliers;
  double needed = static_cast<double>(settings.max_iterations);
  int it = 0;
  for (; it < settings.max_iterations; ++it) {
    if (static_cast<double>(it) >= needed && std::isfinite(best)) {
      // Re-estimate with every pair computed so far (more points than when `needed` was set).
      needed = sampler.iterations_needed(best_T, needed);
      if (static_cast<double>(it) >= needed) {
        out.converged = true;
        break;
      }
    }
    const std::optional<Eigen::Isometry3d> T = sampler.next(rng);
    if (!T) continue;
    // Liu et al. 2022, sec. 1.2, SAC-IA step 3: the Huber score, first on the pre-scoring subset.
    ++out.num_scored;
    const Eigen::Matrix3f R = T->linear().cast<float>();
    const Eigen::Vector3f t = T->translation().cast<float>();
    const double pre_bound = std::min(best, std::isfinite(best_pre) ? pre_factor * best_pre : best);
    detail::SacIaInliers inliers;
    const double pre = scorer.score_range(R, t, 0, num_pre, 0.0, pre_bound, inliers);
    if (!(pre <= pre_factor * best_pre) && std::isfinite(best_pre)) continue;  // not promising
    if (!(pre < best)) continue;
    ++out.num_fully_scored;
    const double total = scorer.score_range(R, t, num_pre, score_order.size(), pre, best, inliers);
    if (!(total < best)) continue;  // (a hypothesis that gets here was scored on every point)
    best = total;
    best_inliers = inliers;
    best_pre = pre;
    best_T = *T;
    needed = sampler.iterations_needed(best_T, needed);
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
