// SPDX-License-Identifier: BSD-3-Clause
// `plumb make-demo-building -o FILE.ifc`: the procedural office floor `plumb demo` simulates in,
// written as IFC4 by plumb's own writer (see plumb/bim/demo_building.hpp).

#include <cstdio>
#include <iostream>
#include <memory>
#include <string>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "plumb/bim/demo_building.hpp"
#include "cli_support.hpp"
#include "registry.hpp"

namespace plumb::cli {
namespace {

struct DemoOptions {
  std::string output;
  bim::DemoBuildingSettings settings;
  bool json = false;
};

std::string base_name(const std::string& path) {
  const std::size_t slash = path.find_last_of('/');
  return slash == std::string::npos ? path : path.substr(slash + 1);
}

void run_make_demo_building(DemoOptions o) {
  o.settings.file_name = base_name(o.output);
  const bim::DemoBuildingResult r = bim::write_demo_building(o.output, o.settings);
  double room_area = 0.0;
  for (const auto& s : r.spaces) room_area += s.area();
  if (o.json) {
    nlohmann::json spaces = nlohmann::json::array();
    for (const auto& s : r.spaces) {
      spaces.push_back({{"name", s.name},
                        {"storey", s.storey},
                        {"min", {s.min.x(), s.min.y()}},
                        {"max", {s.max.x(), s.max.y()}}});
    }
    const nlohmann::json j = {{"output", o.output},
                              {"bytes", r.ifc.size()},
                              {"storeys", o.settings.num_storeys},
                              {"walls", r.num_walls},
                              {"doors", r.num_doors},
                              {"windows", r.num_windows},
                              {"slabs", r.num_slabs},
                              {"columns", r.num_columns},
                              {"gross_floor_area", r.gross_floor_area},
                              {"space_area", room_area},
                              {"spaces", spaces}};
    std::cout << j.dump(2) << '\n';
  } else {
    std::printf("%s: %d storey(s), %zu spaces, %zu walls, %zu doors, %zu windows, %zu slabs, %zu columns; "
                "%.1f m^2 gross, %.1f m^2 in rooms and corridors\n",
                o.output.c_str(), o.settings.num_storeys, r.spaces.size(), r.num_walls, r.num_doors, r.num_windows,
                r.num_slabs, r.num_columns, r.gross_floor_area, room_area);
  }
}

}  // namespace

void register_make_demo_building_command(CLI::App& app) {
  auto o = std::make_shared<DemoOptions>();
  auto& s = o->settings;
  CLI::App* cmd = app.add_subcommand(
      "make-demo-building", "Write a procedural office floor (corridor, rooms, doors, windows) as an IFC4 file");
  cmd->add_option("-o,--output", o->output, "Output IFC file")->required();
  cmd->add_option("--length", s.length, "Outer length along x [m]")->check(positive_number(1000.0))->capture_default_str();
  cmd->add_option("--width", s.width, "Outer width along y [m]")->check(positive_number(1000.0))->capture_default_str();
  cmd->add_option("--rooms", s.num_rooms, "Rooms per storey off the corridor")->check(finite_number(2, 1000))->capture_default_str();
  cmd->add_option("--storeys", s.num_storeys, "Storeys with the same plan")->check(finite_number(1, 100))->capture_default_str();
  cmd->add_option("--storey-height", s.storey_height, "Floor-to-floor height [m]")->check(positive_number(100.0))->capture_default_str();
  cmd->add_option("--corridor-width", s.corridor_width, "Clear corridor width [m]")->check(positive_number(100.0))->capture_default_str();
  cmd->add_option("--door-width", s.door_width, "Clear door width, >= 0.9 [m]")->check(finite_number(0.9, 100.0))->capture_default_str();
  cmd->add_option("--entrance-width", s.entrance_width, "Entrance at the west end of the corridor, 0 for none [m]")
      ->check(non_negative_number(100.0))
      ->capture_default_str();
  cmd->add_option("--column-size", s.column_size, "Square columns at wall junctions, 0 for none [m]")
      ->check(non_negative_number(100.0))
      ->capture_default_str();
  cmd->add_option("--seed", s.seed, "Room widths, door positions and GUIDs")
      ->check(non_negative_number())
      ->capture_default_str();
  cmd->add_option("--name", s.name, "Building and project name")->capture_default_str();
  cmd->add_flag("--json", o->json, "Print a JSON summary (counts, areas, room rectangles)");
  cmd->callback([o] { run_make_demo_building(*o); });
}

}  // namespace plumb::cli

PLUMB_CLI_COMMAND(make_demo_building, plumb::cli::register_make_demo_building_command);
