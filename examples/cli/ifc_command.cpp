// SPDX-License-Identifier: BSD-3-Clause
// `plumb ifcinfo MODEL` (parse + mesh summary) and `plumb ifc2cloud MODEL -o OUT` (BIM point cloud).

#include <chrono>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <map>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "cli_support.hpp"
#include "registry.hpp"
#include "plumb/bim/floor_plan.hpp"
#include "plumb/bim/mesh.hpp"
#include "plumb/bim/sample.hpp"
#include "plumb/core/error.hpp"
#include "plumb/io/cloud_io.hpp"
#include "plumb/io/input_file.hpp"

namespace plumb::cli {
namespace {

struct IfcOptions {
  std::string model;
  std::string output;
  double spacing = 0.05;
  std::uint64_t seed = 42;
  std::string types;
  std::string storey;
  std::string elements_out;
  bool json = false;
};

struct Loaded {
  bim::IfcModel model;
  bim::BimMesh mesh;
  double parse_seconds = 0.0;
  double mesh_seconds = 0.0;
};

/// `with_spaces`: also mesh the rooms (IfcSpace), which a floor plan may need and a cloud must not hold.
Loaded load(const std::string& path, bool with_spaces) {
  io::check_input_file(path);  // "is a directory" rather than the STEP parser's "not a STEP file"
  const auto t0 = std::chrono::steady_clock::now();
  bim::IfcModel model = bim::read_ifc(path);
  const auto t1 = std::chrono::steady_clock::now();
  bim::BimMeshSettings mesh_settings;
  mesh_settings.include_spaces = with_spaces;
  bim::BimMesh mesh = bim::build_mesh(model, mesh_settings);
  const auto t2 = std::chrono::steady_clock::now();
  Loaded l{std::move(model), std::move(mesh), 0.0, 0.0};
  l.parse_seconds = std::chrono::duration<double>(t1 - t0).count();
  l.mesh_seconds = std::chrono::duration<double>(t2 - t1).count();
  return l;
}

nlohmann::json vec_json(const Vector3d& v) { return {v.x(), v.y(), v.z()}; }

void run_ifcinfo(const IfcOptions& o) {
  const Loaded l = load(o.model, true);
  const auto& m = l.mesh;
  std::map<std::string, std::pair<std::size_t, std::size_t>> counts;  // type -> (with, without) geometry
  for (const auto& e : m.elements) {
    auto& c = counts[e.type];
    (e.num_triangles > 0 ? c.first : c.second) += 1;
  }
  Vector3d lo, hi;
  m.bounds(lo, hi);
  // The floor of every storey, as simulate and the localizer will find it (none without geometry).
  std::vector<bim::StoreyFloor> floors;
  if (m.num_triangles() > 0 && !m.storeys.empty()) floors = bim::storey_floors(m);
  std::vector<std::string> warnings = l.model.warnings;
  warnings.insert(warnings.end(), m.warnings.begin(), m.warnings.end());
  if (o.json) {
    nlohmann::json j;
    j["file"] = o.model;
    j["schema"] = l.model.step.schema_name();
    j["length_unit"] = l.model.units.length_name;
    j["length_to_m"] = l.model.units.length_to_m;
    j["instances"] = l.model.step.size();
    nlohmann::json types = nlohmann::json::object();
    for (const auto& [t, c] : counts) types[t] = {{"with_geometry", c.first}, {"without_geometry", c.second}};
    j["elements"] = types;
    nlohmann::json storeys = nlohmann::json::array();
    for (std::size_t i = 0; i < m.storeys.size(); ++i) {
      nlohmann::json st = {{"name", m.storeys[i].name}, {"elevation", m.storeys[i].elevation}};
      if (i < floors.size()) {
        st["walkable_area"] = floors[i].free_area;
        st["floor_source"] = bim::to_string(floors[i].source);
      }
      storeys.push_back(st);
    }
    j["storeys"] = storeys;
    j["triangles"] = m.num_triangles();
    j["origin_offset"] = vec_json(m.origin_offset);
    if (!m.vertices.empty()) j["bbox"] = {vec_json(lo + m.origin_offset), vec_json(hi + m.origin_offset)};
    j["warnings"] = warnings;
    j["parse_seconds"] = l.parse_seconds;
    j["mesh_seconds"] = l.mesh_seconds;
    std::cout << j.dump(2) << '\n';
    return;
  }
  std::printf("%s\n  schema %s, length unit %s (%g m), %zu instances\n", o.model.c_str(),
              l.model.step.schema_name().c_str(), l.model.units.length_name.c_str(), l.model.units.length_to_m,
              l.model.step.size());
  std::printf("  %-28s %8s %8s\n", "type", "geometry", "none");
  for (const auto& [t, c] : counts) std::printf("  %-28s %8zu %8zu\n", t.c_str(), c.first, c.second);
  for (std::size_t i = 0; i < m.storeys.size(); ++i) {
    std::printf("  storey %zu '%s' at %.3f m", i, m.storeys[i].name.c_str(), m.storeys[i].elevation);
    if (i < floors.size()) {
      std::printf(": %.1f m^2 walkable (%s)", floors[i].free_area,
                  floors[i].source == bim::FloorSource::kWalls    ? "enclosed by walls, no floor modelled"
                  : floors[i].source == bim::FloorSource::kSpaces ? "room footprints (IfcSpace), floor not modelled"
                                                                  : "floor surfaces");
    }
    std::printf("\n");
  }
  std::printf("  %zu triangles", m.num_triangles());
  if (!m.vertices.empty()) {
    const Vector3d a = lo + m.origin_offset, b = hi + m.origin_offset;
    std::printf(", bbox [%.3f %.3f %.3f] .. [%.3f %.3f %.3f] m", a.x(), a.y(), a.z(), b.x(), b.y(), b.z());
  }
  std::printf("\n  origin offset [%.1f %.1f %.1f] m\n", m.origin_offset.x(), m.origin_offset.y(), m.origin_offset.z());
  std::printf("  parse %.1f ms, mesh %.1f ms\n", 1e3 * l.parse_seconds, 1e3 * l.mesh_seconds);
  for (const auto& w : warnings) std::printf("  warning: %s\n", w.c_str());
}

std::vector<std::string> split_list(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream ss(s);
  std::string item;
  while (std::getline(ss, item, ',')) {
    if (!item.empty()) out.push_back(item);
  }
  return out;
}

void run_ifc2cloud(const IfcOptions& o) {
  const Loaded l = load(o.model, false);
  const auto& m = l.mesh;
  bim::SurfaceSampleSettings s;
  s.spacing = o.spacing;
  s.seed = o.seed;
  s.filter.types = split_list(o.types);
  if (!o.storey.empty()) s.filter.storey = bim::find_storey(m, o.storey);
  const auto t0 = std::chrono::steady_clock::now();
  const PointCloud cloud = bim::sample_surface(m, s);
  const double sample_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  PLUMB_CHECK(!cloud.empty(), "ifc2cloud: no points sampled from " << o.model << " (filters too strict?)");
  io::write_cloud(o.output, cloud);
  if (!o.elements_out.empty()) {
    nlohmann::json arr = nlohmann::json::array();
    for (std::size_t i = 0; i < m.elements.size(); ++i) {
      const auto& e = m.elements[i];
      if (e.num_triangles == 0 || !bim::element_selected(m, i, s.filter)) continue;
      arr.push_back({{"id", e.express_id},
                     {"global_id", e.global_id},
                     {"type", e.type},
                     {"name", e.name},
                     {"storey", e.storey >= 0 ? m.storeys[static_cast<std::size_t>(e.storey)].name : ""},
                     {"label", i},
                     {"triangles", e.num_triangles},
                     {"bbox", {vec_json(e.bbox_min + m.origin_offset), vec_json(e.bbox_max + m.origin_offset)}}});
    }
    std::ofstream out(o.elements_out);
    PLUMB_CHECK(out.good(), o.elements_out << ": cannot open for writing");
    out << arr.dump(1) << '\n';
    PLUMB_CHECK(out.good(), o.elements_out << ": write failed");
  }
  if (o.json) {
    nlohmann::json j;
    j["file"] = o.model;
    j["output"] = o.output;
    j["points"] = cloud.size();
    j["spacing"] = o.spacing;
    j["origin_offset"] = vec_json(m.origin_offset);
    j["parse_seconds"] = l.parse_seconds;
    j["mesh_seconds"] = l.mesh_seconds;
    j["sample_seconds"] = sample_seconds;
    j["warnings"] = m.warnings;
    std::cout << j.dump(2) << '\n';
  } else {
    std::printf("%s: %zu points at %.3f m spacing -> %s (origin offset [%.1f %.1f %.1f] m)\n", o.model.c_str(),
                cloud.size(), o.spacing, o.output.c_str(), m.origin_offset.x(), m.origin_offset.y(),
                m.origin_offset.z());
  }
}

}  // namespace

void register_ifc_commands(CLI::App& app) {
  auto info = std::make_shared<IfcOptions>();
  CLI::App* ci = app.add_subcommand("ifcinfo", "Parse and mesh an IFC model; print schema, units, element counts");
  ci->add_option("MODEL", info->model, "IFC file (IFC2X3 / IFC4)")->required();
  ci->add_flag("--json", info->json, "Print one JSON object");
  ci->callback([info]() { naming_inputs({info->model}, [&] { run_ifcinfo(*info); }); });

  auto cloud = std::make_shared<IfcOptions>();
  CLI::App* cc = app.add_subcommand("ifc2cloud", "Sample an IFC model's surfaces into a labelled point cloud");
  cc->add_option("MODEL", cloud->model, "IFC file (IFC2X3 / IFC4)")->required();
  cc->add_option("-o,--output", cloud->output, "Output cloud (.ply or .pcd); labels = element index")->required();
  cc->add_option("--spacing", cloud->spacing, "Mean point spacing [m]")
      ->check(positive_number(1000.0))
      ->capture_default_str();
  cc->add_option("--seed", cloud->seed, "Random seed")->check(non_negative_number())->capture_default_str();
  cc->add_option("--types", cloud->types, "Comma-separated IFC types to keep, e.g. IfcWall,IfcSlab");
  cc->add_option("--storey", cloud->storey, "Storey name or index to keep");
  cc->add_option("--elements-out", cloud->elements_out, "Write the element table (JSON) here");
  cc->add_flag("--json", cloud->json, "Print one JSON object");
  cc->callback([cloud]() { naming_inputs({cloud->model}, [&] { run_ifc2cloud(*cloud); }); });
}

}  // namespace plumb::cli

PLUMB_CLI_COMMAND(ifc, plumb::cli::register_ifc_commands);
