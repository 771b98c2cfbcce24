// SPDX-License-Identifier: BSD-3-Clause
// Links plumb::sim: a ray cast down from 1 m above the demo office's ground floor meets its slab.
#include <cmath>
#include <cstdio>

#include <plumb/bim/demo_building.hpp>
#include <plumb/bim/ifc.hpp>
#include <plumb/bim/mesh.hpp>
#include <plumb/sim/raycaster.hpp>

int main() {
  const plumb::bim::DemoBuildingResult demo = plumb::bim::make_demo_building();
  const plumb::bim::BimMesh mesh = plumb::bim::build_mesh(plumb::bim::parse_ifc(demo.ifc, "demo.ifc"));
  const plumb::sim::RayCaster caster(mesh);
  const plumb::bim::DemoSpace& room = demo.spaces.front();
  const plumb::Vector2d c = 0.5 * (room.min + room.max);
  const plumb::Vector3d origin = plumb::Vector3d(c.x(), c.y(), 1.0) - mesh.origin_offset;  // mesh frame
  const plumb::sim::RayHit hit = caster.cast(origin, -plumb::Vector3d::UnitZ());
  const bool ok = std::isfinite(hit.range) && hit.range > 0.5 && hit.range < 1.5 && hit.element >= 0;
  std::printf("plumb::sim: ray to the floor %s (%.3f m)\n", ok ? "ok" : "FAILED", hit.range);
  return ok ? 0 : 1;
}
