// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief The building as built for the simulator: the BIM's elements slightly displaced, windows
/// and doors letting rays through, furniture the model does not know and people walking.

#include <cstdint>
#include <limits>
#include <memory>
#include <vector>

#include "plumb/bim/mesh.hpp"
#include "plumb/core/types.hpp"
#include "plumb/sim/raycaster.hpp"

namespace plumb::sim {

/// @brief True class of a simulated return.
enum SimLabel : std::int32_t {
  kSimOther = 0,         ///< no return / unknown
  kSimGround = 1,        ///< upward faces of slabs, floor coverings, ramps, hit from above
  kSimWall = 2,          ///< IfcWall, IfcWallStandardCase, IfcWallElementedCase, IfcCurtainWall
  kSimOtherElement = 3,  ///< any other BIM element (and slab faces that are not floors)
  kSimClutter = 4,       ///< furniture boxes and people (not in the BIM)
};

/// @brief Settings of World.
struct WorldSettings {
  /// Largest `clutter`: one piece per m^2 is more than a floor holds, and placing costs
  /// attempts in proportion to the target count (World throws above it).
  static constexpr double kMaxClutter = 10.0;
  double as_built_sigma_m = 0.01;  ///< per-element random shift, each axis [m]
  double as_built_sigma_rad = 0.2 * 3.14159265358979323846 / 180.0;  ///< per-element rotation, each axis [rad]
  double clutter = 1.0;      ///< furniture density factor: about one box per 10 m^2 of floor; 0 = none; <= kMaxClutter
  int num_people = 2;        ///< people walking back and forth (0 = none)
  std::uint64_t seed = 1;    ///< deviations, clutter and people depend on this only
  int storey = -1;           ///< storey whose floors get clutter and people; -1 = all storeys
  double person_speed = 1.0;   ///< walking speed [m/s]
  double person_radius = 0.25; ///< people are vertical cylinders of this radius [m]
  double person_height = 1.75; ///< [m]
  RayCasterSettings caster;  ///< BVH of the as-built mesh
};

/// @brief A furniture box standing on a floor (oriented about z).
struct ClutterBox {
  Vector3d center = Vector3d::Zero();  ///< centre of the box [m], world (= BIM mesh) frame
  Vector3d half_size = Vector3d::Zero();  ///< half extents along the box axes [m]
  double yaw = 0.0;                    ///< rotation of the box axes about z [rad]
};

/// @brief A person walking back and forth between two floor points at constant speed.
struct Person {
  Vector3d a = Vector3d::Zero();  ///< one end of the walk, on the floor [m]
  Vector3d b = Vector3d::Zero();  ///< the other end [m]
  double phase = 0.0;             ///< time offset of the walk [s]
  double speed = 1.0;             ///< [m/s]
  double radius = 0.25;           ///< [m]
  double height = 1.75;           ///< [m]
  /// @brief Foot point (on the floor, axis of the cylinder) at `time` [s].
  Vector3d position(double time) const;
};

/// @brief The simulated building as built.
///
/// Built from the nominal BIM mesh: every element is moved by a small random rigid motion about its
/// bounding-box centre (as-built deviations); IfcWindow, IfcDoor, IfcOpeningElement and IfcSpace
/// triangles are left out (windows transmit, doors stand open); furniture boxes are placed on the
/// floors of rooms against walls, away from doors and from the middle of free space; people walk
/// back and forth along free straight lines. Everything depends on the settings (seed) only.
/// @note cast() and label_of() are const and thread-safe.
class World {
 public:
  /// @throws plumb::Error on bad settings or a mesh the ray caster rejects.
  explicit World(const bim::BimMesh& mesh, const WorldSettings& settings = {});

  /// @brief First hit of the ray at `time` [s] (people move with time).
  /// RayHit::triangle is a BIM triangle index (< bim().num_triangles()) for a BIM hit, and
  /// bim().num_triangles() + 12 k + j for triangle j of clutter box k, and
  /// bim().num_triangles() + 12 clutter().size() + p for person p. RayHit::element is the BIM
  /// element index, -1 for clutter and people.
  RayHit cast(const Vector3d& origin, const Vector3d& unit_dir,
              double t_max = std::numeric_limits<double>::infinity(), double time = 0.0) const;

  /// @brief True class of a hit returned by cast() (kSimOther for a miss).
  SimLabel label_of(const RayHit& hit) const;

  /// @brief The nominal model (as given).
  const bim::BimMesh& bim() const { return *bim_; }
  /// @brief Clutter boxes (for route planning: obstacles the BIM does not know).
  const std::vector<ClutterBox>& clutter() const { return clutter_; }
  /// @brief People (their positions over time: Person::position).
  const std::vector<Person>& people() const { return people_; }
  /// @brief Obstacles not in the BIM as boxes: the clutter boxes (people are not included).
  const std::vector<ClutterBox>& obstacles() const { return clutter_; }
  /// @brief As-built pose of element e: its points are at T * nominal point.
  const Eigen::Isometry3d& element_deviation(std::size_t e) const { return deviation_.at(e); }
  /// @brief The static ray caster (as-built BIM + clutter, no people).
  const RayCaster& static_caster() const { return *caster_; }
  /// @brief Label of every BIM element by its type (ground-capable elements give kSimGround here;
  /// label_of() refines by the face hit).
  SimLabel element_class(std::size_t e) const { return element_class_.at(e); }
  const WorldSettings& settings() const { return settings_; }

 private:
  std::shared_ptr<const bim::BimMesh> bim_;
  WorldSettings settings_;
  std::vector<Eigen::Isometry3d> deviation_;
  std::vector<SimLabel> element_class_;
  std::vector<ClutterBox> clutter_;
  std::vector<Person> people_;
  std::vector<std::uint32_t> caster_to_bim_triangle_;  ///< caster triangle -> BIM triangle (BIM part)
  std::uint32_t num_caster_bim_triangles_ = 0;
  std::shared_ptr<const RayCaster> caster_;
};

/// @brief Class of an IFC type as the simulator labels it (kSimGround for floor-capable types).
SimLabel sim_class_of_type(const std::string& ifc_type);

/// @brief True for types that transmit or are absent in the simulated world (IfcWindow, IfcDoor,
/// IfcOpeningElement, IfcSpace).
bool sim_type_is_transparent(const std::string& ifc_type);

}  // namespace plumb::sim
