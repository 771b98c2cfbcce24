// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/sim/world.hpp"

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <unordered_map>
#include <utility>

#include "plumb/core/error.hpp"
#include "plumb/core/rng.hpp"

namespace plumb::sim {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

std::string lower(const std::string& s) {
  std::string out = s;
  for (char& c : out) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return out;
}

/// Furniture kinds: full width (along the wall), depth, height [m].
struct FurnitureKind {
  double width, depth, height;
};
constexpr FurnitureKind kFurniture[] = {
    {1.6, 0.8, 0.75},  // desk
    {1.0, 0.45, 1.9},  // cabinet
    {1.2, 0.4, 2.0},   // shelf
    {0.6, 0.6, 0.6},   // carton
    {2.0, 0.9, 0.85},  // sofa / bench
};

Eigen::Matrix3d small_rotation(const Vector3d& w) {
  const double a = w.norm();
  if (a == 0.0) return Eigen::Matrix3d::Identity();
  return Eigen::AngleAxisd(a, w / a).toRotationMatrix();
}

/// The 8 corners and 12 triangles (outward, counter-clockwise) of an oriented box.
void append_box(const ClutterBox& box, std::vector<Vector3d>& vertices,
                std::vector<std::array<std::uint32_t, 3>>& triangles) {
  const auto base = static_cast<std::uint32_t>(vertices.size());
  const Eigen::Matrix3d R = Eigen::AngleAxisd(box.yaw, Vector3d::UnitZ()).toRotationMatrix();
  for (int i = 0; i < 8; ++i) {
    const Vector3d s((i & 1) ? 1.0 : -1.0, (i & 2) ? 1.0 : -1.0, (i & 4) ? 1.0 : -1.0);
    vertices.push_back(box.center + R * s.cwiseProduct(box.half_size));
  }
  // Faces as corner quads (bit 0 = x, bit 1 = y, bit 2 = z), each wound outward.
  const std::uint32_t quads[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4},
                                     {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  for (const auto& q : quads) {
    triangles.push_back({base + q[0], base + q[1], base + q[2]});
    triangles.push_back({base + q[0], base + q[2], base + q[3]});
  }
}

double footprint_radius(const ClutterBox& b) { return b.half_size.head<2>().norm(); }

}  // namespace

SimLabel sim_class_of_type(const std::string& ifc_type) {
  const std::string t = lower(ifc_type);
  if (t == "ifcslab" || t == "ifcslabstandardcase" || t == "ifcslabelementedcase" || t == "ifccovering" ||
      t == "ifcramp" || t == "ifcrampflight" || t == "ifcsite") {
    return kSimGround;
  }
  if (t == "ifcwall" || t == "ifcwallstandardcase" || t == "ifcwallelementedcase" || t == "ifccurtainwall") {
    return kSimWall;
  }
  return kSimOtherElement;
}

bool sim_type_is_transparent(const std::string& ifc_type) {
  const std::string t = lower(ifc_type);
  return t == "ifcwindow" || t == "ifcwindowstandardcase" || t == "ifcdoor" || t == "ifcdoorstandardcase" ||
         t == "ifcopeningelement" || t == "ifcopeningstandardcase" || t == "ifcspace";
}

Vector3d Person::position(double time) const {
  const double len = (b - a).norm();
  if (!(len > 0.0) || !(speed > 0.0)) return a;
  const double period = 2.0 * len;
  double s = std::fmod((time + phase) * speed, period);
  if (s < 0.0) s += period;
  const double d = s <= len ? s : period - s;
  return a + (b - a) * (d / len);
}

namespace {

void check_world_inputs(const bim::BimMesh& mesh, const WorldSettings& s) {
  PLUMB_CHECK(std::isfinite(s.as_built_sigma_m) && s.as_built_sigma_m >= 0.0,
              "World: settings.as_built_sigma_m " << s.as_built_sigma_m << " must be finite and >= 0");
  PLUMB_CHECK(std::isfinite(s.as_built_sigma_rad) && s.as_built_sigma_rad >= 0.0,
              "World: settings.as_built_sigma_rad " << s.as_built_sigma_rad << " must be finite and >= 0");
  PLUMB_CHECK(std::isfinite(s.clutter) && s.clutter >= 0.0 && s.clutter <= WorldSettings::kMaxClutter,
              "World: settings.clutter " << s.clutter << " must be in [0, " << WorldSettings::kMaxClutter << "]");
  PLUMB_CHECK(s.num_people >= 0, "World: settings.num_people " << s.num_people << " must be >= 0");
  PLUMB_CHECK(s.person_speed > 0.0 && s.person_radius > 0.0 && s.person_height > 0.0 &&
                  std::isfinite(s.person_speed + s.person_radius + s.person_height),
              "World: person speed, radius and height must be finite and > 0");
  PLUMB_CHECK(s.storey >= -1 && s.storey < static_cast<int>(mesh.storeys.size()),
              "World: settings.storey " << s.storey << " but the model has " << mesh.storeys.size()
                                        << " storeys (-1 = all)");
  PLUMB_CHECK(mesh.triangle_element.size() == mesh.triangles.size(),
              "World: mesh has " << mesh.triangle_element.size() << " triangle elements for "
                                 << mesh.triangles.size() << " triangles");
  const std::size_t num_elements = mesh.elements.size();
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    PLUMB_CHECK(mesh.triangle_element[t] >= -1 && mesh.triangle_element[t] < static_cast<std::int64_t>(num_elements),
                "World: triangle " << t << " has element " << mesh.triangle_element[t] << " of " << num_elements);
  }
}

/// As-built deviations: each element turned about its bounding-box centre c by R and shifted by t,
/// p' = R (p - c) + c + t. The vertices are moved as p + (R - I)(p - c) + t.
struct AsBuiltMotions {
  bool perturb = false;
  std::vector<Eigen::Isometry3d> deviation;
  std::vector<Eigen::Matrix3d> rot_minus_identity;
  std::vector<Vector3d> center, shift;
};

AsBuiltMotions draw_as_built_motions(const bim::BimMesh& mesh, const WorldSettings& s, Rng& rng) {
  const std::size_t num_elements = mesh.elements.size();
  AsBuiltMotions m;
  m.deviation.assign(num_elements, Eigen::Isometry3d::Identity());
  m.rot_minus_identity.assign(num_elements, Eigen::Matrix3d::Zero());
  m.center.assign(num_elements, Vector3d::Zero());
  m.shift.assign(num_elements, Vector3d::Zero());
  m.perturb = s.as_built_sigma_m > 0.0 || s.as_built_sigma_rad > 0.0;
  for (std::size_t e = 0; e < num_elements; ++e) {
    const bim::BimElement& el = mesh.elements[e];
    // Rooms are not built: no deviation drawn, so a mesh with its spaces simulates the same world.
    if (!m.perturb || el.type == "IfcSpace") continue;
    const Vector3d w(rng.normal(), rng.normal(), rng.normal());
    const Vector3d t(rng.normal(), rng.normal(), rng.normal());
    const Eigen::Matrix3d R = small_rotation(w * s.as_built_sigma_rad);
    m.center[e] = (el.bbox_min.allFinite() && el.bbox_max.allFinite()) ? Vector3d(0.5 * (el.bbox_min + el.bbox_max))
                                                                        : Vector3d::Zero();
    m.shift[e] = t * s.as_built_sigma_m;
    m.rot_minus_identity[e] = R - Eigen::Matrix3d::Identity();
    // p' = R (p - c) + c + t
    m.deviation[e].linear() = R;
    m.deviation[e].translation() = m.center[e] - R * m.center[e] + m.shift[e];
  }
  return m;
}

/// The triangle soup of the world's ray caster.
struct CasterMesh {
  std::vector<Vector3d> vertices;
  std::vector<std::array<std::uint32_t, 3>> triangles;
  std::vector<std::int32_t> tri_element;
  std::vector<std::uint32_t> bim_triangle;  ///< caster triangle -> BIM triangle (BIM part)
};

/// The as-built BIM triangles: transparent elements left out, vertices per element so each moves
/// with its element (an element stays watertight; neighbours may open hairline gaps, as built).
CasterMesh as_built_triangles(const bim::BimMesh& mesh, const AsBuiltMotions& motions) {
  CasterMesh out;
  std::unordered_map<std::uint64_t, std::uint32_t> remap;
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    const std::int32_t e = mesh.triangle_element[t];
    if (e >= 0 && sim_type_is_transparent(mesh.elements[static_cast<std::size_t>(e)].type)) continue;
    std::array<std::uint32_t, 3> tri{};
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t v = mesh.triangles[t][static_cast<std::size_t>(k)];
      PLUMB_CHECK(v < mesh.vertices.size(), "World: triangle " << t << " uses vertex " << v << " of "
                                                               << mesh.vertices.size());
      const std::uint64_t key = (static_cast<std::uint64_t>(static_cast<std::uint32_t>(e)) << 32) | v;
      auto [it, inserted] = remap.try_emplace(key, static_cast<std::uint32_t>(out.vertices.size()));
      if (inserted) {
        const Vector3d& p = mesh.vertices[v];
        if (e >= 0 && motions.perturb) {
          const auto ue = static_cast<std::size_t>(e);
          out.vertices.push_back(p + motions.rot_minus_identity[ue] * (p - motions.center[ue]) + motions.shift[ue]);
        } else {
          out.vertices.push_back(p);
        }
      }
      tri[static_cast<std::size_t>(k)] = it->second;
    }
    out.triangles.push_back(tri);
    out.tri_element.push_back(e);
    out.bim_triangle.push_back(static_cast<std::uint32_t>(t));
  }
  return out;
}

/// Places furniture and people on the floors of the as-built BIM: every test is a ray cast against
/// the BIM triangles alone (the clutter is added to the world's caster afterwards).
class ClutterPlacer {
 public:
  ClutterPlacer(const bim::BimMesh& mesh, const CasterMesh& bim_part, const std::vector<SimLabel>& element_class,
                const WorldSettings& s, Rng& rng)
      : bim_part_(bim_part),
        element_class_(element_class),
        s_(s),
        rng_(rng),
        caster_(bim_part.vertices, bim_part.triangles, bim_part.tri_element, s.caster) {
    collect_floor(mesh);
    collect_doors(mesh);
  }

  /// Floor area the clutter can stand on [m^2].
  double floor_area() const { return total_area_; }

  /// Furniture against walls, until `target` pieces stand or the attempts run out.
  std::vector<ClutterBox> furniture(std::size_t target) {
    std::vector<ClutterBox> placed;
    const std::size_t max_attempts = 60 * target + 100;
    for (std::size_t attempt = 0; attempt < max_attempts && placed.size() < target; ++attempt) {
      Vector3d p;
      if (!sample_floor(p)) continue;
      const FurnitureKind kind = kFurniture[rng_.uniform_index(std::size(kFurniture))];
      ClutterBox box;
      if (against_wall(p, kind, box, placed)) placed.push_back(box);
    }
    return placed;
  }

  /// People: straight free walks of 2..8 m, around the furniture.
  std::vector<Person> people(const std::vector<ClutterBox>& clutter) {
    std::vector<Person> walkers;
    for (int person = 0, attempt = 0; person < s_.num_people && attempt < 400 * s_.num_people; ++attempt) {
      Vector3d p;
      if (!sample_floor(p)) continue;
      const double az = rng_.uniform(0.0, 2.0 * kPi);
      const Vector3d d(std::cos(az), std::sin(az), 0.0);
      const double reach[2] = {walk_reach(p, d, d, clutter), walk_reach(p, d, Vector3d(-d), clutter)};
      if (reach[0] < 0.0 || reach[1] < 0.0) continue;
      const Vector3d a = p + d * reach[0], b = p - d * reach[1];
      if ((a - b).norm() < 2.0) continue;
      bool ok = !near_door(a, s_.person_radius) && !near_door(b, s_.person_radius);
      for (int k = 0; k <= 8 && ok; ++k) {  // level floor and head room along the walk
        const Vector3d q = a + (b - a) * (k / 8.0);
        ok = column_clear(q, s_.person_height + 0.05);
      }
      if (!ok) continue;
      Person walker;
      walker.a = a;
      walker.b = b;
      walker.speed = s_.person_speed;
      walker.radius = s_.person_radius;
      walker.height = s_.person_height;
      walker.phase = rng_.uniform(0.0, 2.0 * (a - b).norm() / s_.person_speed);
      walkers.push_back(walker);
      ++person;
    }
    return walkers;
  }

 private:
  static constexpr int kDirs = 16;

  /// Floor triangles (as built, facing up) of the chosen storey, weighted by area.
  void collect_floor(const bim::BimMesh& mesh) {
    const auto& vertices = bim_part_.vertices;
    const auto& triangles = bim_part_.triangles;
    for (std::uint32_t t = 0; t < triangles.size(); ++t) {
      const std::int32_t e = bim_part_.tri_element[t];
      if (e < 0 || element_class_[static_cast<std::size_t>(e)] != kSimGround) continue;
      if (s_.storey >= 0 && mesh.elements[static_cast<std::size_t>(e)].storey != s_.storey) continue;
      const Vector3d& a = vertices[triangles[t][0]];
      const Vector3d n = (vertices[triangles[t][1]] - a).cross(vertices[triangles[t][2]] - a);
      const double area2 = n.norm();
      if (!(area2 > 0.0) || n.z() < 0.95 * area2) continue;  // upward within ~18 deg
      total_area_ += 0.5 * area2;
      floor_tri_.push_back(t);
      cum_area_.push_back(total_area_);
    }
  }

  /// Door boxes (nominal), grown by a margin: no furniture there.
  void collect_doors(const bim::BimMesh& mesh) {
    for (const bim::BimElement& el : mesh.elements) {
      const std::string t = lower(el.type);
      if ((t == "ifcdoor" || t == "ifcdoorstandardcase") && el.bbox_min.allFinite() && el.bbox_max.allFinite()) {
        door_boxes_.emplace_back(el.bbox_min - Vector3d::Constant(1.0), el.bbox_max + Vector3d::Constant(1.0));
      }
    }
  }

  bool near_door(const Vector3d& p, double r) const {
    for (const auto& [lo, hi] : door_boxes_) {
      if (p.x() > lo.x() - r && p.x() < hi.x() + r && p.y() > lo.y() - r && p.y() < hi.y() + r &&
          p.z() > lo.z() - 0.5 && p.z() < hi.z()) {
        return true;
      }
    }
    return false;
  }

  /// Horizontal ranges in 16 directions at 0.4 m above a floor point (capped at 3 m).
  void horizontal_ranges(const Vector3d& p, std::array<RayHit, kDirs>& hits) const {
    for (int k = 0; k < kDirs; ++k) {
      const double az = 2.0 * kPi * k / kDirs;
      hits[static_cast<std::size_t>(k)] =
          caster_.cast(p + Vector3d(0, 0, 0.4), Vector3d(std::cos(az), std::sin(az), 0.0), 3.0);
    }
  }

  /// A random floor point in free space: the floor is the top surface there, a ceiling lies 2..6 m
  /// above (indoors), and no two opposite horizontal rays meet surfaces less than 1 m apart (a
  /// point inside a wall's solid would see both of its faces close by). Leaves the point's
  /// horizontal ranges in around_.
  bool sample_floor(Vector3d& p) {
    if (floor_tri_.empty()) return false;
    const auto& vertices = bim_part_.vertices;
    const double u = rng_.uniform(0.0, total_area_);
    const std::size_t i = std::min<std::size_t>(
        floor_tri_.size() - 1,
        static_cast<std::size_t>(std::upper_bound(cum_area_.begin(), cum_area_.end(), u) - cum_area_.begin()));
    const auto& tri = bim_part_.triangles[floor_tri_[i]];
    double r1 = rng_.uniform(), r2 = rng_.uniform();
    if (r1 + r2 > 1.0) { r1 = 1.0 - r1; r2 = 1.0 - r2; }
    const Vector3d q = vertices[tri[0]] + r1 * (vertices[tri[1]] - vertices[tri[0]]) +
                       r2 * (vertices[tri[2]] - vertices[tri[0]]);
    const RayHit down = caster_.cast(q + Vector3d(0, 0, 0.5), -Vector3d::UnitZ(), 1.0);
    if (!down.hit() || std::abs(down.range - 0.5) > 0.02) return false;
    p = q + Vector3d(0, 0, 0.5 - down.range);
    const RayHit up = caster_.cast(p + Vector3d(0, 0, 0.01), Vector3d::UnitZ(), 6.0);
    if (!up.hit() || up.range < 2.0) return false;
    horizontal_ranges(p, around_);
    for (int k = 0; k < kDirs / 2; ++k) {
      const double width = std::min(3.0, around_[static_cast<std::size_t>(k)].range) +
                           std::min(3.0, around_[static_cast<std::size_t>(k + kDirs / 2)].range);
      if (width < 1.0) return false;
    }
    return true;
  }

  /// Floor under a footprint point (level with `floor_z`) and nothing standing there up to `height`.
  bool column_clear(const Vector3d& floor_point, double height) const {
    const RayHit down = caster_.cast(floor_point + Vector3d(0, 0, height), -Vector3d::UnitZ(), height + 0.2);
    return down.hit() && std::abs(down.range - height) < 0.03;
  }

  /// A piece of `kind` with its back against the wall nearest to the sampled point `p` (seen in
  /// around_), when it stands there free of the BIM, of the doors and of the pieces `placed`.
  bool against_wall(const Vector3d& p, const FurnitureKind& kind, ClutterBox& box,
                    const std::vector<ClutterBox>& placed) const {
    // Nearest wall at knee height.
    double nearest = kInf;
    Vector3d wall_normal = Vector3d::Zero();
    for (int k = 0; k < kDirs; ++k) {
      const RayHit& h = around_[static_cast<std::size_t>(k)];
      if (!h.hit() || h.element < 0 || element_class_[static_cast<std::size_t>(h.element)] != kSimWall) continue;
      const Vector3d n(h.normal.x(), h.normal.y(), 0.0);
      if (n.norm() < 0.9) continue;
      const double az = 2.0 * kPi * k / kDirs;
      const double dist = h.range * std::abs(Vector3d(std::cos(az), std::sin(az), 0.0).dot(n.normalized()));
      if (dist < nearest) {
        nearest = dist;  // distance to the wall plane
        wall_normal = n.normalized();
      }
    }
    if (!(nearest < 3.0)) return false;
    // Back against that wall, 3 cm off it, its front facing the room.
    const double yaw = std::atan2(wall_normal.y(), wall_normal.x()) - 0.5 * kPi;
    // Move p onto the wall plane and back out by depth / 2 + gap.
    const Vector3d foot = p - wall_normal * (nearest - (0.5 * kind.depth + 0.03));
    box.half_size = Vector3d(0.5 * kind.width, 0.5 * kind.depth, 0.5 * kind.height);
    box.yaw = yaw;
    box.center = foot + Vector3d(0, 0, box.half_size.z());
    if (!stands_free(box, foot, wall_normal, kind.height)) return false;
    const Vector3d front = box.center + wall_normal * box.half_size.y();
    if (caster_.occluded(Vector3d(front.x(), front.y(), foot.z() + 0.3), wall_normal, 1.0)) return false;
    if (near_door(box.center, footprint_radius(box))) return false;
    for (const ClutterBox& other : placed) {
      if ((other.center - box.center).head<2>().norm() < footprint_radius(other) + footprint_radius(box) + 0.1 &&
          std::abs(other.center.z() - box.center.z()) < 1.0) {
        return false;
      }
    }
    return true;
  }

  /// The box (standing at `foot`, `height` tall) against the wall of normal `wall_normal` meets no
  /// BIM surface and stands on floor.
  bool stands_free(const ClutterBox& box, const Vector3d& foot, const Vector3d& wall_normal, double height) const {
    const Eigen::Matrix3d R = Eigen::AngleAxisd(box.yaw, Vector3d::UnitZ()).toRotationMatrix();
    // Floor everywhere under the footprint and nothing inside the box.
    bool ok = true;
    for (int i = 0; i < 9 && ok; ++i) {
      const Vector3d local(((i % 3) - 1) * 0.95 * box.half_size.x(), ((i / 3) - 1) * 0.95 * box.half_size.y(), 0.0);
      ok = column_clear(foot + R * local, height + 0.05);
    }
    // Nothing crosses the footprint: from the centre (free space) towards its corners and edge
    // midpoints, near the floor and near the top.
    for (int i = 0; i < 9 && ok; ++i) {
      if (i == 4) continue;
      const Vector3d local(((i % 3) - 1) * 0.98 * box.half_size.x(), ((i / 3) - 1) * 0.98 * box.half_size.y(), 0.0);
      const Vector3d w = R * local;
      for (double h : {0.1, height - 0.05}) {
        if (caster_.occluded(foot + Vector3d(0, 0, h), w.normalized(), w.norm())) {
          ok = false;
          break;
        }
      }
    }
    // Its back really stands against the wall (not against a far plane seen through a gap).
    for (double along : {-0.9, 0.0, 0.9}) {
      if (!ok) break;
      const Vector3d back = foot + R * Vector3d(along * box.half_size.x(), 0.0, 0.0) + Vector3d(0, 0, 0.4);
      const RayHit h = caster_.cast(back, -wall_normal, box.half_size.y() + 0.15);
      ok = h.hit();
    }
    return ok;
  }

  /// How far a person may walk from `p` along `u` (the walk's direction `d` or its opposite): short
  /// of the BIM surfaces (at 4 m at most) and of the first furniture box in the way; < 0 = nowhere.
  double walk_reach(const Vector3d& p, const Vector3d& d, const Vector3d& u,
                    const std::vector<ClutterBox>& clutter) const {
    const Vector3d side(-d.y(), d.x(), 0.0);
    double reach = 8.0;
    for (double h : {0.3, 1.2}) {
      for (double off : {-s_.person_radius, 0.0, s_.person_radius}) {
        const RayHit hit = caster_.cast(p + Vector3d(0, 0, h) + side * off, u, 8.0);
        if (hit.hit()) reach = std::min(reach, hit.range);
      }
    }
    reach = std::max(0.0, std::min(4.0, reach - s_.person_radius - 0.3));
    // Stop short of the first furniture box in the way.
    for (double step = 0.0; step <= reach; step += 0.05) {
      if (blocked_by_clutter(p + u * step, clutter)) {
        return step - 0.05;
      }
    }
    return reach;
  }

  bool blocked_by_clutter(const Vector3d& q, const std::vector<ClutterBox>& clutter) const {
    for (const ClutterBox& box : clutter) {
      if ((box.center - q).head<2>().norm() < footprint_radius(box) + s_.person_radius + 0.1 &&
          std::abs(box.center.z() - box.half_size.z() - q.z()) < 1.0) {
        return true;
      }
    }
    return false;
  }

  const CasterMesh& bim_part_;
  const std::vector<SimLabel>& element_class_;
  const WorldSettings& s_;
  Rng& rng_;
  const RayCaster caster_;
  std::vector<std::uint32_t> floor_tri_;
  std::vector<double> cum_area_;
  double total_area_ = 0.0;
  std::vector<std::pair<Vector3d, Vector3d>> door_boxes_;
  std::array<RayHit, kDirs> around_;
};

}  // namespace

World::World(const bim::BimMesh& mesh, const WorldSettings& settings)
    : bim_(std::make_shared<bim::BimMesh>(mesh)), settings_(settings) {
  const WorldSettings& s = settings_;
  check_world_inputs(mesh, s);

  element_class_.resize(mesh.elements.size());
  for (std::size_t e = 0; e < mesh.elements.size(); ++e) element_class_[e] = sim_class_of_type(mesh.elements[e].type);
  Rng rng(s.seed);
  AsBuiltMotions motions = draw_as_built_motions(mesh, s, rng);
  deviation_ = std::move(motions.deviation);

  CasterMesh built = as_built_triangles(mesh, motions);
  caster_to_bim_triangle_ = std::move(built.bim_triangle);
  num_caster_bim_triangles_ = static_cast<std::uint32_t>(built.triangles.size());

  const bool want_clutter = s.clutter > 0.0 || s.num_people > 0;
  if (want_clutter && !built.triangles.empty()) {
    ClutterPlacer placer(mesh, built, element_class_, s, rng);
    clutter_ = placer.furniture(static_cast<std::size_t>(std::llround(s.clutter * placer.floor_area() / 10.0)));
    people_ = placer.people(clutter_);
  }

  for (const ClutterBox& box : clutter_) {
    append_box(box, built.vertices, built.triangles);
    for (int j = 0; j < 12; ++j) built.tri_element.push_back(-1);
  }
  caster_ = std::make_shared<const RayCaster>(std::move(built.vertices), std::move(built.triangles),
                                              std::move(built.tri_element), s.caster);
}

RayHit World::cast(const Vector3d& origin, const Vector3d& unit_dir, double t_max, double time) const {
  RayHit hit = caster_->cast(origin, unit_dir, t_max);
  const auto num_bim = static_cast<std::uint32_t>(bim_->triangles.size());
  if (hit.hit()) {
    if (hit.triangle < num_caster_bim_triangles_) {
      hit.triangle = caster_to_bim_triangle_[hit.triangle];
    } else {
      hit.triangle = num_bim + (hit.triangle - num_caster_bim_triangles_);
      hit.element = -1;
    }
  }
  if (people_.empty() || !origin.allFinite() || !unit_dir.allFinite()) return hit;
  double best = std::min(hit.range, t_max);
  const auto first_person = static_cast<std::uint32_t>(num_bim + 12 * clutter_.size());
  for (std::size_t i = 0; i < people_.size(); ++i) {
    const Person& person = people_[i];
    const Vector3d f = person.position(time);
    const double r = person.radius;
    const double z0 = f.z(), z1 = f.z() + person.height;
    const double px = origin.x() - f.x(), py = origin.y() - f.y();
    const double c = px * px + py * py - r * r;
    if (c <= 0.0 && origin.z() >= z0 && origin.z() <= z1) continue;  // origin inside them: ignore them
    const double a = unit_dir.x() * unit_dir.x() + unit_dir.y() * unit_dir.y();
    const double b = px * unit_dir.x() + py * unit_dir.y();
    double t_hit = kInf;
    Vector3d n = Vector3d::Zero();
    if (a > 0.0) {
      const double disc = b * b - a * c;
      if (disc >= 0.0) {
        const double t = (-b - std::sqrt(disc)) / a;
        const double z = origin.z() + t * unit_dir.z();
        if (t > 0.0 && z >= z0 && z <= z1) {
          t_hit = t;
          n = Vector3d(px + t * unit_dir.x(), py + t * unit_dir.y(), 0.0) / r;
        }
      }
    }
    if (unit_dir.z() < 0.0 && origin.z() > z1) {  // the head (top cap) from above
      const double t = (z1 - origin.z()) / unit_dir.z();
      const double qx = px + t * unit_dir.x(), qy = py + t * unit_dir.y();
      if (t > 0.0 && t < t_hit && qx * qx + qy * qy <= r * r) {
        t_hit = t;
        n = Vector3d::UnitZ();
      }
    }
    if (t_hit < best) {
      best = t_hit;
      hit.range = t_hit;
      hit.triangle = first_person + static_cast<std::uint32_t>(i);
      hit.element = -1;
      hit.normal = n;
    }
  }
  return hit;
}

SimLabel World::label_of(const RayHit& hit) const {
  if (!hit.hit()) return kSimOther;
  if (hit.element < 0) {
    return hit.triangle >= bim_->triangles.size() ? kSimClutter : kSimOther;
  }
  const SimLabel cls = element_class_[static_cast<std::size_t>(hit.element)];
  if (cls == kSimGround) return hit.normal.z() > 0.7 ? kSimGround : kSimOtherElement;
  return cls;
}

}  // namespace plumb::sim
