// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/bim/sample.hpp"

#include <cmath>
#include <sstream>

#include "plumb/core/error.hpp"
#include "plumb/core/rng.hpp"

namespace plumb::bim {

namespace {
std::string upper(std::string s) {
  for (char& c : s) {
    if (c >= 'a' && c <= 'z') c = static_cast<char>(c - 'a' + 'A');
  }
  return s;
}

std::vector<bool> selection(const BimMesh& mesh, const ElementFilter& filter) {
  std::vector<bool> keep(mesh.elements.size());
  for (std::size_t i = 0; i < keep.size(); ++i) keep[i] = element_selected(mesh, i, filter);
  return keep;
}
}  // namespace

bool element_selected(const BimMesh& mesh, std::size_t index, const ElementFilter& filter) {
  PLUMB_CHECK(index < mesh.elements.size(), "element_selected: index " << index << " out of range");
  const BimElement& e = mesh.elements[index];
  if (filter.storey >= 0 && e.storey != filter.storey) return false;
  if (filter.types.empty()) return true;
  const std::string t = upper(e.type);
  for (const auto& want : filter.types) {
    if (upper(want) == t) return true;
  }
  return false;
}

int find_storey(const BimMesh& mesh, const std::string& name_or_index) {
  for (std::size_t i = 0; i < mesh.storeys.size(); ++i) {
    if (mesh.storeys[i].name == name_or_index) return static_cast<int>(i);
  }
  for (std::size_t i = 0; i < mesh.storeys.size(); ++i) {
    if (upper(mesh.storeys[i].name) == upper(name_or_index)) return static_cast<int>(i);
  }
  if (!name_or_index.empty() && name_or_index.find_first_not_of("0123456789") == std::string::npos &&
      name_or_index.size() < 9) {
    const int k = std::stoi(name_or_index);
    if (k < static_cast<int>(mesh.storeys.size())) return k;
  }
  std::ostringstream os;
  for (std::size_t i = 0; i < mesh.storeys.size(); ++i) os << (i ? ", " : "") << i << "='" << mesh.storeys[i].name << "'";
  PLUMB_THROW("find_storey: no storey '" << name_or_index << "' (storeys: " << os.str() << ")");
}

PointCloud sample_surface(const BimMesh& mesh, const SurfaceSampleSettings& settings) {
  PLUMB_CHECK(std::isfinite(settings.spacing) && settings.spacing > 0.0,
              "sample_surface: spacing must be positive, got " << settings.spacing);
  PLUMB_CHECK(mesh.triangle_element.size() == mesh.triangles.size(), "sample_surface: inconsistent mesh");
  const std::vector<bool> keep = selection(mesh, settings.filter);
  const double density = 1.0 / (settings.spacing * settings.spacing);
  // Expected count first, so that memory is reserved once.
  double expected = 0.0;
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    if (!keep[static_cast<std::size_t>(mesh.triangle_element[t])]) continue;
    const auto& tri = mesh.triangles[t];
    expected += 0.5 * (mesh.vertices[tri[1]] - mesh.vertices[tri[0]]).cross(mesh.vertices[tri[2]] - mesh.vertices[tri[0]]).norm();
  }
  expected *= density;
  PLUMB_CHECK(expected < 5e8, "sample_surface: spacing " << settings.spacing << " m would give " << expected << " points");
  PointCloud cloud;
  const auto reserve = static_cast<std::size_t>(expected * 1.01 + 16);
  cloud.points.reserve(reserve);
  cloud.normals.reserve(reserve);
  cloud.labels.reserve(reserve);
  Rng rng(settings.seed);
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    const std::int32_t el = mesh.triangle_element[t];
    if (!keep[static_cast<std::size_t>(el)]) continue;
    const auto& tri = mesh.triangles[t];
    const Vector3d& a = mesh.vertices[tri[0]];
    const Vector3d ab = mesh.vertices[tri[1]] - a;
    const Vector3d ac = mesh.vertices[tri[2]] - a;
    const Vector3d cr = ab.cross(ac);
    const double area2 = cr.norm();
    if (!(area2 > 0.0)) continue;
    const double n_exp = 0.5 * area2 * density;
    auto count = static_cast<std::size_t>(n_exp);
    if (rng.uniform() < n_exp - static_cast<double>(count)) ++count;
    const Vector3f normal = (cr / area2).cast<float>();
    for (std::size_t k = 0; k < count; ++k) {
      double u = rng.uniform();
      double v = rng.uniform();
      if (u + v > 1.0) {
        u = 1.0 - u;
        v = 1.0 - v;
      }
      cloud.points.push_back((a + u * ab + v * ac).cast<float>());
      cloud.normals.push_back(normal);
      cloud.labels.push_back(el);
    }
  }
  return cloud;
}

FloorPlan slice_floor_plan(const BimMesh& mesh, double height, const FloorPlanSettings& settings) {
  PLUMB_CHECK(std::isfinite(height), "slice_floor_plan: height must be finite");
  PLUMB_CHECK(std::isfinite(settings.point_spacing) && settings.point_spacing > 0.0,
              "slice_floor_plan: point_spacing must be positive, got " << settings.point_spacing);
  const std::vector<bool> keep = selection(mesh, settings.filter);
  FloorPlan plan;
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    const std::int32_t el = mesh.triangle_element[t];
    if (!keep[static_cast<std::size_t>(el)]) continue;
    const auto& tri = mesh.triangles[t];
    Vector3d p[3];
    double d[3];
    for (int k = 0; k < 3; ++k) {
      p[k] = mesh.vertices[tri[static_cast<std::size_t>(k)]];
      d[k] = p[k].z() - height;
    }
    // Vertices on the plane count as above (so a shared edge is cut once).
    const bool above[3] = {d[0] >= 0, d[1] >= 0, d[2] >= 0};
    if (above[0] == above[1] && above[1] == above[2]) continue;
    Vector2d ends[2];
    int n = 0;
    for (int k = 0; k < 3 && n < 2; ++k) {
      const int j = (k + 1) % 3;
      if (above[k] == above[j]) continue;
      const double s = d[k] / (d[k] - d[j]);
      ends[n++] = (p[k] + s * (p[j] - p[k])).head<2>();
    }
    if (n != 2) continue;
    plan.segment_start.push_back(ends[0]);
    plan.segment_end.push_back(ends[1]);
    plan.segment_element.push_back(el);
    const double len = (ends[1] - ends[0]).norm();
    const auto steps = static_cast<std::size_t>(std::floor(len / settings.point_spacing));
    for (std::size_t k = 0; k <= steps; ++k) {
      const double s = len > 0 ? (static_cast<double>(k) + 0.5) * settings.point_spacing / len : 0.0;
      if (s > 1.0) break;
      plan.points.push_back((ends[0] + s * (ends[1] - ends[0])).cast<float>());
      plan.point_element.push_back(el);
    }
  }
  return plan;
}

}  // namespace plumb::bim
