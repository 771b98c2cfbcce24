// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/features/fpfh.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <utility>

#include "plumb/core/error.hpp"
#include "plumb/search/kdtree.hpp"

#include "features/fpfh_detail.hpp"

namespace plumb {

namespace detail {

/// Bin of a value of the φ or θ feature, a cosine in [-1, 1]: floor(11 (f + 1) / 2), clamped.
int fpfh_cos_bin(float f) {
  int b = static_cast<int>(std::floor(static_cast<float>(kFpfhBinsPerFeature) * (f + 1.0f) * 0.5f));
  return std::min(std::max(b, 0), kFpfhBinsPerFeature - 1);
}

int fpfh_angle_bin(float y, float x) {
  // cos / sin of β_k for k = 1..10 (float of the double values)
  static constexpr float kCos[10] = {-0.841253532831181f, -0.415415013001886f, 0.142314838273285f,
                                     0.654860733945285f,  0.959492973614497f,  0.959492973614497f,
                                     0.654860733945285f,  0.142314838273285f,  -0.415415013001886f,
                                     -0.841253532831181f};
  static constexpr float kSin[10] = {-0.540640817455598f, -0.909631995354518f, -0.989821441880933f,
                                     -0.755749574354258f, -0.281732556841430f, 0.281732556841430f,
                                     0.755749574354258f,  0.989821441880933f,  0.909631995354518f,
                                     0.540640817455598f};
  if (x == 0.0f && y == 0.0f) return kFpfhBinsPerFeature / 2;
  const int half = y >= 0.0f ? 5 : 0;
  int bin = half;
  for (int k = 0; k < 5; ++k) {
    bin += (y * kCos[half + k] - x * kSin[half + k] >= 0.0f) ? 1 : 0;
  }
  return bin;
}

/// Bins (α, φ, θ) of the pair features of (p1, n1) and (p2, n2), Rusu 2009 / PCL / Open3D
/// `ComputePairFeatures`: the pair's source is the point whose normal is closer to the connecting
/// line; u = source normal, v = unit(d × u), w = u × v, α = atan2(w·n_t, u·n_t), φ = v·n_t,
/// θ = u·d/|d|. Degenerate pairs (coincident points, d parallel to u) give features (0, 0, 0).
/// @return false when the two normals make exactly equal angles with the line: then the source is
///         p1 here but p2 for the reversed pair, whose features differ. Otherwise the reversed
///         pair (p2, n2, p1, n1) has bit-identical features (every operation is mirrored exactly).
bool fpfh_pair_bins(const Vector3f& p1, const Vector3f& n1, const Vector3f& p2,
                    const Vector3f& n2, int bins[3]) {
  Vector3f d = p2 - p1;
  const float len = d.norm();
  // Features (0, 0, 0) fall in the middle bin of each sub-histogram.
  bins[0] = bins[1] = bins[2] = kFpfhBinsPerFeature / 2;
  if (len == 0.0f) return true;
  const float a1 = n1.dot(d) / len;
  const float a2 = n2.dot(d) / len;
  const Vector3f* u = &n1;
  const Vector3f* nt = &n2;
  float theta = a1;
  // acos(|a1|) > acos(|a2|)  <=>  |a1| < |a2|: the source is the point whose normal makes the
  // smaller angle with the line; swapping the roles reverses d.
  if (std::fabs(a1) < std::fabs(a2)) {
    u = &n2;
    nt = &n1;
    d = -d;
    theta = -a2;
  }
  const bool symmetric = std::fabs(a1) != std::fabs(a2);
  Vector3f v = d.cross(*u);
  const float v_norm = v.norm();
  if (v_norm == 0.0f) return symmetric;
  v /= v_norm;
  const Vector3f w = u->cross(v);
  bins[0] = fpfh_angle_bin(w.dot(*nt), u->dot(*nt));
  bins[1] = fpfh_cos_bin(v.dot(*nt));
  bins[2] = fpfh_cos_bin(theta);
  return symmetric;
}

/// Neighbour lists in compressed rows: row r holds entries [begin[r], begin[r + 1]).
struct FpfhNeighborRows {
  std::vector<std::uint32_t> begin{0};
  std::vector<std::uint32_t> index;  ///< neighbour's cloud index (the point itself excluded)
  std::vector<float> dist_sq;        ///< its squared distance [m^2]
};

/// Checks the cloud, the settings and the indices of compute_fpfh().
void check_fpfh_inputs(const PointCloud& cloud, const FpfhSettings& settings,
                       const std::vector<std::size_t>* indices) {
  PLUMB_CHECK(settings.radius > 0.0f && std::isfinite(settings.radius),
              "compute_fpfh: settings.radius = " << settings.radius << " must be > 0 and finite");
  PLUMB_CHECK(!std::isnan(settings.visible_side_tolerance), "compute_fpfh: settings.visible_side_tolerance is NaN");
  PLUMB_CHECK(!cloud.empty(), "compute_fpfh: the cloud is empty");
  PLUMB_CHECK(cloud.has_normals(),
              "compute_fpfh: the cloud has no normals (compute_normals first)");
  cloud.check_consistent("compute_fpfh");
  const std::size_t n = cloud.size();
  PLUMB_CHECK(n < std::numeric_limits<std::uint32_t>::max(),
              "compute_fpfh: " << n << " points is too many (limit 2^32 - 1)");
  if (indices != nullptr) {
    for (std::size_t k = 0; k < indices->size(); ++k) {
      PLUMB_CHECK((*indices)[k] < n, "compute_fpfh: indices[" << k << "] = " << (*indices)[k]
                                                               << " out of range for " << n
                                                               << " points");
    }
  }
}

/// The radius neighbourhoods compute_fpfh() needs: a row per point that needs an SPFH (the
/// queries, then their neighbours), built by one radius search each.
class FpfhNeighborhoods {
 public:
  static constexpr std::uint32_t kNoRow = std::numeric_limits<std::uint32_t>::max();

  FpfhNeighborhoods(const PointCloud& cloud, const FpfhSettings& settings, const std::vector<std::uint8_t>& usable)
      : row_of(cloud.size(), kNoRow), cloud_(cloud), settings_(settings), usable_(usable), tree_(cloud.points) {}

  /// Rows for the usable `queries`, then for every neighbour in them.
  void build(const std::vector<std::size_t>& queries) {
    for (std::size_t p : queries) {
      if (usable_[p] && row_of[p] == kNoRow) add_row(p);
    }
    const std::size_t num_query_rows = row_point.size();
    for (std::size_t r = 0; r < num_query_rows; ++r) {
      for (std::uint32_t e = rows.begin[r]; e < rows.begin[r + 1]; ++e) {
        const std::uint32_t q = rows.index[e];
        if (row_of[q] == kNoRow) add_row(q);
      }
    }
  }

  std::vector<std::uint32_t> row_of;     ///< row of each cloud point, or kNoRow
  std::vector<std::uint32_t> row_point;  ///< cloud index of each row
  std::vector<std::uint8_t> row_capped;  ///< 1: the cap dropped neighbours within the radius
  FpfhNeighborRows rows;

 private:
  const PointCloud& cloud_;
  const FpfhSettings& settings_;
  const std::vector<std::uint8_t>& usable_;
  const KdTree<3> tree_;
  std::vector<std::size_t> found_idx_;
  std::vector<float> found_d2_;
  std::vector<std::pair<float, std::uint32_t>> cand_;

  /// One radius search for point p; the row keeps its neighbours (self excluded, nearest
  /// max_neighbors kept with self counted, as Open3D's hybrid search).
  void add_row(std::size_t p) {
    row_of[p] = static_cast<std::uint32_t>(row_point.size());
    row_point.push_back(static_cast<std::uint32_t>(p));
    const std::size_t m = tree_.radius(cloud_.points[p], settings_.radius, found_idx_, found_d2_, false);
    cand_.clear();
    bool self_found = false;
    const bool visible_only = settings_.visible_side_tolerance >= 0.0f;
    for (std::size_t j = 0; j < m; ++j) {
      const std::size_t q = found_idx_[j];
      if (q == p) {
        self_found = true;
        continue;
      }
      if (!usable_[q]) continue;
      if (visible_only) {
        const Vector3f d = cloud_.points[q] - cloud_.points[p];
        if (cloud_.normals[p].dot(d) < -settings_.visible_side_tolerance ||
            cloud_.normals[q].dot(d) > settings_.visible_side_tolerance) {
          continue;
        }
      }
      cand_.emplace_back(found_d2_[j], static_cast<std::uint32_t>(q));
    }
    // With the point itself counted, `cap` entries leave cap - 1 neighbours.
    const std::size_t cap = settings_.max_neighbors;
    const std::size_t keep = (cap == 0) ? cand_.size() : std::min(cand_.size(), cap - (self_found ? 1 : 0));
    row_capped.push_back(keep < cand_.size() ? 1 : 0);
    if (keep < cand_.size()) {
      std::nth_element(cand_.begin(), cand_.begin() + static_cast<std::ptrdiff_t>(keep), cand_.end());
      cand_.resize(keep);
    }
    for (const auto& c : cand_) {
      rows.index.push_back(c.second);
      rows.dist_sq.push_back(c.first);
    }
    rows.begin.push_back(static_cast<std::uint32_t>(rows.index.size()));
  }

};

/// SPFH per row (Rusu 2009), kFpfhBins values a row, each sub-histogram normalised to 100: every
/// neighbour adds 100 / (number of neighbours) to one bin of each feature.
std::vector<float> compute_spfh(const PointCloud& cloud, const FpfhNeighborhoods& nb) {
  constexpr std::uint32_t kNoRow = FpfhNeighborhoods::kNoRow;
  const FpfhNeighborRows& rows = nb.rows;
  const std::size_t num_rows = nb.row_point.size();
  std::vector<float> incr(num_rows, 0.0f);
  for (std::size_t r = 0; r < num_rows; ++r) {
    const std::uint32_t count = rows.begin[r + 1] - rows.begin[r];
    if (count > 0) incr[r] = 100.0f / static_cast<float>(count);
  }
  std::vector<float> spfh(num_rows * kFpfhBins, 0.0f);
  auto add_bins = [&spfh, &incr](std::size_t r, const int bins[3]) {
    float* h = &spfh[r * kFpfhBins];
    const float inc = incr[r];
    h[bins[0]] += inc;
    h[kFpfhBinsPerFeature + bins[1]] += inc;
    h[2 * kFpfhBinsPerFeature + bins[2]] += inc;
  };
  for (std::size_t r = 0; r < num_rows; ++r) {
    const std::size_t p = nb.row_point[r];
    const Vector3f& pp = cloud.points[p];
    const Vector3f& np = cloud.normals[p];
    for (std::uint32_t k = rows.begin[r]; k < rows.begin[r + 1]; ++k) {
      const std::uint32_t q = rows.index[k];
      const std::uint32_t rq = nb.row_of[q];
      // Radius neighbourhoods are symmetric: when neither row was capped, q's row holds p, and
      // the pair's features are computed once (at the smaller index) for both rows. A bin is a
      // sum of equal increments, so the order of the additions does not change the result.
      const bool both = rq != kNoRow && !nb.row_capped[r] && !nb.row_capped[rq];
      if (both && q < p) continue;
      int bins[3];
      const bool mirrored = fpfh_pair_bins(pp, np, cloud.points[q], cloud.normals[q], bins);
      add_bins(r, bins);
      if (!both) continue;
      if (!mirrored) fpfh_pair_bins(cloud.points[q], cloud.normals[q], pp, np, bins);
      add_bins(rq, bins);
    }
  }
  return spfh;
}

/// FPFH of the point of row r (Liu et al. 2022, eq. 1, with Open3D's weighting and normalisation,
/// see the header): its SPFH plus its neighbours', weighted by 1 / squared distance.
void fpfh_signature(const FpfhNeighborhoods& nb, const std::vector<float>& spfh, std::uint32_t r,
                    FpfhSignature& sig) {
  const FpfhNeighborRows& rows = nb.rows;
  // float sums (4 lanes); 1e-6 relative, far below the bins' 1e-3 agreement with Open3D
  float acc[kFpfhBins] = {};
  for (std::uint32_t k = rows.begin[r]; k < rows.begin[r + 1]; ++k) {
    const float d2 = rows.dist_sq[k];
    if (d2 == 0.0f) continue;
    const float wgt = 1.0f / d2;
    const float* hq = &spfh[static_cast<std::size_t>(nb.row_of[rows.index[k]]) * kFpfhBins];
    for (int j = 0; j < kFpfhBins; ++j) acc[j] += wgt * hq[j];
  }
  float scale[3];
  for (int s = 0; s < 3; ++s) {
    double sum = 0.0;
    for (int j = 0; j < kFpfhBinsPerFeature; ++j) sum += acc[s * kFpfhBinsPerFeature + j];
    scale[s] = sum != 0.0 ? static_cast<float>(100.0 / sum) : 0.0f;
  }
  const float* hp = &spfh[static_cast<std::size_t>(r) * kFpfhBins];
  for (int j = 0; j < kFpfhBins; ++j) sig[j] = acc[j] * scale[j / kFpfhBinsPerFeature] + hp[j];
}

}  // namespace detail

FpfhResult compute_fpfh(const PointCloud& cloud, const FpfhSettings& settings,
                        const std::vector<std::size_t>* indices) {
  detail::check_fpfh_inputs(cloud, settings, indices);
  const std::size_t n = cloud.size();

  FpfhResult out;
  if (indices != nullptr) {
    out.indices = *indices;
  } else {
    out.indices.resize(n);
    for (std::size_t i = 0; i < n; ++i) out.indices[i] = i;
  }
  out.features.assign(out.indices.size(), FpfhSignature{});

  // A point takes part (as query or neighbour) only with a finite position and normal.
  std::vector<std::uint8_t> usable(n);
  std::size_t num_usable = 0;
  for (std::size_t i = 0; i < n; ++i) {
    usable[i] = cloud.points[i].allFinite() && cloud.normals[i].allFinite();
    num_usable += usable[i];
  }
  if (num_usable == 0) {
    out.num_invalid = out.indices.size();
    return out;
  }
  // The neighbourhoods of the queries and of their neighbours, then the SPFH of each.
  detail::FpfhNeighborhoods nb(cloud, settings, usable);
  nb.build(out.indices);
  const std::vector<float> spfh = detail::compute_spfh(cloud, nb);

  // The FPFH of every query with neighbours.
  for (std::size_t f = 0; f < out.indices.size(); ++f) {
    const std::size_t p = out.indices[f];
    const std::uint32_t r = usable[p] ? nb.row_of[p] : detail::FpfhNeighborhoods::kNoRow;
    if (r == detail::FpfhNeighborhoods::kNoRow || nb.rows.begin[r] == nb.rows.begin[r + 1]) {
      ++out.num_invalid;
      continue;
    }
    detail::fpfh_signature(nb, spfh, r, out.features[f]);
  }
  return out;
}

}  // namespace plumb
