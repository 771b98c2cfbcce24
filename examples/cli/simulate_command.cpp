// SPDX-License-Identifier: BSD-3-Clause
// `plumb simulate MODEL -o DIR [--scenario indoor|site] [--lidar NAME|FILE.json] [--seed S] [--loops N]
// [--length M] [--clutter F] [--as-built-sigma M] [--as-built-deg D] [--imu mems|2deg_h] [--threads N] [--json]`:
// a robot drives through (or around) an IFC building; LiDAR frames, wheel encoders, wheel odometry,
// IMU and ground truth are written as a frame dump directory. DIR is checked before any work and the
// dump is staged inside it, then moved into place as a whole (OutputDir, run_output.hpp): a
// non-empty DIR is refused unless --overwrite, which replaces every dump file (no stale frame is left).

#include <unistd.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <iostream>
#include <memory>
#include <string>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "cli_support.hpp"
#include "registry.hpp"
#include "run_output.hpp"
#include "plumb/app/simulate.hpp"
#include "plumb/bim/ifc.hpp"
#include "plumb/bim/mesh.hpp"
#include "plumb/bim/sample.hpp"
#include "plumb/core/error.hpp"
#include "plumb/core/parallel.hpp"
#include "plumb/sim/scenario.hpp"

namespace plumb::cli {
namespace {

struct SimulateOptions {
  std::string model_path;
  std::string output_dir;
  std::string scenario = "indoor";
  std::string lidar;  // preset name or JSON file; empty = the scenario's default
  std::string imu;    // preset; empty = mems
  std::uint64_t seed = 1;
  int loops = 2;
  double length = 0.0;
  double clutter = 1.0;
  double as_built_sigma = 0.01;
  double as_built_deg = 0.2;
  std::string storey;  // name or index; empty = the largest walkable storey
  int threads = 0;
  bool overwrite = false;
  bool compressed = false;
  bool json = false;
};

/// A LiDAR from a JSON file: {"name", "elevations_deg" | "elevations_rad", "columns", "rate_hz",
/// "min_range", "max_range", "range_sigma", "dropout"}; or {"preset": NAME, ...overrides}.
void run_simulate(const SimulateOptions& o) {
  const sim::ScenarioKind kind = sim::scenario_kind_from_string(o.scenario);
  sim::ScenarioSettings s = sim::scenario_defaults(kind);
  if (!o.lidar.empty()) {
    const bool is_file = o.lidar.size() > 5 && o.lidar.substr(o.lidar.size() - 5) == ".json";
    s.lidar = is_file ? read_lidar_model(o.lidar) : sim::lidar_preset(o.lidar);
  }
  if (!o.imu.empty()) {
    const double rate = s.imu.rate_hz;
    s.imu = sim::imu_preset(o.imu);
    s.imu.rate_hz = rate;
  }
  s.seed = o.seed;
  s.loops = o.loops;
  s.length = o.length;
  s.world.clutter = o.clutter;
  s.world.as_built_sigma_m = o.as_built_sigma;
  s.world.as_built_sigma_rad = o.as_built_deg * M_PI / 180.0;
  s.num_threads = resolve_thread_count(o.threads);
  SimulateDumpSettings ds;
  ds.dump.overwrite = false;  // the staging directory is new
  if (o.compressed) ds.dump.encoding = io::PcdEncoding::kBinaryCompressed;
  ds.model_name = o.model_path.substr(o.model_path.find_last_of('/') + 1);
  const bool progress_bar = isatty(fileno(stderr)) != 0;
  if (progress_bar) {
    ds.progress = [](std::size_t done, std::size_t total) {
      const int width = 40;
      const int filled = total > 0 ? static_cast<int>(width * done / total) : width;
      std::fprintf(stderr, "\r[%s%s] %zu/%zu frames", std::string(static_cast<std::size_t>(filled), '#').c_str(),
                   std::string(static_cast<std::size_t>(width - filled), ' ').c_str(), done, total);
      if (done == total) std::fprintf(stderr, "\n");
      std::fflush(stderr);
    };
  }
  // Before the work: an unwritable or foreign output directory is found now.
  OutputDir out(o.output_dir, "simulate", frame_dump_names(), o.overwrite, false);
  const bim::BimMesh mesh = bim::build_mesh(bim::read_ifc(o.model_path), bim::mesh_settings_with_spaces());
  s.storey = o.storey.empty() ? -1 : bim::find_storey(mesh, o.storey);
  const sim::ScenarioResult r = simulate_to_dump(mesh, out.staging(), s, ds);
  out.commit();
  if (o.json) {
    nlohmann::json j = {{"scenario", o.scenario},
                        {"lidar", s.lidar.name},
                        {"frames", r.num_frames},
                        {"points", r.num_points},
                        {"path_length", r.path_length},
                        {"duration", r.duration},
                        {"seconds", r.wall_seconds},
                        {"storey", r.storey},
                        {"storey_name", r.storey_name},
                        {"seed", o.seed},
                        {"output", o.output_dir}};
    std::cout << j.dump(2) << '\n';
  } else {
    std::printf("%s: %zu frames (%s), %.1f m in %.1f s simulated on storey '%s', %.1f s wall -> %s\n",
                o.scenario.c_str(), r.num_frames, s.lidar.name.c_str(), r.path_length, r.duration,
                r.storey_name.c_str(), r.wall_seconds, o.output_dir.c_str());
  }
}

}  // namespace

void register_simulate_command(CLI::App& app) {
  auto opts = std::make_shared<SimulateOptions>();
  CLI::App* cmd = app.add_subcommand(
      "simulate", "Simulate a robot with LiDAR, wheel encoders and IMU in an IFC building; write a frame dump");
  cmd->add_option("model", opts->model_path, "IFC building model")->required()->check(CLI::ExistingFile);
  cmd->add_option("-o,--output", opts->output_dir, "Output frame dump directory")->required();
  cmd->add_option("--scenario", opts->scenario, "indoor (default) or site")
      ->check(CLI::IsMember({"indoor", "site"}));
  cmd->add_option("--lidar", opts->lidar,
                  "LiDAR preset (rfans32, vlp16, os1-64) or a JSON model file (default: rfans32 indoor, vlp16 site)");
  cmd->add_option("--imu", opts->imu, "IMU noise preset: mems (default), 2deg_h, ideal")
      ->check(CLI::IsMember({"mems", "2deg_h", "ideal"}));
  cmd->add_option("--seed", opts->seed, "Seed of everything random (default 1)")->check(non_negative_number());
  cmd->add_option("--loops", opts->loops, "Times the route is driven (default 2)")->check(finite_number(1, 1000));
  // Limits keep every run bounded: the robot gives up after 2 h of driving anyway (RobotSettings).
  cmd->add_option("--length", opts->length,
                  "Stop after this many metres along the route, at most 10000 (default: all loops)")
      ->check(finite_number(0.0, 10000.0));
  cmd->add_option("--storey", opts->storey,
                  "Indoor storey, by name or index (default: the largest storey with modelled floors)");
  cmd->add_option("--clutter", opts->clutter,
                  "Furniture density factor, 0 = none, at most 10 (1: about one piece per 10 m^2; default 1)")
      ->check(finite_number(0.0, sim::WorldSettings::kMaxClutter));
  cmd->add_option("--as-built-sigma", opts->as_built_sigma, "As-built element shift, std dev [m], at most 1 (default 0.01)")
      ->check(finite_number(0.0, 1.0));
  cmd->add_option("--as-built-deg", opts->as_built_deg,
                  "As-built element rotation about each axis, std dev [deg], at most 10 (default 0.2; 0 and "
                  "--as-built-sigma 0 = the exact model)")
      ->check(finite_number(0.0, 10.0));
  cmd->add_option("--threads", opts->threads, "Frames simulated in parallel (0 = every core, the default; the same output for any count)")
      ->check(finite_number(0, 256));
  cmd->add_flag("--compressed", opts->compressed, "Write PCD frames binary_compressed (LZF) instead of binary");
  cmd->add_flag("--overwrite", opts->overwrite,
                "Write into a non-empty directory: every frame dump file in it is replaced (other files are kept)");
  cmd->add_flag("--json", opts->json, "Print a JSON summary");
  cmd->callback([opts] { naming_inputs({opts->model_path, opts->lidar}, [&] { run_simulate(*opts); }); });
}

}  // namespace plumb::cli

PLUMB_CLI_COMMAND(simulate, plumb::cli::register_simulate_command);
