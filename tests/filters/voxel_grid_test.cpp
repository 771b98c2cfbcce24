// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/filters/voxel_grid.hpp"

#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "plumb/core/error.hpp"
#include "plumb/core/rng.hpp"
#include "plumb/io/pcd.hpp"
#include "filters/voxel_sort.hpp"
#include "test_data.hpp"

namespace plumb {
namespace {

constexpr float kQuietNaN = std::numeric_limits<float>::quiet_NaN();
constexpr float kInfinity = std::numeric_limits<float>::infinity();

// ---- brute-force oracle ---------------------------------------------------------------------
// Voxel coordinates floor((p - min) / leaf) in double (the documented convention), grouped in a
// std::map keyed by (i_z, i_y, i_x) so that iteration follows the documented output order.
struct OracleVoxel {
  std::vector<std::size_t> members;  // ascending source index
  Vector3d centroid = Vector3d::Zero();
  std::size_t nearest = 0;
};

std::vector<OracleVoxel> oracle_voxels(const PointCloud& cloud, double leaf,
                                       std::size_t min_points = 1) {
  Vector3d lo = Vector3d::Constant(std::numeric_limits<double>::infinity());
  for (const Vector3f& p : cloud.points) {
    if (p.allFinite()) lo = lo.cwiseMin(p.cast<double>());
  }
  std::map<std::array<std::int64_t, 3>, std::vector<std::size_t>> cells;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const Vector3f& p = cloud.points[i];
    if (!p.allFinite()) continue;
    std::array<std::int64_t, 3> c{};
    for (int a = 0; a < 3; ++a) {
      c[static_cast<std::size_t>(2 - a)] =
          static_cast<std::int64_t>(std::floor((static_cast<double>(p[a]) - lo[a]) / leaf));
    }
    cells[c].push_back(i);
  }
  std::vector<OracleVoxel> out;
  for (const auto& [coords, members] : cells) {
    if (members.size() < min_points) continue;
    OracleVoxel v;
    v.members = members;
    for (std::size_t i : members) v.centroid += cloud.points[i].cast<double>();
    v.centroid /= static_cast<double>(members.size());
    double best = std::numeric_limits<double>::infinity();
    for (std::size_t i : members) {
      const double d = (cloud.points[i].cast<double>() - v.centroid).squaredNorm();
      if (d < best) {
        best = d;
        v.nearest = i;
      }
    }
    out.push_back(v);
  }
  return out;
}

PointCloud random_cloud(std::uint64_t seed, std::size_t n, double lo, double hi,
                        bool with_fields) {
  Rng rng(seed);
  PointCloud c;
  for (std::size_t i = 0; i < n; ++i) {
    c.points.emplace_back(static_cast<float>(rng.uniform(lo, hi)),
                          static_cast<float>(rng.uniform(lo, hi)),
                          static_cast<float>(rng.uniform(lo, hi)));
    if (with_fields) {
      Vector3d nrm(rng.normal(), rng.normal(), rng.normal());
      c.normals.push_back(nrm.normalized().cast<float>());
      c.intensities.push_back(static_cast<float>(rng.uniform(0.0, 255.0)));
      c.rings.push_back(static_cast<std::uint16_t>(rng.uniform_index(32)));
      c.times.push_back(static_cast<float>(rng.uniform(0.0, 0.1)));
      c.labels.push_back(static_cast<std::int32_t>(rng.uniform_index(1000)) - 500);
    }
  }
  return c;
}

void expect_nearest_matches_oracle(const PointCloud& cloud, double leaf, std::size_t min_points) {
  VoxelGridSettings s;
  s.leaf_size = leaf;
  s.min_points_per_voxel = min_points;
  const VoxelGridResult r = voxel_grid(cloud, s);
  const std::vector<OracleVoxel> ref = oracle_voxels(cloud, leaf, min_points);
  ASSERT_EQ(r.cloud.size(), ref.size()) << "leaf " << leaf;
  ASSERT_EQ(r.indices.size(), ref.size());
  for (std::size_t k = 0; k < ref.size(); ++k) {
    ASSERT_EQ(r.indices[k], ref[k].nearest) << "voxel " << k << " leaf " << leaf;
    ASSERT_EQ(r.cloud.points[k], cloud.points[ref[k].nearest]);
  }
}

// ---- oracle comparisons -----------------------------------------------------------------------

TEST(VoxelGridTest, NearestMatchesBruteForceOnRandomClouds) {
  // Negative and positive coordinates, leaves from very fine (mostly single points) to coarse.
  for (std::uint64_t seed = 1; seed <= 4; ++seed) {
    const PointCloud cloud = random_cloud(seed, 3000, -7.3, 5.1, false);
    for (double leaf : {0.05, 0.3, 1.0, 2.7, 100.0}) expect_nearest_matches_oracle(cloud, leaf, 1);
  }
}

TEST(VoxelGridTest, CentroidMatchesBruteForceOnRandomClouds) {
  const PointCloud cloud = random_cloud(11, 4000, -3.0, 2.0, true);
  for (double leaf : {0.2, 0.9}) {
    VoxelGridSettings s;
    s.leaf_size = leaf;
    s.mode = VoxelMode::kCentroid;
    const VoxelGridResult r = voxel_grid(cloud, s);
    const std::vector<OracleVoxel> ref = oracle_voxels(cloud, leaf);
    ASSERT_EQ(r.cloud.size(), ref.size());
    EXPECT_TRUE(r.indices.empty());
    EXPECT_EQ(r.num_voxels, ref.size());
    ASSERT_EQ(r.cloud.normals.size(), ref.size());
    ASSERT_EQ(r.cloud.intensities.size(), ref.size());
    ASSERT_EQ(r.cloud.rings.size(), ref.size());
    ASSERT_EQ(r.cloud.times.size(), ref.size());
    ASSERT_EQ(r.cloud.labels.size(), ref.size());
    for (std::size_t k = 0; k < ref.size(); ++k) {
      const OracleVoxel& v = ref[k];
      EXPECT_LT((r.cloud.points[k].cast<double>() - v.centroid).norm(), 1e-6) << "voxel " << k;
      Vector3d nsum = Vector3d::Zero();
      double isum = 0.0, tsum = 0.0;
      for (std::size_t i : v.members) {
        nsum += cloud.normals[i].cast<double>();
        isum += cloud.intensities[i];
        tsum += cloud.times[i];
      }
      const double m = static_cast<double>(v.members.size());
      if (nsum.norm() / m > 1e-3) {
        EXPECT_LT((r.cloud.normals[k].cast<double>() - nsum.normalized()).norm(), 1e-5);
      }
      EXPECT_NEAR(r.cloud.normals[k].norm(), 1.0f, 1e-5f);
      EXPECT_NEAR(r.cloud.intensities[k], isum / m, 1e-3);
      EXPECT_NEAR(r.cloud.times[k], tsum / m, 1e-7);
      EXPECT_EQ(r.cloud.rings[k], cloud.rings[v.nearest]);
      EXPECT_EQ(r.cloud.labels[k], cloud.labels[v.nearest]);
    }
  }
}

TEST(VoxelGridTest, PointsExactlyOnVoxelBorders) {
  // Leaf 0.25 and coordinates k * 0.25 are exact in float and double, so every lattice point sits
  // on a voxel's lower border and opens its own voxel; points +0.1 inside join that voxel, points
  // 0.25 - 2^-20 inside still do.
  const double leaf = 0.25;
  PointCloud cloud;
  for (int z = 0; z < 4; ++z) {
    for (int y = -2; y < 2; ++y) {
      for (int x = -3; x < 1; ++x) {
        const Vector3f corner(0.25f * static_cast<float>(x), 0.25f * static_cast<float>(y),
                              0.25f * static_cast<float>(z));
        cloud.points.push_back(corner);
        cloud.points.push_back(corner + Vector3f(0.1f, 0.1f, 0.1f));
        cloud.points.push_back(corner + Vector3f::Constant(0.25f - 0x1.0p-20f));
      }
    }
  }
  VoxelGridSettings s;
  s.leaf_size = leaf;
  const VoxelGridResult r = voxel_grid(cloud, s);
  EXPECT_EQ(r.num_voxels, 64u);  // 4 x 4 x 4 lattice cells, counted by hand
  EXPECT_EQ(r.cloud.size(), 64u);
  EXPECT_EQ(r.status, Status::kOk);
  expect_nearest_matches_oracle(cloud, leaf, 1);
  // Nearest to the centroid of {c, c + 0.1, c + 0.25 - eps} (centroid c + ~0.117) is c + 0.1.
  for (std::size_t k = 0; k < r.indices.size(); ++k) EXPECT_EQ(r.indices[k] % 3, 1u);
  // Output order: i_z slowest, i_x fastest.
  for (std::size_t k = 1; k < r.cloud.size(); ++k) {
    const Vector3f& a = r.cloud.points[k - 1];
    const Vector3f& b = r.cloud.points[k];
    const bool ascending = a.z() < b.z() || (a.z() == b.z() && (a.y() < b.y() ||
                                                                 (a.y() == b.y() && a.x() < b.x())));
    EXPECT_TRUE(ascending) << "k " << k;
  }
  // Random points snapped to a lattice of the leaf size: many points exactly on borders.
  Rng rng(5);
  PointCloud snapped;
  for (int i = 0; i < 2000; ++i) {
    Vector3f p;
    for (int a = 0; a < 3; ++a) {
      const double u = rng.uniform(-2.0, 2.0);
      p[a] = static_cast<float>(rng.uniform() < 0.5 ? std::round(u / 0.125) * 0.125 : u);
    }
    snapped.points.push_back(p);
  }
  for (double l : {0.125, 0.25, 0.5}) expect_nearest_matches_oracle(snapped, l, 1);
}

TEST(VoxelGridTest, BordersWhereProductAndQuotientDisagreeFollowTheQuotient) {
  // For leaves without an exact inverse, (p - min) * (1 / leaf) and (p - min) / leaf can have
  // different floors right at a voxel border. Find such float coordinates (the search is part of
  // the test, so it cannot pass vacuously) and check the documented quotient convention holds.
  // Candidates: exact floats j / 256. Both directions occur: 1.75 / 0.07 is 24.999999999999996
  // as a quotient but exactly 25 as a product; 3.25 / 0.13 is exactly 25 as a quotient but
  // 24.999999999999996 as a product.
  for (double leaf : {0.07, 1.1, 0.13, 0.17}) {
    PointCloud cloud;
    cloud.points.emplace_back(0.0f, 0.0f, 0.0f);  // bounding-box min at the origin
    const double inv = 1.0 / leaf;
    std::size_t num_disagreeing = 0;
    for (int j = 1; j < 400000 && num_disagreeing < 40; ++j) {
      const float x = static_cast<float>(j) / 256.0f;
      const double d = static_cast<double>(x);
      if (std::floor(d * inv) != std::floor(d / leaf)) {
        ++num_disagreeing;
        cloud.points.emplace_back(x, 0.5f * static_cast<float>(leaf), x);
        // A neighbour just below the border: must land in the voxel before.
        cloud.points.emplace_back(std::nextafter(x, 0.0f), 0.5f * static_cast<float>(leaf), x);
      }
    }
    ASSERT_GT(num_disagreeing, 0u) << "leaf " << leaf;
    // Points spread over voxels so most are alone: then the kept index reveals the voxel split.
    expect_nearest_matches_oracle(cloud, leaf, 1);
    VoxelGridSettings s;
    s.leaf_size = leaf;
    EXPECT_EQ(voxel_grid(cloud, s).num_voxels, oracle_voxels(cloud, leaf).size());
  }
}

TEST(VoxelGridTest, TiesGoToLowestSourceIndex) {
  // Two points (exact in float) symmetric about their centroid (0.5, 0.5, 0.5): equally near, so
  // the one that comes first in the input is kept, whichever it is.
  PointCloud cloud;
  cloud.points = {Vector3f(0.75f, 0.5f, 0.5f), Vector3f(0.25f, 0.5f, 0.5f), Vector3f(5, 5, 5)};
  VoxelGridSettings s;
  s.leaf_size = 1.0;
  VoxelGridResult r = voxel_grid(cloud, s);
  ASSERT_EQ(r.indices.size(), 2u);
  EXPECT_EQ(r.indices[0], 0u);
  std::swap(cloud.points[0], cloud.points[1]);
  r = voxel_grid(cloud, s);
  ASSERT_EQ(r.indices.size(), 2u);
  EXPECT_EQ(r.indices[0], 0u);
  EXPECT_EQ(r.cloud.points[0], Vector3f(0.25f, 0.5f, 0.5f));
}

TEST(VoxelGridTest, NearestModeCopiesEveryField) {
  const PointCloud cloud = random_cloud(21, 2500, -1.0, 1.0, true);
  VoxelGridSettings s;
  s.leaf_size = 0.3;
  const VoxelGridResult r = voxel_grid(cloud, s);
  const std::vector<OracleVoxel> ref = oracle_voxels(cloud, 0.3);
  ASSERT_EQ(r.indices.size(), ref.size());
  for (std::size_t k = 0; k < ref.size(); ++k) {
    const std::size_t i = ref[k].nearest;
    ASSERT_EQ(r.indices[k], i);
    EXPECT_EQ(r.cloud.points[k], cloud.points[i]);
    EXPECT_EQ(r.cloud.normals[k], cloud.normals[i]);
    EXPECT_EQ(r.cloud.intensities[k], cloud.intensities[i]);
    EXPECT_EQ(r.cloud.rings[k], cloud.rings[i]);
    EXPECT_EQ(r.cloud.times[k], cloud.times[i]);
    EXPECT_EQ(r.cloud.labels[k], cloud.labels[i]);
  }
  EXPECT_NO_THROW(r.cloud.check_consistent());
}

TEST(VoxelGridTest, CentroidModeFallsBackToNearestNormalWhenNormalsCancel) {
  PointCloud cloud;
  cloud.points = {Vector3f(0.1f, 0.1f, 0.1f), Vector3f(0.3f, 0.3f, 0.3f), Vector3f(0.35f, 0.35f, 0.35f)};
  cloud.normals = {Vector3f(0, 0, 1), Vector3f(1, 0, 0), Vector3f(-1, 0, -1)};
  // Sum of normals = 0 exactly. Centroid (0.25, ...): point 1 (0.3) is nearest.
  VoxelGridSettings s;
  s.leaf_size = 1.0;
  s.mode = VoxelMode::kCentroid;
  const VoxelGridResult r = voxel_grid(cloud, s);
  ASSERT_EQ(r.cloud.size(), 1u);
  EXPECT_EQ(r.cloud.normals[0], Vector3f(1, 0, 0));
  EXPECT_NEAR(r.cloud.points[0].x(), 0.25f, 1e-6f);
}

// ---- counts, statuses, bad input --------------------------------------------------------------

TEST(VoxelGridTest, NonFinitePointsAreDroppedAndCounted) {
  PointCloud cloud = random_cloud(31, 1000, -2.0, 2.0, true);
  PointCloud finite_only = cloud;
  // Replace 7 points by non-finite ones, in the original and by removal in the reference cloud.
  const std::vector<std::size_t> bad = {0, 5, 99, 500, 501, 998, 999};
  const Vector3f bad_points[] = {Vector3f(kQuietNaN, 0, 0), Vector3f(0, kInfinity, 0), Vector3f(0, 0, -kInfinity),
                                 Vector3f(kQuietNaN, kQuietNaN, kQuietNaN), Vector3f(1, 1, kQuietNaN),
                                 Vector3f(-kInfinity, 1, 1), Vector3f(kInfinity, kInfinity, kInfinity)};
  std::vector<std::size_t> keep;
  for (std::size_t i = 0, b = 0; i < cloud.size(); ++i) {
    if (b < bad.size() && bad[b] == i) {
      cloud.points[i] = bad_points[b++];
    } else {
      keep.push_back(i);
    }
  }
  finite_only = finite_only.select(keep);
  for (VoxelMode mode : {VoxelMode::kNearestToCentroid, VoxelMode::kCentroid}) {
    VoxelGridSettings s;
    s.leaf_size = 0.5;
    s.mode = mode;
    const VoxelGridResult r = voxel_grid(cloud, s);
    const VoxelGridResult ref = voxel_grid(finite_only, s);
    EXPECT_EQ(r.num_dropped_non_finite, 7u);
    EXPECT_EQ(ref.num_dropped_non_finite, 0u);
    ASSERT_EQ(r.cloud.size(), ref.cloud.size());
    for (std::size_t k = 0; k < r.cloud.size(); ++k) {
      EXPECT_EQ(r.cloud.points[k], ref.cloud.points[k]);
      if (mode == VoxelMode::kNearestToCentroid) {
        EXPECT_EQ(r.indices[k], keep[ref.indices[k]]);
      }
    }
  }
  expect_nearest_matches_oracle(cloud, 0.5, 1);

  PointCloud all_bad;
  all_bad.points = {Vector3f(kQuietNaN, 0, 0), Vector3f(0, kInfinity, 0)};
  const VoxelGridResult r = voxel_grid(all_bad);
  EXPECT_TRUE(r.cloud.empty());
  EXPECT_EQ(r.num_dropped_non_finite, 2u);
  EXPECT_EQ(r.num_voxels, 0u);
  EXPECT_EQ(r.status, Status::kInsufficientData);
}

// The bounds of the finite points (the grid's origin) against a plain loop, on clouds of every
// small length and with no-returns (NaN) and infinite coordinates at random places, one coordinate
// at a time: the vectorised pass must skip a point with any bad coordinate and count the others.
TEST(VoxelGridTest, FiniteBoundsMatchAPlainLoopWithNonFinitePointsAnywhere) {
  Rng rng(17);
  const float bad[] = {std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::infinity(),
                       -std::numeric_limits<float>::infinity()};
  for (std::size_t n = 0; n < 70; ++n) {
    for (int round = 0; round < 20; ++round) {
      std::vector<Vector3f> pts(n);
      for (Vector3f& p : pts) {
        p = Vector3f(static_cast<float>(rng.uniform(-50.0, 50.0)), static_cast<float>(rng.uniform(-5.0, 5.0)),
                     static_cast<float>(rng.uniform(-2.0, 30.0)));
        if (rng.uniform(0.0, 1.0) < 0.3) p[static_cast<int>(rng.uniform_index(3))] = bad[round % 3];
      }
      Vector3f lo = Vector3f::Constant(std::numeric_limits<float>::infinity());
      Vector3f hi = -lo;
      std::size_t finite = 0;
      for (const Vector3f& p : pts) {
        if (!(std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2]))) continue;
        lo = lo.cwiseMin(p);
        hi = hi.cwiseMax(p);
        ++finite;
      }
      const detail::FiniteBounds b = detail::finite_bounds(pts);
      ASSERT_EQ(b.num_finite, finite) << "n " << n << ", round " << round;
      if (finite == 0) continue;
      for (int k = 0; k < 3; ++k) {
        ASSERT_EQ(b.lo[k], lo[k]) << "n " << n << ", round " << round << ", axis " << k;
        ASSERT_EQ(b.hi[k], hi[k]) << "n " << n << ", round " << round << ", axis " << k;
      }
    }
  }
}

TEST(VoxelGridTest, EmptyInputGivesEmptyOutputAndStatus) {
  for (VoxelMode mode : {VoxelMode::kNearestToCentroid, VoxelMode::kCentroid}) {
    VoxelGridSettings s;
    s.mode = mode;
    const VoxelGridResult r = voxel_grid(PointCloud{}, s);
    EXPECT_TRUE(r.cloud.empty());
    EXPECT_TRUE(r.indices.empty());
    EXPECT_EQ(r.num_voxels, 0u);
    EXPECT_EQ(r.num_dropped_non_finite, 0u);
    EXPECT_EQ(r.status, Status::kInsufficientData);
  }
  PointCloud one;
  one.points = {Vector3f(1, 2, 3)};
  one.intensities = {7.0f};
  const VoxelGridResult r = voxel_grid(one);
  ASSERT_EQ(r.cloud.size(), 1u);
  EXPECT_EQ(r.cloud.points[0], Vector3f(1, 2, 3));
  EXPECT_EQ(r.cloud.intensities[0], 7.0f);
  EXPECT_EQ(r.status, Status::kOk);
}

TEST(VoxelGridTest, MinPointsPerVoxelDropsSparseVoxels) {
  const PointCloud cloud = random_cloud(41, 3000, -1.0, 1.0, false);
  for (std::size_t min_points : {2u, 3u, 6u}) expect_nearest_matches_oracle(cloud, 0.25, min_points);
  VoxelGridSettings s;
  s.leaf_size = 0.25;
  s.min_points_per_voxel = 6;
  s.mode = VoxelMode::kCentroid;
  const VoxelGridResult r = voxel_grid(cloud, s);
  const std::vector<OracleVoxel> all = oracle_voxels(cloud, 0.25, 1);
  const std::vector<OracleVoxel> dense = oracle_voxels(cloud, 0.25, 6);
  EXPECT_EQ(r.num_voxels, all.size());
  EXPECT_EQ(r.num_sparse_voxels, all.size() - dense.size());
  ASSERT_EQ(r.cloud.size(), dense.size());
  for (std::size_t k = 0; k < dense.size(); ++k) {
    EXPECT_LT((r.cloud.points[k].cast<double>() - dense[k].centroid).norm(), 1e-6);
  }
  // Every voxel too sparse: empty output, status says so.
  PointCloud two;
  two.points = {Vector3f(0, 0, 0), Vector3f(5, 5, 5)};
  s.min_points_per_voxel = 2;
  const VoxelGridResult empty = voxel_grid(two, s);
  EXPECT_TRUE(empty.cloud.empty());
  EXPECT_EQ(empty.num_voxels, 2u);
  EXPECT_EQ(empty.num_sparse_voxels, 2u);
  EXPECT_EQ(empty.status, Status::kInsufficientData);
}

TEST(VoxelGridTest, InvalidSettingsThrow) {
  const PointCloud cloud = random_cloud(51, 10, 0.0, 1.0, false);
  for (double leaf : {0.0, -0.1, static_cast<double>(kQuietNaN), static_cast<double>(kInfinity),
                      -static_cast<double>(kInfinity)}) {
    VoxelGridSettings s;
    s.leaf_size = leaf;
    EXPECT_THROW(voxel_grid(cloud, s), Error) << "leaf " << leaf;
    EXPECT_THROW(voxel_grid(PointCloud{}, s), Error) << "leaf " << leaf << " on empty input";
  }
  VoxelGridSettings s;
  s.min_points_per_voxel = 0;
  EXPECT_THROW(voxel_grid(cloud, s), Error);
  PointCloud inconsistent = cloud;
  inconsistent.intensities = {1.0f, 2.0f};
  EXPECT_THROW(voxel_grid(inconsistent), Error);
}

// ---- key range -----------------------------------------------------------------------------

TEST(VoxelGridTest, OneMillimetreLeafOverTenKilometres) {
  // A 10 km x 10 km x 100 m site at a 1 mm leaf: 1e7 x 1e7 x 1e5 voxels = 1e19 < 2^64 (three
  // 21-bit fields would overflow). Float spacing is ~1 mm at 10 km, so the sub-millimetre pairs sit
  // near the origin corner, where float resolves them; the far corners test the key range.
  const double leaf = 0.001;
  PointCloud cloud;
  for (int c = 0; c < 8; ++c) {  // 8 box corners: 8 voxels
    cloud.points.emplace_back((c & 1) ? 10000.0f : 0.0f, (c & 2) ? 10000.0f : 0.0f,
                              (c & 4) ? 100.0f : 0.0f);
  }
  // Neighbours two millimetres in from the far corner on each axis: 3 more voxels.
  cloud.points.emplace_back(9999.998f, 10000.0f, 100.0f);
  cloud.points.emplace_back(10000.0f, 9999.998f, 100.0f);
  cloud.points.emplace_back(10000.0f, 10000.0f, 99.998f);
  // Pairs 0.5 mm apart that share a millimetre cell (merge: 1 voxel each) ...
  const std::size_t merge_first = cloud.size();
  cloud.points.emplace_back(1.0002f, 2.0001f, 50.0003f);
  cloud.points.emplace_back(1.0007f, 2.0001f, 50.0003f);
  cloud.points.emplace_back(3.0001f, 4.0002f, 0.0001f);
  cloud.points.emplace_back(3.0001f, 4.0007f, 0.0001f);
  // ... and pairs 0.5 mm apart across a millimetre border (split: 2 voxels each).
  cloud.points.emplace_back(5.0008f, 6.0001f, 7.0001f);
  cloud.points.emplace_back(5.0013f, 6.0001f, 7.0001f);
  cloud.points.emplace_back(8.0001f, 9.0001f, 0.0007f);
  cloud.points.emplace_back(8.0001f, 9.0001f, 0.0012f);
  VoxelGridSettings s;
  s.leaf_size = leaf;
  const VoxelGridResult r = voxel_grid(cloud, s);
  EXPECT_EQ(r.num_voxels, 8u + 3u + 2u + 4u);
  EXPECT_EQ(r.cloud.size(), 17u);
  expect_nearest_matches_oracle(cloud, leaf, 1);
  // The merged pairs keep their first point (equal distances to the midpoint: lowest index).
  std::size_t merged_kept = 0;
  for (std::size_t i : r.indices) {
    if (i == merge_first || i == merge_first + 2) ++merged_kept;
    EXPECT_NE(i, merge_first + 1);
    EXPECT_NE(i, merge_first + 3);
  }
  EXPECT_EQ(merged_kept, 2u);
  // Ascending key order: the origin corner first, the far corner last.
  EXPECT_EQ(r.indices.front(), 0u);
  EXPECT_EQ(r.indices.back(), 7u);
}

TEST(VoxelGridTest, GridTooLargeForSixtyFourBitsThrowsClearError) {
  PointCloud cloud;
  cloud.points = {Vector3f(0, 0, 0), Vector3f(1e6f, 1e6f, 1e6f)};
  VoxelGridSettings s;
  s.leaf_size = 1e-9;
  try {
    voxel_grid(cloud, s);
    FAIL() << "expected plumb::Error";
  } catch (const Error& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("voxel_grid"), std::string::npos) << msg;
    EXPECT_NE(msg.find("leaf_size 1e-09 m"), std::string::npos) << msg;
    EXPECT_NE(msg.find("extent 1e+06 x 1e+06 x 1e+06 m"), std::string::npos) << msg;
  }
  // A 10 km cube at 1 mm needs 1e21 keys > 2^64: also refused.
  cloud.points = {Vector3f(0, 0, 0), Vector3f(1e4f, 1e4f, 1e4f)};
  s.leaf_size = 0.001;
  EXPECT_THROW(voxel_grid(cloud, s), Error);
  // One axis alone beyond 2^64 voxels.
  cloud.points = {Vector3f(0, 0, 0), Vector3f(1e6f, 0, 0)};
  s.leaf_size = 1e-15;
  EXPECT_THROW(voxel_grid(cloud, s), Error);
}

// ---- real data, against peer-produced voxel counts ----------------------------------------------
// Reference counts come from Open3D 0.16 (python3-open3d), whose
// VoxelGrid.create_from_point_cloud_within_bounds(cloud, leaf, min_bound, max_bound) uses our origin
// convention (voxel = floor((p - min_bound) / leaf) in double) when min_bound is the cloud's
// bounding-box min:
//   o3d.geometry.VoxelGrid.create_from_point_cloud_within_bounds(pcd, leaf, pcd.get_min_bound(),
//                                                                pcd.get_max_bound() + 1.0)
//   -> len(grid.get_voxels())
// For comparison (different origins, so not used as references): PCL 1.13 VoxelGrid<PointXYZ>
// (grid anchored at the world origin, in float) gives 13490 on room_scan1 and 15772 on hdl32 at
// 0.1 m (bench/filters_bench out_points; equal to ours on room_scan1 by coincidence); Open3D
// VoxelDownSample (anchored at min - leaf / 2) gives 13422 / 28051 on room_scan1 at 0.1 / 0.05 m
// and 15753 on hdl32.

struct RealCase {
  const char* file;
  double leaf;
  std::size_t open3d_voxels;
};

TEST(VoxelGridTest, VoxelCountsMatchOpen3dOnRealClouds) {
  const RealCase cases[] = {
      {"cloud3d/pcl_room_scans/room_scan1.pcd", 0.1, 13490},
      {"cloud3d/pcl_room_scans/room_scan1.pcd", 0.05, 27930},
      {"cloud3d/hdl32_pair/251370668.pcd", 0.1, 15780},
  };
  for (const RealCase& c : cases) {
    PLUMB_REQUIRE_DATA(path, c.file);
    const PointCloud cloud = io::read_pcd(path);
    for (VoxelMode mode : {VoxelMode::kNearestToCentroid, VoxelMode::kCentroid}) {
      VoxelGridSettings s;
      s.leaf_size = c.leaf;
      s.mode = mode;
      const VoxelGridResult r = voxel_grid(cloud, s);
      EXPECT_EQ(r.num_voxels, c.open3d_voxels) << c.file << " leaf " << c.leaf;
      EXPECT_EQ(r.cloud.size(), c.open3d_voxels) << c.file << " leaf " << c.leaf;
      EXPECT_EQ(r.num_dropped_non_finite, 0u);
      EXPECT_EQ(r.status, Status::kOk);
    }
  }
}

TEST(VoxelGridTest, NearestMatchesBruteForceOnRoomScan) {
  PLUMB_REQUIRE_DATA(path, "cloud3d/pcl_room_scans/room_scan1.pcd");
  const PointCloud cloud = io::read_pcd(path);
  ASSERT_EQ(cloud.size(), 112586u);  // SOURCES.md
  expect_nearest_matches_oracle(cloud, 0.1, 1);
  expect_nearest_matches_oracle(cloud, 0.1, 4);
}

}  // namespace
}  // namespace plumb
