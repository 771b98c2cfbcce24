// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/bim/bim_cloud.hpp"

#include <algorithm>
#include <cctype>
#include <set>
#include <string>

#include "plumb/bim/sample.hpp"

namespace plumb::bim {

PointCloud sample_bim_cloud(const BimMesh& mesh, double spacing) {
  static const std::set<std::string> kInvisible = {"IFCDOOR", "IFCWINDOW", "IFCSPACE", "IFCOPENINGELEMENT",
                                                   "IFCFURNISHINGELEMENT", "IFCFURNITURE"};
  SurfaceSampleSettings ss;
  ss.spacing = spacing;
  std::set<std::string> types;
  for (const BimElement& e : mesh.elements) {
    std::string upper = e.type;
    std::transform(upper.begin(), upper.end(), upper.begin(), [](unsigned char c) { return std::toupper(c); });
    if (!kInvisible.count(upper) && e.num_triangles > 0) types.insert(e.type);
  }
  ss.filter.types.assign(types.begin(), types.end());
  return sample_surface(mesh, ss);
}

}  // namespace plumb::bim
