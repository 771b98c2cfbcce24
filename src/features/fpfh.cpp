// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/features/fpfh.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <utility>

#include "plumb/core/error.hpp"
#include "plumb/core/parallel.hpp"
#include "plumb/search/kdtree.hpp"

#include "features/fpfh_detail.hpp"

namespace plumb {

namespace {
constexpr std::size_t kSignatureGrain = 512;  // signatures per chunk
}  // namespace

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
  PLUMB_CHECK(settings.threads >= 0, "compute_fpfh: settings.threads = " << settings.threads << " must be >= 0 (0 = every core)");
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

  /// Rows for the usable `queries`, then for every neighbour in them. The rows are numbered first
  /// (in that order), then searched: in chunks of a fixed number of rows on settings.threads,
  /// each chunk into its own buffers, appended in chunk order.
  void build(const std::vector<std::size_t>& queries) {
    std::vector<std::uint32_t> points;
    for (std::size_t p : queries) {
      if (usable_[p] && row_of[p] == kNoRow) number_row(p, points);
    }
    search_rows(points);
    points.clear();
    const std::size_t num_query_rows = row_point.size();
    for (std::size_t r = 0; r < num_query_rows; ++r) {
      for (std::uint32_t e = rows.begin[r]; e < rows.begin[r + 1]; ++e) {
        const std::uint32_t q = rows.index[e];
        if (row_of[q] == kNoRow) number_row(q, points);
      }
    }
    search_rows(points);
  }

  std::vector<std::uint32_t> row_of;     ///< row of each cloud point, or kNoRow
  std::vector<std::uint32_t> row_point;  ///< cloud index of each row
  std::vector<std::uint8_t> row_capped;  ///< 1: the cap dropped neighbours within the radius
  FpfhNeighborRows rows;

 private:
  static constexpr std::size_t kRowGrain = 256;  // rows per chunk of searches

  // The searches of a chunk of rows: each row's neighbour count, then all their entries.
  struct RowChunk {
    std::vector<std::uint32_t> count, index;
    std::vector<float> dist_sq;
    std::vector<std::uint8_t> capped;
    std::vector<std::size_t> found_idx;  // scratch of the radius search
    std::vector<float> found_d2;
    std::vector<std::pair<float, std::uint32_t>> cand;
  };

  const PointCloud& cloud_;
  const FpfhSettings& settings_;
  const std::vector<std::uint8_t>& usable_;
  const KdTree<3> tree_;

  void number_row(std::size_t p, std::vector<std::uint32_t>& points) {
    row_of[p] = static_cast<std::uint32_t>(row_point.size());
    row_point.push_back(static_cast<std::uint32_t>(p));
    points.push_back(static_cast<std::uint32_t>(p));
  }

  void search_rows(const std::vector<std::uint32_t>& points) {
    const std::size_t chunks = chunk_count(points.size(), kRowGrain);
    std::vector<RowChunk> parts(chunks);
    parallel_chunks(settings_.threads, chunks, [&](std::size_t c) {
      const std::size_t end = std::min(points.size(), (c + 1) * kRowGrain);
      for (std::size_t i = c * kRowGrain; i < end; ++i) search_row(points[i], parts[c]);
    });
    for (RowChunk& part : parts) {
      for (std::uint32_t count : part.count) rows.begin.push_back(rows.begin.back() + count);
      rows.index.insert(rows.index.end(), part.index.begin(), part.index.end());
      rows.dist_sq.insert(rows.dist_sq.end(), part.dist_sq.begin(), part.dist_sq.end());
      row_capped.insert(row_capped.end(), part.capped.begin(), part.capped.end());
      part = RowChunk();
    }
  }

  /// One radius search for point p, its row into `out`: its neighbours (self excluded, nearest
  /// max_neighbors kept with self counted, as Open3D's hybrid search).
  void search_row(std::size_t p, RowChunk& out) const {
    const std::size_t m = tree_.radius(cloud_.points[p], settings_.radius, out.found_idx, out.found_d2, false);
    auto& cand = out.cand;
    cand.clear();
    bool self_found = false;
    const bool visible_only = settings_.visible_side_tolerance >= 0.0f;
    for (std::size_t j = 0; j < m; ++j) {
      const std::size_t q = out.found_idx[j];
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
      cand.emplace_back(out.found_d2[j], static_cast<std::uint32_t>(q));
    }
    // With the point itself counted, `cap` entries leave cap - 1 neighbours.
    const std::size_t cap = settings_.max_neighbors;
    const std::size_t keep = (cap == 0) ? cand.size() : std::min(cand.size(), cap - (self_found ? 1 : 0));
    out.capped.push_back(keep < cand.size() ? 1 : 0);
    if (keep < cand.size()) {
      std::nth_element(cand.begin(), cand.begin() + static_cast<std::ptrdiff_t>(keep), cand.end());
      cand.resize(keep);
    }
    for (const auto& c : cand) {
      out.index.push_back(c.second);
      out.dist_sq.push_back(c.first);
    }
    out.count.push_back(static_cast<std::uint32_t>(cand.size()));
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

  // The FPFH of every query with neighbours (each writes only its own signature; the queries
  // without are counted per chunk).
  std::vector<std::size_t> invalid(chunk_count(out.indices.size(), kSignatureGrain), 0);
  parallel_for(settings.threads, out.indices.size(), kSignatureGrain, [&](std::size_t begin, std::size_t end) {
    for (std::size_t f = begin; f < end; ++f) {
      const std::size_t p = out.indices[f];
      const std::uint32_t r = usable[p] ? nb.row_of[p] : detail::FpfhNeighborhoods::kNoRow;
      if (r == detail::FpfhNeighborhoods::kNoRow || nb.rows.begin[r] == nb.rows.begin[r + 1]) {
        ++invalid[begin / kSignatureGrain];
      } else {
        detail::fpfh_signature(nb, spfh, r, out.features[f]);
      }
    }
  });
  for (std::size_t k : invalid) out.num_invalid += k;
  return out;
}

}  // namespace plumb
