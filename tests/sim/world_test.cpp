// SPDX-License-Identifier: BSD-3-Clause
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <set>
#include <string>

#include "plumb/bim/ifc.hpp"
#include "plumb/bim/mesh.hpp"
#include "plumb/core/error.hpp"
#include "plumb/core/rng.hpp"
#include "plumb/sim/lidar.hpp"
#include "plumb/sim/world.hpp"
#include "test_data.hpp"

using plumb::Vector3d;
using plumb::bim::BimElement;
using plumb::bim::BimMesh;
using namespace plumb::sim;

namespace {

constexpr double kFar = std::numeric_limits<double>::infinity();

/// Append a closed axis-aligned box as a new element of `type`.
int add_box(BimMesh& m, const Vector3d& lo, const Vector3d& hi, const std::string& type) {
  BimElement el;
  el.express_id = static_cast<std::uint32_t>(m.elements.size() + 1);
  el.type = type;
  el.name = type + std::to_string(m.elements.size());
  el.storey = 0;
  el.first_triangle = m.triangles.size();
  el.num_triangles = 12;
  el.bbox_min = lo;
  el.bbox_max = hi;
  el.has_body = true;
  const auto base = static_cast<std::uint32_t>(m.vertices.size());
  for (int i = 0; i < 8; ++i) {
    m.vertices.emplace_back((i & 1) ? hi.x() : lo.x(), (i & 2) ? hi.y() : lo.y(), (i & 4) ? hi.z() : lo.z());
  }
  const std::uint32_t quads[6][4] = {{0, 4, 6, 2}, {1, 3, 7, 5}, {0, 1, 5, 4},
                                     {2, 6, 7, 3}, {0, 2, 3, 1}, {4, 5, 7, 6}};
  const auto index = static_cast<std::int32_t>(m.elements.size());
  for (const auto& q : quads) {
    m.triangles.push_back({base + q[0], base + q[1], base + q[2]});
    m.triangles.push_back({base + q[0], base + q[2], base + q[3]});
    m.triangle_element.push_back(index);
    m.triangle_element.push_back(index);
  }
  m.elements.push_back(el);
  return index;
}

/// A 10 m x 8 m room, 3 m high: floor slab, ceiling slab, four walls 0.2 m thick, a column, a
/// window (1 m wide, z 1..2) in the east wall at y 3.5..4.5 and a door (1 m wide, z 0..2.1) in the
/// west wall at y 3.5..4.5. Inside: x in [0, 10], y in [0, 8], z in [0, 3].
struct Building {
  BimMesh mesh;
  int floor = -1, ceiling = -1, wall_south = -1, wall_north = -1, column = -1, window = -1, door = -1;
};

Building synthetic_building() {
  Building b;
  BimMesh& m = b.mesh;
  m.storeys.push_back({1, "Ground", 0.0});
  b.floor = add_box(m, Vector3d(-0.2, -0.2, -0.2), Vector3d(10.2, 8.2, 0.0), "IfcSlab");
  b.ceiling = add_box(m, Vector3d(-0.2, -0.2, 3.0), Vector3d(10.2, 8.2, 3.2), "IfcSlab");
  b.wall_south = add_box(m, Vector3d(-0.2, -0.2, 0.0), Vector3d(10.2, 0.0, 3.0), "IfcWallStandardCase");
  b.wall_north = add_box(m, Vector3d(-0.2, 8.0, 0.0), Vector3d(10.2, 8.2, 3.0), "IfcWall");
  // East wall x in [10, 10.2] around the window hole y 3.5..4.5, z 1..2.
  add_box(m, Vector3d(10.0, 0.0, 0.0), Vector3d(10.2, 3.5, 3.0), "IfcWall");
  add_box(m, Vector3d(10.0, 4.5, 0.0), Vector3d(10.2, 8.0, 3.0), "IfcWall");
  add_box(m, Vector3d(10.0, 3.5, 0.0), Vector3d(10.2, 4.5, 1.0), "IfcWall");
  add_box(m, Vector3d(10.0, 3.5, 2.0), Vector3d(10.2, 4.5, 3.0), "IfcWall");
  b.window = add_box(m, Vector3d(10.05, 3.5, 1.0), Vector3d(10.15, 4.5, 2.0), "IfcWindow");
  // West wall x in [-0.2, 0] around the door hole y 3.5..4.5, z 0..2.1.
  add_box(m, Vector3d(-0.2, 0.0, 0.0), Vector3d(0.0, 3.5, 3.0), "IfcWall");
  add_box(m, Vector3d(-0.2, 4.5, 0.0), Vector3d(0.0, 8.0, 3.0), "IfcWall");
  add_box(m, Vector3d(-0.2, 3.5, 2.1), Vector3d(0.0, 4.5, 3.0), "IfcWall");
  b.door = add_box(m, Vector3d(-0.15, 3.5, 0.0), Vector3d(-0.05, 4.5, 2.1), "IfcDoor");
  b.column = add_box(m, Vector3d(6.0, 5.0, 0.0), Vector3d(6.4, 5.4, 3.0), "IfcColumn");
  return b;
}

WorldSettings exact_settings() {
  WorldSettings s;
  s.as_built_sigma_m = 0.0;
  s.as_built_sigma_rad = 0.0;
  s.clutter = 0.0;
  s.num_people = 0;
  return s;
}

}  // namespace

TEST(WorldTest, LabelsOnASyntheticBuilding) {
  const Building b = synthetic_building();
  const World world(b.mesh, exact_settings());
  const Vector3d o(3.0, 2.0, 1.5);
  struct Case {
    Vector3d dir;
    double range;
    int element;
    SimLabel label;
  };
  const Case cases[] = {
      {Vector3d(0, 0, -1), 1.5, b.floor, kSimGround},          // the floor from above
      {Vector3d(0, 0, 1), 1.5, b.ceiling, kSimOtherElement},   // a slab from below is no ground
      {Vector3d(0, -1, 0), 2.0, b.wall_south, kSimWall},
      {Vector3d(0, 1, 0), 6.0, b.wall_north, kSimWall},
      {Vector3d(3.0, 3.0, 0).normalized(), std::sqrt(18.0), b.column, kSimOtherElement},
  };
  for (const Case& c : cases) {
    const RayHit h = world.cast(o, c.dir, kFar, 0.0);
    ASSERT_TRUE(h.hit());
    EXPECT_NEAR(h.range, c.range, 1e-12);
    EXPECT_EQ(h.element, c.element);
    EXPECT_EQ(b.mesh.triangle_element[h.triangle], c.element);  // a BIM triangle index
    EXPECT_EQ(world.label_of(h), c.label);
  }
  EXPECT_EQ(world.label_of(RayHit{}), kSimOther);
  // The top of the ceiling slab seen from above is ground (a floor of the storey above).
  const RayHit roof = world.cast(Vector3d(5, 4, 10), Vector3d(0, 0, -1), kFar, 0.0);
  EXPECT_NEAR(roof.range, 6.8, 1e-12);
  EXPECT_EQ(world.label_of(roof), kSimGround);
  // The side of a slab is not ground.
  const RayHit side = world.cast(Vector3d(12, 4, -0.1), Vector3d(-1, 0, 0), kFar, 0.0);
  EXPECT_EQ(side.element, b.floor);
  EXPECT_EQ(world.label_of(side), kSimOtherElement);
  EXPECT_EQ(sim_class_of_type("IFCWALLSTANDARDCASE"), kSimWall);
  EXPECT_EQ(sim_class_of_type("IfcCurtainWall"), kSimWall);
  EXPECT_EQ(sim_class_of_type("IfcBeam"), kSimOtherElement);
  EXPECT_EQ(sim_class_of_type("IfcCovering"), kSimGround);
}

TEST(WorldTest, WindowsTransmitAndDoorsStandOpen) {
  Building b = synthetic_building();
  // Something outside behind the window and the door, 5 m away.
  const int shed_east = add_box(b.mesh, Vector3d(15.0, 0.0, 0.0), Vector3d(16.0, 8.0, 3.0), "IfcBuildingElementProxy");
  const int shed_west = add_box(b.mesh, Vector3d(-6.0, 0.0, 0.0), Vector3d(-5.0, 8.0, 3.0), "IfcBuildingElementProxy");
  const World world(b.mesh, exact_settings());
  const RayHit through_window = world.cast(Vector3d(5, 4, 1.5), Vector3d(1, 0, 0), kFar, 0.0);
  ASSERT_TRUE(through_window.hit());
  EXPECT_EQ(through_window.element, shed_east);
  EXPECT_NEAR(through_window.range, 10.0, 1e-12);
  const RayHit through_door = world.cast(Vector3d(5, 4, 1.0), Vector3d(-1, 0, 0), kFar, 0.0);
  ASSERT_TRUE(through_door.hit());
  EXPECT_EQ(through_door.element, shed_west);
  EXPECT_NEAR(through_door.range, 10.0, 1e-12);
  // Beside the window: the wall.
  const RayHit wall = world.cast(Vector3d(5, 4, 0.5), Vector3d(1, 0, 0), kFar, 0.0);
  EXPECT_NEAR(wall.range, 5.0, 1e-12);
  EXPECT_EQ(world.label_of(wall), kSimWall);
  // The nominal model still has its window and door.
  EXPECT_EQ(world.bim().elements[static_cast<std::size_t>(b.window)].type, "IfcWindow");
  EXPECT_TRUE(sim_type_is_transparent("IFCDOOR"));
  EXPECT_FALSE(sim_type_is_transparent("IfcWall"));
}

TEST(WorldTest, AsBuiltDeviationsMoveEachElementRigidly) {
  const Building b = synthetic_building();
  WorldSettings s = exact_settings();
  s.as_built_sigma_m = 0.01;
  s.as_built_sigma_rad = 0.2 * M_PI / 180.0;
  const World world(b.mesh, s);
  const World nominal(b.mesh, exact_settings());
  plumb::Rng rng(5);
  int moved = 0, checked = 0;
  double max_shift = 0.0;
  for (int i = 0; i < 400; ++i) {
    const Vector3d o(rng.uniform(1, 9), rng.uniform(1, 7), rng.uniform(0.5, 2.5));
    Vector3d d(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1));
    d.normalize();
    const RayHit h = world.cast(o, d, kFar, 0.0);
    const RayHit h0 = nominal.cast(o, d, kFar, 0.0);
    if (!h.hit() || !h0.hit() || h.element != h0.element) continue;
    ++checked;
    // The as-built hit, taken back through its element's deviation, lies on the nominal surface:
    // the nominal triangle's plane.
    const Eigen::Isometry3d& T = world.element_deviation(static_cast<std::size_t>(h.element));
    const Vector3d p_nominal = T.inverse() * Vector3d(o + h.range * d);
    const auto& tri = b.mesh.triangles[h.triangle];
    const Vector3d a = b.mesh.vertices[tri[0]];
    const Vector3d n = (b.mesh.vertices[tri[1]] - a).cross(b.mesh.vertices[tri[2]] - a).normalized();
    EXPECT_NEAR(n.dot(p_nominal - a), 0.0, 1e-9);
    // The as-built surface lies within centimetres of the nominal one.
    max_shift = std::max(max_shift, std::abs(n.dot(Vector3d(o + h.range * d) - a)));
    if (std::abs(h.range - h0.range) > 1e-6) ++moved;
  }
  EXPECT_GT(checked, 300);
  EXPECT_GT(moved, checked / 2);
  EXPECT_LT(max_shift, 0.1);  // centimetres: 0.2 deg over ~5 m plus a few sigma
  for (std::size_t e = 0; e < b.mesh.elements.size(); ++e) {
    const Eigen::Isometry3d& T = world.element_deviation(e);
    const double angle = Eigen::AngleAxisd(T.linear()).angle();
    EXPECT_LT(angle, 5.0 * std::sqrt(3.0) * s.as_built_sigma_rad);
    const Vector3d c = 0.5 * (b.mesh.elements[e].bbox_min + b.mesh.elements[e].bbox_max);
    EXPECT_LT((T * c - c).norm(), 5.0 * std::sqrt(3.0) * s.as_built_sigma_m);
  }
}

TEST(WorldTest, ClutterStandsOnTheFloorAgainstWallsAndIsLabelled) {
  const Building b = synthetic_building();
  WorldSettings s;
  s.clutter = 3.0;
  s.num_people = 2;
  s.seed = 4;
  const World world(b.mesh, s);
  ASSERT_GE(world.clutter().size(), 3u);
  EXPECT_EQ(world.obstacles().size(), world.clutter().size());
  EXPECT_EQ(world.people().size(), 2u);
  const auto num_bim = static_cast<std::uint32_t>(b.mesh.num_triangles());
  for (std::size_t k = 0; k < world.clutter().size(); ++k) {
    const ClutterBox& box = world.clutter()[k];
    SCOPED_TRACE(k);
    // On the floor (z = 0, within the as-built deviation) and inside the room.
    EXPECT_NEAR(box.center.z() - box.half_size.z(), 0.0, 0.05);
    const Eigen::Matrix3d R = Eigen::AngleAxisd(box.yaw, Vector3d::UnitZ()).toRotationMatrix();
    double min_wall_gap = kFar;
    for (int i = 0; i < 4; ++i) {
      const Vector3d corner = box.center + R * Vector3d((i & 1) ? box.half_size.x() : -box.half_size.x(),
                                                        (i & 2) ? box.half_size.y() : -box.half_size.y(), 0);
      EXPECT_GT(corner.x(), -0.05);
      EXPECT_LT(corner.x(), 10.05);
      EXPECT_GT(corner.y(), -0.05);
      EXPECT_LT(corner.y(), 8.05);
      min_wall_gap = std::min({min_wall_gap, corner.x(), 10.0 - corner.x(), corner.y(), 8.0 - corner.y()});
    }
    EXPECT_LT(min_wall_gap, 0.15) << box.center.transpose() << " half " << box.half_size.transpose() << " yaw " << box.yaw;  // against a wall
    // Not in front of the door (x = 0, y 3.5..4.5).
    EXPECT_FALSE(box.center.x() < 1.5 && box.center.y() > 2.5 && box.center.y() < 5.5);
    // A ray from above at its centre meets the box top, labelled clutter.
    const RayHit h = world.cast(box.center + Vector3d(0, 0, box.half_size.z() + 0.3), Vector3d(0, 0, -1), kFar, 0.0);
    ASSERT_TRUE(h.hit());
    if (h.triangle < num_bim + 12 * world.clutter().size()) {  // (else a person passes there)
      EXPECT_NEAR(h.range, 0.3, 1e-9);
      EXPECT_EQ(h.element, -1);
      EXPECT_GE(h.triangle, num_bim + 12 * k);
      EXPECT_LT(h.triangle, num_bim + 12 * (k + 1));
      EXPECT_EQ(world.label_of(h), kSimClutter);
    }
    for (std::size_t j = 0; j < k; ++j) {
      const ClutterBox& other = world.clutter()[j];
      EXPECT_GT((other.center - box.center).head<2>().norm(),
                other.half_size.head<2>().norm() + box.half_size.head<2>().norm());
    }
  }
}

TEST(WorldTest, PeopleWalkAndAreHitWhereTheyStand) {
  const Building b = synthetic_building();
  WorldSettings s;
  s.clutter = 0.0;
  s.num_people = 2;
  s.seed = 4;
  const World world(b.mesh, s);
  ASSERT_EQ(world.people().size(), 2u);
  const auto num_bim = static_cast<std::uint32_t>(b.mesh.num_triangles());
  for (std::size_t p = 0; p < world.people().size(); ++p) {
    const Person& person = world.people()[p];
    SCOPED_TRACE(p);
    EXPECT_GE((person.b - person.a).norm(), 2.0);
    EXPECT_NEAR(person.a.z(), 0.0, 0.05);  // on the floor
    const double dt = 0.1;
    int full_steps = 0;
    for (double t = 0.0; t < 10.0; t += 0.5) {
      const Vector3d f = person.position(t);
      EXPECT_LT((f - person.a).norm() + (f - person.b).norm() - (person.b - person.a).norm(), 1e-9);
      const double step = (person.position(t + dt) - f).norm();
      EXPECT_LE(step, person.speed * dt + 1e-9);
      if (std::abs(step - person.speed * dt) < 1e-9) ++full_steps;
      // From 0.3 m beside them at chest height, perpendicular to the walk; and from above the head.
      const Vector3d walk = (person.b - person.a).normalized();
      const Vector3d side(-walk.y(), walk.x(), 0.0);
      const RayHit h = world.cast(f + Vector3d(0, 0, 1.2) + side * (person.radius + 0.3), -side, kFar, t);
      ASSERT_TRUE(h.hit());
      EXPECT_NEAR(h.range, 0.3, 1e-9);
      EXPECT_EQ(h.element, -1);
      EXPECT_EQ(h.triangle, num_bim + p);
      EXPECT_EQ(world.label_of(h), kSimClutter);
      EXPECT_GT(h.normal.dot(side), 0.999);
      const RayHit top = world.cast(f + Vector3d(0, 0, 2.5), -Vector3d::UnitZ(), kFar, t);
      EXPECT_NEAR(top.range, 2.5 - person.height, 1e-9);
      EXPECT_EQ(top.triangle, num_bim + p);
      // A ray that passes 1 cm beside them does not hit them.
      const RayHit miss = world.cast(f + Vector3d(0, 0, 1.2) + side * (person.radius + 0.01) - walk * 2.0, walk, 4.0, t);
      EXPECT_NE(miss.triangle, num_bim + p);
    }
    EXPECT_GE(full_steps, 10);  // they walk (turning at the ends now and then)
  }
}

TEST(WorldTest, DeterministicForASeed) {
  const Building b = synthetic_building();
  WorldSettings s;
  s.clutter = 2.0;
  s.seed = 9;
  const World w1(b.mesh, s), w2(b.mesh, s);
  s.seed = 10;
  const World w3(b.mesh, s);
  ASSERT_EQ(w1.clutter().size(), w2.clutter().size());
  for (std::size_t k = 0; k < w1.clutter().size(); ++k) {
    EXPECT_EQ(w1.clutter()[k].center, w2.clutter()[k].center);
    EXPECT_EQ(w1.clutter()[k].yaw, w2.clutter()[k].yaw);
  }
  ASSERT_EQ(w1.people().size(), w2.people().size());
  for (std::size_t p = 0; p < w1.people().size(); ++p) EXPECT_EQ(w1.people()[p].position(3.3), w2.people()[p].position(3.3));
  plumb::Rng rng(1);
  int differ = 0;
  for (int i = 0; i < 300; ++i) {
    const Vector3d o(rng.uniform(1, 9), rng.uniform(1, 7), rng.uniform(0.5, 2.5));
    const Vector3d d = Vector3d(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1)).normalized();
    const RayHit h1 = w1.cast(o, d, kFar, 1.0), h2 = w2.cast(o, d, kFar, 1.0), h3 = w3.cast(o, d, kFar, 1.0);
    EXPECT_EQ(h1.range, h2.range);
    EXPECT_EQ(h1.triangle, h2.triangle);
    if (h1.range != h3.range) ++differ;
  }
  EXPECT_GT(differ, 100);  // another seed builds another building
}

TEST(WorldTest, BadSettingsThrow) {
  const Building b = synthetic_building();
  WorldSettings s;
  s.as_built_sigma_m = -0.1;
  EXPECT_THROW(World(b.mesh, s), plumb::Error);
  s = WorldSettings{};
  s.clutter = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(World(b.mesh, s), plumb::Error);
  s = WorldSettings{};
  s.storey = 3;
  EXPECT_THROW(World(b.mesh, s), plumb::Error);
  s = WorldSettings{};
  s.num_people = -1;
  EXPECT_THROW(World(b.mesh, s), plumb::Error);
  BimMesh broken = b.mesh;
  broken.triangle_element.pop_back();
  EXPECT_THROW(World(broken, WorldSettings{}), plumb::Error);
  // An empty model is a world where every ray misses.
  const World empty(BimMesh{}, WorldSettings{});
  EXPECT_FALSE(empty.cast(Vector3d::Zero(), Vector3d::UnitX(), kFar, 0.0).hit());
  EXPECT_TRUE(empty.clutter().empty());
}

TEST(WorldTest, FzkHausHasFurnitureAndEveryClassInASweep) {
  PLUMB_REQUIRE_DATA(path, "ifc/buildings/AC20-FZK-Haus.ifc");
  const BimMesh mesh = plumb::bim::build_mesh(plumb::bim::read_ifc(path));
  WorldSettings s;
  s.storey = 0;
  const World world(mesh, s);
  EXPECT_GE(world.clutter().size(), 3u);
  EXPECT_EQ(world.people().size(), 2u);
  // Every box stands on a floor of storey 0 with nothing of the BIM inside it: from the box centre
  // the nominal model is at least the box's half extent away in all horizontal directions.
  const RayCaster nominal(mesh);
  for (const ClutterBox& box : world.clutter()) {
    const RayHit down = nominal.cast(box.center, -Vector3d::UnitZ(), 3.0);
    ASSERT_TRUE(down.hit());
    EXPECT_NEAR(down.range, box.half_size.z(), 0.05);
    EXPECT_EQ(world.label_of(world.cast(box.center + Vector3d(0, 0, box.half_size.z() + 0.3), -Vector3d::UnitZ(), 1.0, 0.0)),
              kSimClutter);
  }
  // Sweeps from the middle of the people's walks see ground, walls, other elements and clutter.
  const LidarModel lidar = lidar_preset("vlp16");
  plumb::Rng rng(2);
  std::map<std::int32_t, int> count;
  for (const Person& person : world.people()) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.translation() = 0.5 * (person.a + person.b) + Vector3d(0, 0, 0.8);
    for (double stamp : {0.0, 1.0, 2.0}) {
      const plumb::PointCloud cloud = simulate_sweep(world, lidar, [&](double) { return T; }, stamp, rng);
      for (std::int32_t l : cloud.labels) ++count[l];
    }
  }
  EXPECT_GT(count[kSimGround], 100);
  EXPECT_GT(count[kSimWall], 100);
  EXPECT_GT(count[kSimOtherElement], 0);
  EXPECT_GT(count[kSimClutter], 0);
  EXPECT_EQ(count[kSimOther], 0);
}
