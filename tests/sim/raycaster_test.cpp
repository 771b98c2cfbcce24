// SPDX-License-Identifier: BSD-3-Clause
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <thread>
#include <vector>

#include "plumb/bim/ifc.hpp"
#include "plumb/bim/mesh.hpp"
#include "plumb/core/error.hpp"
#include "plumb/core/rng.hpp"
#include "plumb/sim/raycaster.hpp"
#include "test_data.hpp"

using plumb::Rng;
using plumb::Vector3d;
using plumb::sim::RayCaster;
using plumb::sim::RayCasterSettings;
using plumb::sim::RayHit;
using Tri = std::array<std::uint32_t, 3>;

namespace {

constexpr double kInfinity = std::numeric_limits<double>::infinity();

/// Closed axis-aligned box: 8 corners, 12 triangles; element = face index (0..5: -x +x -y +y -z +z).
void box_mesh(const Vector3d& lo, const Vector3d& hi, std::vector<Vector3d>& v, std::vector<Tri>& t,
              std::vector<std::int32_t>& e) {
  const auto base = static_cast<std::uint32_t>(v.size());
  for (int i = 0; i < 8; ++i) {
    v.emplace_back((i & 1) ? hi.x() : lo.x(), (i & 2) ? hi.y() : lo.y(), (i & 4) ? hi.z() : lo.z());
  }
  const std::uint32_t quads[6][4] = {{0, 4, 6, 2}, {1, 3, 7, 5}, {0, 1, 5, 4},
                                     {2, 6, 7, 3}, {0, 2, 3, 1}, {4, 5, 7, 6}};
  for (int f = 0; f < 6; ++f) {
    const auto& q = quads[f];
    t.push_back({base + q[0], base + q[1], base + q[2]});
    t.push_back({base + q[0], base + q[2], base + q[3]});
    e.push_back(f);
    e.push_back(f);
  }
}

/// Exit distance of a ray from inside an axis-aligned box, and the face index it leaves through.
double box_exit(const Vector3d& lo, const Vector3d& hi, const Vector3d& o, const Vector3d& d, int* face) {
  double best = kInfinity;
  for (int k = 0; k < 3; ++k) {
    if (d[k] == 0.0) continue;
    const double t = ((d[k] > 0.0 ? hi[k] : lo[k]) - o[k]) / d[k];
    if (t < best) {
      best = t;
      *face = 2 * k + (d[k] > 0.0 ? 1 : 0);
    }
  }
  return best;
}

Vector3d random_unit(Rng& rng) {
  for (;;) {
    const Vector3d v(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1));
    const double n = v.norm();
    if (n > 0.1 && n <= 1.0) return v / n;
  }
}

/// Independent oracle: Moeller-Trumbore over every triangle (double).
double brute_force_range(const std::vector<Vector3d>& v, const std::vector<Tri>& tris, const Vector3d& o,
                         const Vector3d& d) {
  double best = kInfinity;
  for (const Tri& t : tris) {
    const Vector3d e1 = v[t[1]] - v[t[0]], e2 = v[t[2]] - v[t[0]];
    const Vector3d p = d.cross(e2);
    const double det = e1.dot(p);
    if (std::abs(det) < 1e-300) continue;
    const double inv = 1.0 / det;
    const Vector3d s = o - v[t[0]];
    const double u = s.dot(p) * inv;
    if (u < 0.0 || u > 1.0) continue;
    const Vector3d q = s.cross(e1);
    const double w = d.dot(q) * inv;
    if (w < 0.0 || u + w > 1.0) continue;
    const double r = e2.dot(q) * inv;
    if (r > 0.0 && r < best) best = r;
  }
  return best;
}

}  // namespace

TEST(RayCasterTest, ExactRangesInAKnownBox) {
  const Vector3d lo(-2.0, -1.0, -0.5), hi(3.0, 4.0, 2.5);
  std::vector<Vector3d> v;
  std::vector<Tri> t;
  std::vector<std::int32_t> e;
  box_mesh(lo, hi, v, t, e);
  const RayCaster caster(v, t, e);
  EXPECT_EQ(caster.num_triangles(), 12u);
  Rng rng(7);
  for (int i = 0; i < 5000; ++i) {
    const Vector3d o(rng.uniform(lo.x() + 0.01, hi.x() - 0.01), rng.uniform(lo.y() + 0.01, hi.y() - 0.01),
                     rng.uniform(lo.z() + 0.01, hi.z() - 0.01));
    const Vector3d d = random_unit(rng);
    int face = -1;
    const double expected = box_exit(lo, hi, o, d, &face);
    const RayHit h = caster.cast(o, d);
    ASSERT_TRUE(h.hit()) << i;
    EXPECT_NEAR(h.range, expected, 1e-9 * (1.0 + expected));
    EXPECT_EQ(h.element, face);
    EXPECT_EQ(e[h.triangle], face);
    // The normal faces the origin: minus the exit face's outward axis.
    Vector3d n_expected = Vector3d::Zero();
    n_expected[face / 2] = (face % 2) ? -1.0 : 1.0;
    EXPECT_LT((h.normal - n_expected).norm(), 1e-12);
    // t_max just short of the wall: no hit; just beyond: the same hit.
    EXPECT_FALSE(caster.cast(o, d, expected * (1.0 - 1e-9)).hit());
    EXPECT_NEAR(caster.cast(o, d, expected * (1.0 + 1e-9)).range, expected, 1e-9 * (1.0 + expected));
  }
  // From outside, looking at the box: entry distance.
  const RayHit h = caster.cast(Vector3d(10.0, 1.0, 1.0), Vector3d(-1.0, 0.0, 0.0));
  ASSERT_TRUE(h.hit());
  EXPECT_NEAR(h.range, 7.0, 1e-12);
  EXPECT_EQ(h.element, 1);
  EXPECT_NEAR(h.normal.x(), 1.0, 1e-12);
  EXPECT_FALSE(caster.cast(Vector3d(10.0, 1.0, 1.0), Vector3d(1.0, 0.0, 0.0)).hit());
}

TEST(RayCasterTest, RaysThroughSharedEdgesAndVerticesNeverMissAClosedBox) {
  // A box whose faces are split into many triangles (a 4x4 grid of quads per face, each quad two
  // triangles), so there are many shared edges and vertices; rays aimed exactly at grid points and
  // along edges must hit.
  const int n = 4;
  std::vector<Vector3d> v;
  std::vector<Tri> t;
  auto grid_face = [&](const Vector3d& corner, const Vector3d& du, const Vector3d& dv) {
    const auto base = static_cast<std::uint32_t>(v.size());
    for (int j = 0; j <= n; ++j) {
      for (int i = 0; i <= n; ++i) v.push_back(corner + du * (double(i) / n) + dv * (double(j) / n));
    }
    for (int j = 0; j < n; ++j) {
      for (int i = 0; i < n; ++i) {
        const std::uint32_t a = base + static_cast<std::uint32_t>(j * (n + 1) + i);
        const std::uint32_t b = a + 1, c = a + static_cast<std::uint32_t>(n + 1), d = c + 1;
        t.push_back({a, b, d});
        t.push_back({a, d, c});
      }
    }
  };
  // Faces of [-1,1]^3 built separately (vertices on the box edges are duplicated with equal values).
  grid_face(Vector3d(-1, -1, -1), Vector3d(0, 2, 0), Vector3d(2, 0, 0));
  grid_face(Vector3d(-1, -1, 1), Vector3d(2, 0, 0), Vector3d(0, 2, 0));
  grid_face(Vector3d(-1, -1, -1), Vector3d(2, 0, 0), Vector3d(0, 0, 2));
  grid_face(Vector3d(-1, 1, -1), Vector3d(0, 0, 2), Vector3d(2, 0, 0));
  grid_face(Vector3d(-1, -1, -1), Vector3d(0, 0, 2), Vector3d(0, 2, 0));
  grid_face(Vector3d(1, -1, -1), Vector3d(0, 2, 0), Vector3d(0, 0, 2));
  for (int leaf : {1, 4}) {
    RayCasterSettings s;
    s.leaf_size = leaf;
    const RayCaster caster(v, t, {}, s);
    std::size_t misses = 0, rays = 0;
    // From the centre and from off-centre points, at every vertex and every edge midpoint.
    for (const Vector3d& o : {Vector3d(0, 0, 0), Vector3d(0.25, -0.5, 0.125), Vector3d(-0.75, 0.5, 0.5)}) {
      std::vector<Vector3d> targets = v;
      for (const Tri& tri : t) {
        for (int k = 0; k < 3; ++k) targets.push_back(0.5 * (v[tri[static_cast<std::size_t>(k)]] + v[tri[static_cast<std::size_t>((k + 1) % 3)]]));
      }
      for (const Vector3d& p : targets) {
        const Vector3d d = (p - o).normalized();
        const RayHit h = caster.cast(o, d);
        ++rays;
        if (!h.hit()) {
          ++misses;
          continue;
        }
        EXPECT_NEAR(h.range, (p - o).norm(), 1e-9);
      }
    }
    EXPECT_EQ(misses, 0u) << "of " << rays << " rays, leaf_size " << leaf;
    // Axis-aligned rays from the centre meet the centre vertex of each face exactly.
    for (int k = 0; k < 3; ++k) {
      for (double sgn : {-1.0, 1.0}) {
        Vector3d d = Vector3d::Zero();
        d[k] = sgn;
        const RayHit h = caster.cast(Vector3d::Zero(), d);
        ASSERT_TRUE(h.hit());
        EXPECT_EQ(h.range, 1.0);
      }
    }
  }
}

TEST(RayCasterTest, MatchesBruteForceOnFzkHaus) {
  PLUMB_REQUIRE_DATA(path, "ifc/buildings/AC20-FZK-Haus.ifc");
  const plumb::bim::BimMesh mesh = plumb::bim::build_mesh(plumb::bim::read_ifc(path));
  ASSERT_GT(mesh.num_triangles(), 1000u);
  Vector3d lo, hi;
  mesh.bounds(lo, hi);
  Rng rng(11);
  for (const RayCasterSettings s : {RayCasterSettings{}, RayCasterSettings{1, 2}, RayCasterSettings{8, 32}}) {
    const RayCaster caster(mesh, s);
    int hits = 0;
    for (int i = 0; i < 300; ++i) {
      const Vector3d o(rng.uniform(lo.x(), hi.x()), rng.uniform(lo.y(), hi.y()), rng.uniform(lo.z(), hi.z()));
      const Vector3d d = random_unit(rng);
      const double expected = brute_force_range(mesh.vertices, mesh.triangles, o, d);
      const RayHit h = caster.cast(o, d);
      ASSERT_EQ(h.hit(), expected < kInfinity) << "ray " << i << " leaf " << s.leaf_size;
      if (!h.hit()) continue;
      ++hits;
      EXPECT_NEAR(h.range, expected, 1e-7) << "ray " << i;
      // The reported triangle really lies at that range along the ray.
      EXPECT_NEAR(brute_force_range(mesh.vertices, {mesh.triangles[h.triangle]}, o, d), h.range, 1e-7);
      EXPECT_EQ(h.element, mesh.triangle_element[h.triangle]);
      EXPECT_NEAR(h.normal.norm(), 1.0, 1e-12);
      EXPECT_LE(h.normal.dot(d), 0.0);
      EXPECT_EQ(caster.occluded(o, d, h.range * 1.0001), true);
      EXPECT_EQ(caster.occluded(o, d, h.range * 0.9999), false);
    }
    EXPECT_GT(hits, 100);
  }
}

TEST(RayCasterTest, CoincidentCentroidsAndLargeLeavesMatchBruteForce) {
  // 600 triangles whose boxes share one centre (no spatial split separates them: median splits, then leaves
  // chunked into 4-wide nodes) inside a closed box, for the smallest and the largest leaf size.
  std::vector<Vector3d> v;
  std::vector<Tri> t;
  std::vector<std::int32_t> e;
  box_mesh(Vector3d(-3, -3, -3), Vector3d(3, 3, 3), v, t, e);
  Rng rng(5);
  for (int i = 0; i < 600; ++i) {
    const Vector3d a = random_unit(rng) * rng.uniform(0.2, 1.5);
    const Vector3d c = a.cwiseProduct(Vector3d(rng.uniform(-0.9, 0.9), rng.uniform(-0.9, 0.9), rng.uniform(-0.9, 0.9)));
    const auto base = static_cast<std::uint32_t>(v.size());
    v.push_back(a);
    v.push_back(-a);
    v.push_back(c);  // bounding box symmetric about the origin: its centre is the origin
    t.push_back({base, base + 1, base + 2});
    e.push_back(100 + i);
  }
  for (int leaf : {1, 255}) {
    RayCasterSettings s;
    s.leaf_size = leaf;
    const RayCaster caster(v, t, e, s);
    for (int i = 0; i < 400; ++i) {
      const Vector3d o(rng.uniform(-2.5, 2.5), rng.uniform(-2.5, 2.5), rng.uniform(-2.5, 2.5));
      const Vector3d d = random_unit(rng);
      const double expected = brute_force_range(v, t, o, d);
      const RayHit h = caster.cast(o, d);
      ASSERT_TRUE(h.hit()) << i;  // inside a closed box
      EXPECT_NEAR(h.range, expected, 1e-9) << "ray " << i << " leaf " << leaf;
      EXPECT_NEAR(brute_force_range(v, {t[h.triangle]}, o, d), h.range, 1e-9);
      EXPECT_TRUE(caster.occluded(o, d, h.range * (1.0 + 1e-9)));
      EXPECT_FALSE(caster.occluded(o, d, h.range * (1.0 - 1e-9)));
    }
  }
}

TEST(RayCasterTest, ConcurrentCastsAgree) {
  std::vector<Vector3d> v;
  std::vector<Tri> t;
  std::vector<std::int32_t> e;
  Rng rng(3);
  for (int b = 0; b < 200; ++b) {
    const Vector3d c(rng.uniform(-10, 10), rng.uniform(-10, 10), rng.uniform(-10, 10));
    box_mesh(c, c + Vector3d(rng.uniform(0.1, 2), rng.uniform(0.1, 2), rng.uniform(0.1, 2)), v, t, e);
  }
  const RayCaster caster(v, t, e);
  std::vector<Vector3d> dirs(4000);
  for (auto& d : dirs) d = random_unit(rng);
  std::vector<double> serial(dirs.size()), a(dirs.size()), b(dirs.size());
  for (std::size_t i = 0; i < dirs.size(); ++i) serial[i] = caster.cast(Vector3d::Zero(), dirs[i]).range;
  std::thread ta([&] { for (std::size_t i = 0; i < dirs.size(); ++i) a[i] = caster.cast(Vector3d::Zero(), dirs[i]).range; });
  std::thread tb([&] { for (std::size_t i = 0; i < dirs.size(); ++i) b[i] = caster.cast(Vector3d::Zero(), dirs[i]).range; });
  ta.join();
  tb.join();
  EXPECT_EQ(a, serial);
  EXPECT_EQ(b, serial);
  // And agree with the oracle.
  for (std::size_t i = 0; i < 200; ++i) {
    const double expected = brute_force_range(v, t, Vector3d::Zero(), dirs[i]);
    if (expected == kInfinity) {
      EXPECT_EQ(serial[i], kInfinity);
    } else {
      EXPECT_NEAR(serial[i], expected, 1e-9);
    }
  }
}

TEST(RayCasterTest, BadInput) {
  std::vector<Vector3d> v;
  std::vector<Tri> t;
  std::vector<std::int32_t> e;
  box_mesh(Vector3d(-1, -1, -1), Vector3d(1, 1, 1), v, t, e);
  const RayCaster caster(v, t, e);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(caster.cast(Vector3d(nan, 0, 0), Vector3d(1, 0, 0)).hit());
  EXPECT_FALSE(caster.cast(Vector3d::Zero(), Vector3d(nan, 0, 0)).hit());
  EXPECT_FALSE(caster.cast(Vector3d::Zero(), Vector3d(kInfinity, 0, 0)).hit());
  EXPECT_FALSE(caster.cast(Vector3d::Zero(), Vector3d::Zero()).hit());
  EXPECT_FALSE(caster.cast(Vector3d::Zero(), Vector3d(1, 0, 0), nan).hit());
  EXPECT_FALSE(caster.cast(Vector3d::Zero(), Vector3d(1, 0, 0), -1.0).hit());
  EXPECT_TRUE(caster.cast(Vector3d::Zero(), Vector3d(1, 0, 0)).hit());

  const RayCaster empty({}, {}, {});
  EXPECT_FALSE(empty.cast(Vector3d::Zero(), Vector3d(1, 0, 0)).hit());
  EXPECT_FALSE(empty.occluded(Vector3d::Zero(), Vector3d(1, 0, 0), kInfinity));

  auto bad_index = t;
  bad_index[3][1] = 8;
  EXPECT_THROW(RayCaster(v, bad_index, e), plumb::Error);
  auto bad_vertex = v;
  bad_vertex[2].y() = nan;
  EXPECT_THROW(RayCaster(bad_vertex, t, e), plumb::Error);
  EXPECT_THROW(RayCaster(v, t, std::vector<std::int32_t>(5, 0)), plumb::Error);
  EXPECT_THROW(RayCaster(v, t, e, RayCasterSettings{0, 16}), plumb::Error);
  EXPECT_THROW(RayCaster(v, t, e, RayCasterSettings{4, 1}), plumb::Error);
  // A degenerate (zero-area) triangle is never hit but does no harm.
  std::vector<Vector3d> dv = {Vector3d(1, -1, 0), Vector3d(1, 1, 0), Vector3d(1, 0, 0)};
  const RayCaster degenerate(dv, {Tri{0, 1, 2}}, {});
  EXPECT_FALSE(degenerate.cast(Vector3d::Zero(), Vector3d(1, 0, 0)).hit());
}
