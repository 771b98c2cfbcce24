// SPDX-License-Identifier: BSD-3-Clause
// classify_ground() on frames of an analytic 16-ring LiDAR (2 deg apart, 0.2 deg azimuth, 0.9 m
// above a flat road) ray-cast here at a wall and a raised terrace, with returns dropped as a real
// sensor loses them: which surface each return came from is known exactly.
#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include <gtest/gtest.h>

#include "plumb/core/error.hpp"
#include "plumb/core/lie.hpp"
#include "plumb/loam/ground.hpp"
#include "plumb/loam/range_image.hpp"

namespace plumb {
namespace {

constexpr double kDeg = kPi / 180.0;
constexpr double kHeight = 0.9;  // sensor above the road [m]

enum Surface : int { kNone = 0, kRoad, kWall, kTerrace };

struct Box {
  Vector3d lo, hi;
};
// Level frame at the sensor: the road is z = -kHeight. A wall across +x, a terrace 0.4 m high.
const Box kWallBox{{12.0, -20.0, -kHeight}, {12.3, 20.0, 3.0}};
const Box kTerraceBox{{-8.0, -3.0, -kHeight}, {-4.0, 3.0, -kHeight + 0.4}};

double hit_box(const Vector3d& d, const Box& b) {
  double t0 = 0.0, t1 = std::numeric_limits<double>::infinity();
  for (int a = 0; a < 3; ++a) {
    if (std::abs(d(a)) < 1e-12) {
      if (0.0 < b.lo(a) || 0.0 > b.hi(a)) return std::numeric_limits<double>::infinity();
      continue;
    }
    double ta = b.lo(a) / d(a), tb = b.hi(a) / d(a);
    if (ta > tb) std::swap(ta, tb);
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb);
  }
  return t0 <= t1 && t0 > 0.0 ? t0 : std::numeric_limits<double>::infinity();
}

struct Frame {
  PointCloud cloud;  // sensor frame, rings set
  std::vector<int> surface;
};

/// One sweep; the sensor is tilted by R_level^T (its points are R_level^T times level ones).
/// Every `drop`-th return (by a fixed hash of row and column) is lost; 0 = none.
Frame sweep(const Matrix3d& R_level, int drop) {
  Frame f;
  for (int r = 0; r < 16; ++r) {
    const double e = (-15.0 + 2.0 * r) * kDeg;
    for (int c = 0; c < 1800; ++c) {
      if (drop > 0 && (r * 7919 + c * 104729) % drop == 0) continue;
      const double b = (c + 0.5) * 0.2 * kDeg;  // column centres: one return per pixel
      const Vector3d d_sensor(std::cos(e) * std::sin(b), std::cos(e) * std::cos(b), std::sin(e));
      const Vector3d d = R_level * d_sensor;
      double t = d.z() < -1e-12 ? -kHeight / d.z() : std::numeric_limits<double>::infinity();
      int s = kRoad;
      const double tw = hit_box(d, kWallBox), tt = hit_box(d, kTerraceBox);
      if (tw < t) { t = tw; s = kWall; }
      if (tt < t) { t = tt; s = kTerrace; }
      if (!(t < 100.0)) continue;
      f.cloud.points.push_back((t * d_sensor).cast<float>());
      f.cloud.rings.push_back(static_cast<std::uint16_t>(r));
      f.surface.push_back(s);
    }
  }
  return f;
}

struct Counts {
  std::size_t road = 0, road_marked = 0, other_marked = 0, terrace_marked = 0;
};
Counts count(const Frame& f, const RingGroundResult& g) {
  Counts c;
  for (std::size_t i = 0; i < f.surface.size(); ++i) {
    c.road += f.surface[i] == kRoad ? 1 : 0;
    c.road_marked += f.surface[i] == kRoad && g.ground[i] ? 1 : 0;
    c.other_marked += f.surface[i] != kRoad && g.ground[i] ? 1 : 0;
    c.terrace_marked += f.surface[i] == kTerrace && g.ground[i] ? 1 : 0;
  }
  return c;
}

RangeImage image_of(const PointCloud& cloud) {
  RangeImageSettings s;
  s.ring_source = RingSource::kField;
  s.num_rings = 16;
  return build_range_image(cloud, s);
}

TEST(GroundTest, PlaneTakesTheRoadReturnsThePairTestMisses) {
  for (const double roll_deg : {0.0, 4.0}) {
    SCOPED_TRACE(roll_deg);
    const Matrix3d R_level = so3::exp(Vector3d(roll_deg * kDeg, -1.5 * roll_deg * kDeg, 0.3));
    const Frame f = sweep(R_level, 5);
    const RangeImage image = image_of(f.cloud);
    ASSERT_EQ(image.num_collisions, 0u);

    RingGroundSettings pair_only;
    pair_only.plane_tolerance = 0.0;
    const RingGroundResult p = classify_ground(f.cloud, image, R_level, pair_only);
    const Counts cp = count(f, p);
    EXPECT_FALSE(p.plane_used);
    EXPECT_EQ(p.num_from_plane, 0u);
    // With a fifth of the returns lost, the pair test misses road returns (those whose upper and
    // lower neighbours in the column are both lost or off the road) ...
    EXPECT_LT(cp.road_marked, cp.road);
    EXPECT_GT(cp.road_marked, cp.road / 2);
    // ... and, having no notion of height, takes the terrace's flat top for road (and joins road
    // returns to low returns on the wall behind them).
    EXPECT_GT(cp.terrace_marked, 0u);

    const RingGroundResult g = classify_ground(f.cloud, image, R_level, RingGroundSettings{});
    const Counts cg = count(f, g);
    ASSERT_TRUE(g.plane_used);
    // The plane is the road, z = -0.9 in the level frame: the refits drop the terrace and the wall
    // returns above the tolerance; the wall's foot within it pulls the fit up by ~1 mm.
    EXPECT_NEAR(g.plane.x(), 0.0, 1e-3);
    EXPECT_NEAR(g.plane.y(), 0.0, 1e-3);
    EXPECT_NEAR(g.plane.z(), -kHeight, 3e-3);
    // Every road return; what the plane adds is road or within the tolerance of the road (the
    // foot of the wall); the pair test's marks are kept.
    EXPECT_EQ(cg.road_marked, cg.road);
    EXPECT_EQ(g.num_ground, p.num_ground + g.num_from_plane);
    std::size_t added = 0;
    for (std::size_t i = 0; i < f.surface.size(); ++i) {
      if (p.ground[i]) {
        EXPECT_TRUE(g.ground[i]) << "point " << i;
      } else if (g.ground[i]) {
        ++added;
        const double z = (R_level * f.cloud.points[i].cast<double>()).z();
        EXPECT_TRUE(f.surface[i] == kRoad || std::abs(z + kHeight) <= 0.15 + 0.005) << "point " << i;
      }
    }
    EXPECT_EQ(added, g.num_from_plane);
    EXPECT_GE(g.num_from_plane, cg.road - cp.road_marked);
  }
}

TEST(GroundTest, NoRoadNoPlaneAndBadInput) {
  // Without lost returns the pair test already has the whole road; the plane adds only the feet
  // of the wall and the terrace (returns within its tolerance of the road).
  const Frame full = sweep(Matrix3d::Identity(), 0);
  RingGroundSettings pair_only;
  pair_only.plane_tolerance = 0.0;
  const RingGroundResult p = classify_ground(full.cloud, image_of(full.cloud), Matrix3d::Identity(), pair_only);
  EXPECT_EQ(count(full, p).road_marked, count(full, p).road);
  const RingGroundResult g = classify_ground(full.cloud, image_of(full.cloud), Matrix3d::Identity());
  for (std::size_t i = 0; i < full.surface.size(); ++i) {
    if (g.ground[i] && !p.ground[i]) {
      EXPECT_NE(full.surface[i], kRoad) << "point " << i;
      EXPECT_LE(std::abs(full.cloud.points[i].z() + kHeight), 0.155) << "point " << i;
    }
  }

  // Fewer pair-test returns than the plane needs: the pair test only, no throw.
  const Frame lossy = sweep(Matrix3d::Identity(), 5);
  RingGroundSettings need_many;
  need_many.min_plane_points = lossy.cloud.size() + 1;
  const RingGroundResult gf = classify_ground(lossy.cloud, image_of(lossy.cloud), Matrix3d::Identity(), need_many);
  EXPECT_FALSE(gf.plane_used);
  EXPECT_EQ(gf.num_from_plane, 0u);
  EXPECT_LT(count(lossy, gf).road_marked, count(lossy, gf).road);

  // Empty frame, NaN points: nothing marked, no throw.
  const PointCloud empty;
  EXPECT_EQ(classify_ground(empty, image_of(empty), Matrix3d::Identity()).num_ground, 0u);
  PointCloud with_nan = full.cloud;
  with_nan.points[10] = Vector3f::Constant(std::numeric_limits<float>::quiet_NaN());
  const RingGroundResult gn = classify_ground(with_nan, image_of(with_nan), Matrix3d::Identity());
  EXPECT_EQ(gn.ground[10], 0);

  // Misuse: an image of another cloud, settings out of range, a non-finite rotation.
  EXPECT_THROW(classify_ground(lossy.cloud, image_of(full.cloud), Matrix3d::Identity()), Error);
  RingGroundSettings bad;
  bad.max_slope_deg = 90.0;
  EXPECT_THROW(classify_ground(full.cloud, image_of(full.cloud), Matrix3d::Identity(), bad), Error);
  bad = {};
  bad.plane_tolerance = -0.1;
  EXPECT_THROW(classify_ground(full.cloud, image_of(full.cloud), Matrix3d::Identity(), bad), Error);
  Matrix3d nan_R = Matrix3d::Identity();
  nan_R(0, 0) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(classify_ground(full.cloud, image_of(full.cloud), nan_R), Error);
}

}  // namespace
}  // namespace plumb
