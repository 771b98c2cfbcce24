// SPDX-License-Identifier: BSD-3-Clause
// The bounded voxel hash map of the LiDAR/IMU odometry, and the map association's rejection of
// collinear "planes".
#include "plumb/loam/local_map.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <tuple>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "plumb/core/error.hpp"
#include "plumb/core/rng.hpp"
#include "plumb/loam/odometry.hpp"

namespace plumb {
namespace {

TEST(VoxelHashMapTest, CapsPointsPerVoxelLikeABruteForceCount) {
  VoxelHashMapSettings s;
  s.voxel_size = 0.5;
  s.max_points_per_voxel = 3;
  VoxelHashMap map(s);
  Rng rng(7);
  std::vector<Vector3f> pts;
  for (int i = 0; i < 2000; ++i) {
    pts.emplace_back(static_cast<float>(rng.uniform(-2.0, 2.0)), static_cast<float>(rng.uniform(-2.0, 2.0)),
                     static_cast<float>(rng.uniform(-0.5, 0.5)));
  }
  pts.emplace_back(std::numeric_limits<float>::quiet_NaN(), 0.f, 0.f);
  map.insert(pts);
  // Oracle: the first 3 points of every voxel, counted independently.
  std::map<std::tuple<int, int, int>, int> count;
  std::size_t expected = 0;
  for (const Vector3f& p : pts) {
    if (!p.allFinite()) continue;
    const auto k = std::make_tuple(static_cast<int>(std::floor(p.x() / 0.5)), static_cast<int>(std::floor(p.y() / 0.5)),
                                   static_cast<int>(std::floor(p.z() / 0.5)));
    if (count[k]++ < 3) ++expected;
  }
  EXPECT_EQ(map.num_voxels(), count.size());
  EXPECT_EQ(map.num_points(), expected);
  EXPECT_EQ(map.points().size(), expected);
  // Inserting the same points again adds nothing: every voxel is full or keeps its first points.
  const std::vector<Vector3f> before = map.points();
  map.insert(pts);
  EXPECT_EQ(map.points(), before);
}

TEST(VoxelHashMapTest, PruneDropsFarVoxelsAndKeepsTheNearestWithinTheCap) {
  VoxelHashMapSettings s;
  s.voxel_size = 1.0;
  s.max_points_per_voxel = 1;
  s.max_distance = 10.0;
  s.max_voxels = 5;
  VoxelHashMap map(s);
  std::vector<Vector3f> line;
  for (int i = 0; i < 30; ++i) line.emplace_back(static_cast<float>(i) + 0.5f, 0.5f, 0.5f);
  map.insert(line);
  EXPECT_EQ(map.num_voxels(), 30u);
  map.prune(Vector3d(0.5, 0.5, 0.5));
  ASSERT_EQ(map.num_voxels(), 5u);  // 11 voxels within 10 m, the 5 nearest kept
  const std::vector<Vector3f> kept = map.points();
  for (std::size_t i = 0; i < kept.size(); ++i) EXPECT_FLOAT_EQ(kept[i].x(), static_cast<float>(i) + 0.5f);
  // Far away: everything goes.
  map.prune(Vector3d(100.0, 0.0, 0.0));
  EXPECT_TRUE(map.empty());
  EXPECT_EQ(map.num_voxels(), 0u);
}

// max_age: a window of frames moving along x, each inserted then pruned; the map equals an
// independent model of "voxels that got a point in the last max_age prunes, with their points"
// after every frame. Full voxels age too and are refilled afresh once dropped.
TEST(VoxelHashMapTest, MaxAgeKeepsWhatRecentFramesFilled) {
  VoxelHashMapSettings s;
  s.voxel_size = 1.0;
  s.max_points_per_voxel = 2;
  s.max_distance = 1e6;
  s.max_age = 3;
  VoxelHashMap map(s);
  struct Model {
    std::vector<Vector3f> points;
    int last = 0;
  };
  std::map<std::tuple<int, int, int>, Model> model;
  Rng rng(11);
  std::size_t dropped_full = 0;
  for (int frame = 0; frame < 40; ++frame) {
    // Frames overlap: each covers x in [0.5 f, 0.5 f + 4) and revisits the origin every 10 frames.
    const double x0 = frame % 10 == 9 ? 0.0 : 0.5 * frame;
    std::vector<Vector3f> pts;
    for (int i = 0; i < 60; ++i)
      pts.emplace_back(static_cast<float>(rng.uniform(x0, x0 + 4.0)), static_cast<float>(rng.uniform(0.0, 2.0)), 0.5f);
    map.insert(pts);
    for (const Vector3f& p : pts) {
      const auto k = std::make_tuple(static_cast<int>(std::floor(p.x())), static_cast<int>(std::floor(p.y())), 0);
      Model& m = model[k];
      if (m.points.size() < 2) {
        m.points.push_back(p);
        m.last = frame;
      }
    }
    map.prune(Vector3d::Zero());
    for (auto it = model.begin(); it != model.end();) {
      if (frame - it->second.last >= 3) {
        dropped_full += it->second.points.size() == 2 ? 1 : 0;
        it = model.erase(it);
      } else {
        ++it;
      }
    }
    std::size_t n = 0;
    for (const auto& kv : model) n += kv.second.points.size();
    ASSERT_EQ(map.num_voxels(), model.size()) << "frame " << frame;
    ASSERT_EQ(map.num_points(), n) << "frame " << frame;
    std::vector<Vector3f> got = map.points(), want;
    for (const auto& kv : model) want.insert(want.end(), kv.second.points.begin(), kv.second.points.end());
    auto less = [](const Vector3f& a, const Vector3f& b) {
      return std::make_tuple(a.x(), a.y(), a.z()) < std::make_tuple(b.x(), b.y(), b.z());
    };
    std::sort(got.begin(), got.end(), less);
    std::sort(want.begin(), want.end(), less);
    ASSERT_EQ(got, want) << "frame " << frame;
  }
  EXPECT_GT(dropped_full, 10u);  // full voxels did age out (and the revisits refilled some)
  // No age limit: nothing is ever dropped near the centre.
  s.max_age = 0;
  VoxelHashMap keep(s);
  keep.insert({Vector3f(0.5f, 0.5f, 0.5f)});
  for (int i = 0; i < 100; ++i) keep.prune(Vector3d::Zero());
  EXPECT_EQ(keep.num_points(), 1u);
}

// Everything at once, against a plain list of voxels searched linearly: points in first-fill order
// of their voxels and insertion order within one, the per-voxel cap, the distance, age and count
// limits, over thousands of voxels (so the index grows, shrinks and is rebuilt many times),
// negative coordinates and repeated clear().
TEST(VoxelHashMapTest, MatchesALinearListOfVoxelsInOrder) {
  struct RefVoxel {
    std::tuple<int, int, int> key;
    std::vector<Vector3f> points;
    std::uint64_t touched = 0;
  };
  VoxelHashMapSettings s;
  s.voxel_size = 0.7;
  s.max_points_per_voxel = 3;
  s.max_distance = 9.0;
  s.max_voxels = 1500;
  s.max_age = 4;
  VoxelHashMap map(s);
  std::vector<RefVoxel> ref;
  std::uint64_t generation = 0;
  Rng rng(23);
  for (int frame = 0; frame < 60; ++frame) {
    if (frame == 40) {  // start afresh
      map.clear();
      ref.clear();
      generation = 0;
    }
    const Vector3d c(0.3 * frame - 6.0, -0.2 * frame, 0.0);
    std::vector<Vector3f> pts;
    for (int i = 0; i < 900; ++i) {
      pts.emplace_back(static_cast<float>(c.x() + rng.uniform(-8.0, 8.0)), static_cast<float>(c.y() + rng.uniform(-8.0, 8.0)),
                       static_cast<float>(rng.uniform(-2.0, 2.0)));
    }
    map.insert(pts);
    for (const Vector3f& p : pts) {
      const auto k = std::make_tuple(static_cast<int>(std::floor(static_cast<double>(p.x()) / 0.7)),
                                     static_cast<int>(std::floor(static_cast<double>(p.y()) / 0.7)),
                                     static_cast<int>(std::floor(static_cast<double>(p.z()) / 0.7)));
      auto it = std::find_if(ref.begin(), ref.end(), [&](const RefVoxel& v) { return v.key == k; });
      if (it == ref.end()) it = ref.insert(ref.end(), RefVoxel{k, {}, generation});
      if (it->points.size() < 3) {
        it->points.push_back(p);
        it->touched = generation;
      }
    }
    map.prune(c);
    std::vector<std::pair<double, std::size_t>> keep;
    for (std::size_t i = 0; i < ref.size(); ++i) {
      const Vector3d centre = (Vector3d(std::get<0>(ref[i].key), std::get<1>(ref[i].key), std::get<2>(ref[i].key)) +
                               Vector3d::Constant(0.5)) * 0.7;
      const double d_sq = (centre - c).squaredNorm();
      if (d_sq <= 81.0 && generation - ref[i].touched < 4) keep.emplace_back(d_sq, i);
    }
    ++generation;
    if (keep.size() > s.max_voxels) {
      std::stable_sort(keep.begin(), keep.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
      keep.resize(s.max_voxels);
      std::sort(keep.begin(), keep.end(), [](const auto& a, const auto& b) { return a.second < b.second; });
    }
    std::vector<RefVoxel> kept;
    for (const auto& e : keep) kept.push_back(ref[e.second]);
    ref = std::move(kept);

    std::vector<Vector3f> want;
    for (const RefVoxel& v : ref) want.insert(want.end(), v.points.begin(), v.points.end());
    ASSERT_EQ(map.num_voxels(), ref.size()) << "frame " << frame;
    ASSERT_EQ(map.num_points(), want.size()) << "frame " << frame;
    ASSERT_EQ(map.points(), want) << "frame " << frame;
  }
  EXPECT_GT(map.num_voxels(), 1000u);  // the count limit was in play at the end
}

TEST(VoxelHashMapTest, BadSettingsThrow) {
  VoxelHashMapSettings s;
  s.voxel_size = 0.0;
  EXPECT_THROW(VoxelHashMap{s}, Error);
  s = {};
  s.max_points_per_voxel = 0;
  EXPECT_THROW(VoxelHashMap{s}, Error);
  s = {};
  s.max_distance = -1.0;
  EXPECT_THROW(VoxelHashMap{s}, Error);
}

TEST(LoamAssociateMapTest, PlanesNeedTwoDirectionsOfSpread) {
  // Map plane points on one straight line with noise across it (a single scan ring of the road):
  // no normal is defined, so no plane residual may come out. On a grid they give z-normals.
  PointCloud line, grid, none;
  for (int i = 0; i < 200; ++i) {  // a thin helix: 1 cm around the x axis, 5 points per turn
    const double a = 2.0 * 3.14159265358979323846 * i / 5.0;
    line.points.emplace_back(0.02f * static_cast<float>(i), static_cast<float>(0.01 * std::cos(a)),
                             static_cast<float>(0.01 * std::sin(a)));
  }
  for (int i = 0; i < 20; ++i) {
    for (int k = 0; k < 20; ++k) grid.points.emplace_back(0.2f * static_cast<float>(i), 0.2f * static_cast<float>(k), 0.f);
  }
  LoamFeatures cur;
  for (int i = 0; i < 30; ++i) cur.planes.points.emplace_back(0.1f * static_cast<float>(i) + 0.05f, 0.01f, 0.01f);
  LoamSettings s;
  std::vector<LoamCorrespondence> out;
  loam_associate_map(LoamMap(none, line), cur, Eigen::Isometry3d::Identity(), s, out);
  EXPECT_TRUE(out.empty());
  s.map_plane_ratio = 1.0;  // the check off: rounding decides the "normal"
  loam_associate_map(LoamMap(none, line), cur, Eigen::Isometry3d::Identity(), s, out);
  EXPECT_FALSE(out.empty());
  out.clear();
  s = {};
  loam_associate_map(LoamMap(none, grid), cur, Eigen::Isometry3d::Identity(), s, out);
  ASSERT_EQ(out.size(), cur.planes.size());
  for (const LoamCorrespondence& c : out) {
    EXPECT_EQ(c.kind, LoamCorrespondence::Kind::kPlane);
    EXPECT_NEAR(std::abs(c.dir.z()), 1.0, 1e-9);
  }
}

// A room of noisy walls and floor (plane map) with vertical edges at its corners (edge map).
LoamMap noisy_room(Rng& rng) {
  PointCloud edges, planes;
  auto noisy = [&rng](double x, double y, double z) {
    return Vector3f(static_cast<float>(x + 0.01 * rng.normal()), static_cast<float>(y + 0.01 * rng.normal()),
                    static_cast<float>(z + 0.01 * rng.normal()));
  };
  for (int i = 0; i < 4000; ++i) {
    const double u = rng.uniform(-6.0, 6.0), v = rng.uniform(0.0, 3.0);
    switch (i % 5) {
      case 0: planes.points.push_back(noisy(u, -4.0, v)); break;
      case 1: planes.points.push_back(noisy(u, 4.0, v)); break;
      case 2: planes.points.push_back(noisy(-6.0, u * 4.0 / 6.0, v)); break;
      case 3: planes.points.push_back(noisy(6.0, u * 4.0 / 6.0, v)); break;
      default: planes.points.push_back(noisy(u, rng.uniform(-4.0, 4.0), 0.0)); break;
    }
  }
  for (int i = 0; i < 400; ++i) {
    const double x = i % 2 == 0 ? -6.0 : 6.0, y = (i / 2) % 2 == 0 ? -4.0 : 4.0;
    edges.points.push_back(noisy(x, y, rng.uniform(0.0, 3.0)));
  }
  // A few points twice: equal distances from any query, which must not change the result.
  for (int i = 0; i < 50; ++i) planes.points.push_back(planes.points[static_cast<std::size_t>(7 * i)]);
  return LoamMap(edges, planes);
}

bool same_factors(const std::vector<LoamCorrespondence>& a, const std::vector<LoamCorrespondence>& b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i) {
    if (a[i].kind != b[i].kind || a[i].p != b[i].p || a[i].a != b[i].a || a[i].dir != b[i].dir ||
        a[i].weight != b[i].weight) {
      return false;
    }
  }
  return true;
}

// The cached association against a brute-force reference, the association without a cache: over
// the rounds of a solve (the pose moving less each round), jumps, and a change of queries, every
// round's correspondences are the same, bit for bit; small moves are answered from the cache.
TEST(LoamAssociateMapTest, TheCacheGivesTheUncachedCorrespondences) {
  Rng rng(11);
  const LoamMap map = noisy_room(rng);
  LoamFeatures cur;
  for (int i = 0; i < 600; ++i) {
    const Vector3f p(static_cast<float>(rng.uniform(-7.0, 7.0)), static_cast<float>(rng.uniform(-5.0, 5.0)),
                     static_cast<float>(rng.uniform(-0.5, 3.5)));
    (i % 3 == 0 ? cur.edges : i % 3 == 1 ? cur.planes : cur.plane_candidates).points.push_back(p);
  }
  cur.edge_candidates.points.push_back(Vector3f(6.0f, 4.0f, 1.0f));
  for (int threads : {1, 3}) {
    LoamSettings s;
    s.threads = threads;
    LoamMapCache cache;
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.translation() = Vector3d(0.3, -0.2, 0.05);
    for (int round = 0; round < 12; ++round) {
      // Steps that shrink like a converging solve's, with a jump of 0.5 m at round 6.
      const double step = round == 6 ? 0.5 : 0.05 / (1 << (round % 6));
      T.translation() += step * Vector3d(rng.normal(), rng.normal(), 0.2 * rng.normal());
      T.rotate(Eigen::AngleAxisd(0.1 * step * rng.normal(), Vector3d::UnitZ()));
      std::vector<LoamCorrespondence> plain, cached;
      loam_associate_map(map, cur, T, s, plain);
      loam_associate_map(map, cur, T, s, cached, &cache);
      ASSERT_FALSE(plain.empty());
      ASSERT_TRUE(same_factors(plain, cached)) << "round " << round << ", threads " << threads;
    }
    EXPECT_GT(cache.hits(), cache.searches() / 4) << threads;
    // Other queries (a new cloud) start afresh.
    LoamFeatures other = cur;
    other.planes.points.resize(other.planes.size() / 2);
    std::vector<LoamCorrespondence> plain, cached;
    loam_associate_map(map, other, T, s, plain);
    loam_associate_map(map, other, T, s, cached, &cache);
    EXPECT_TRUE(same_factors(plain, cached));
  }
  // A lattice map and queries moved by exact binary fractions: many map points lie at exactly the
  // same distance from a query, in an order only the tree's search knows. Still the same pairs.
  {
    PointCloud lattice_planes, lattice_edges;
    for (int i = -12; i <= 12; ++i) {
      for (int j = -12; j <= 12; ++j) {
        lattice_planes.points.emplace_back(0.25f * static_cast<float>(i), 0.25f * static_cast<float>(j), 0.0f);
        lattice_planes.points.emplace_back(0.25f * static_cast<float>(i), 3.0f, 0.25f * static_cast<float>(j + 12));
      }
      lattice_edges.points.emplace_back(3.0f, 3.0f, 0.25f * static_cast<float>(i + 12));
    }
    const LoamMap lattice(lattice_edges, lattice_planes);
    LoamFeatures q;
    for (int i = 0; i < 200; ++i) {
      const Vector3f p(0.125f * static_cast<float>(i % 40 - 20), 0.125f * static_cast<float>(i % 23 - 11) + 0.5f,
                       0.125f * static_cast<float>(i % 3));
      (i % 4 == 0 ? q.edges : q.planes).points.push_back(p);
    }
    LoamSettings s;
    LoamMapCache cache;
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    for (int round = 0; round < 8; ++round) {
      T.translation() += Vector3d(1.0 / 64, round % 2 == 0 ? 1.0 / 128 : 0.0, 0.0);
      std::vector<LoamCorrespondence> plain, cached;
      loam_associate_map(lattice, q, T, s, plain);
      loam_associate_map(lattice, q, T, s, cached, &cache);
      ASSERT_FALSE(plain.empty());
      ASSERT_TRUE(same_factors(plain, cached)) << "lattice, round " << round;
    }
    EXPECT_GT(cache.hits(), 0u);
  }
  // map_neighbors beyond what the cache holds: searched every time, the same result.
  LoamSettings wide;
  wide.map_neighbors = 20;
  LoamMapCache cache;
  std::vector<LoamCorrespondence> plain, cached;
  loam_associate_map(map, cur, Eigen::Isometry3d::Identity(), wide, plain);
  loam_associate_map(map, cur, Eigen::Isometry3d::Identity(), wide, cached, &cache);
  EXPECT_TRUE(same_factors(plain, cached));
  EXPECT_EQ(cache.hits() + cache.searches(), 0u);
}

}  // namespace
}  // namespace plumb
