// SPDX-License-Identifier: BSD-3-Clause
// Links plumb::bim: the generated demo office parsed as IFC and meshed.
#include <cstdio>

#include <plumb/bim/demo_building.hpp>
#include <plumb/bim/ifc.hpp>
#include <plumb/bim/mesh.hpp>

int main() {
  const plumb::bim::DemoBuildingResult demo = plumb::bim::make_demo_building();
  const plumb::bim::BimMesh mesh = plumb::bim::build_mesh(plumb::bim::parse_ifc(demo.ifc, "demo.ifc"));
  const bool ok = mesh.elements.size() >= demo.num_walls + demo.num_slabs && !mesh.vertices.empty();
  std::printf("plumb::bim: demo office, %zu elements meshed %s\n", mesh.elements.size(), ok ? "ok" : "FAILED");
  return ok ? 0 : 1;
}
