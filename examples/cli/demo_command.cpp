// SPDX-License-Identifier: BSD-3-Clause
// `plumb demo [-o DIR] [--length M] [--loops N] [--seed S] [--threads N] [--surveyed-start] [--overwrite]
// [--json]`: the whole product on the built-in sample. Writes the procedural demo office (IFC4), simulates a robot driving
// two loops through it (rfans32 LiDAR, wheel encoders, IMU, as-built deviations, furniture, people),
// localizes the first frame in the model (BimLocalizer, no hint; --surveyed-start starts at the
// true pose instead), runs the BIM-corrected odometry with the as-built estimate (as `plumb run
// --as-built`) and prints the error table of Liu et al. 2022, Table 2 (wheel odometry, LiDAR without
// BIM, BIM-corrected) against the exact ground truth, and the elements that deviate from the model.
// DIR receives demo_office.ifc, dump/ (the frame dump) and run/ (what `plumb run` writes). A DIR that
// an earlier `plumb demo` filled is replaced; one holding anything else is refused unless --overwrite (OutputDir).

#include <chrono>
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>
#include <string>
#include <thread>

#include <CLI/CLI.hpp>

#include "cli_support.hpp"
#include "registry.hpp"
#include "run_output.hpp"
#include "plumb/app/deviation_files.hpp"
#include "plumb/app/simulate.hpp"
#include "plumb/bim/demo_building.hpp"
#include "plumb/bim/ifc.hpp"
#include "plumb/core/clock.hpp"
#include "plumb/core/error.hpp"
#include "plumb/core/parallel.hpp"
#include "plumb/sim/scenario.hpp"

namespace plumb::cli {
namespace {

struct DemoCommandOptions {
  std::string out_dir = "plumb_demo";
  double length = 40.0;
  int loops = 2;
  std::uint64_t seed = 1;
  int threads = 0;
  bool surveyed_start = false;
  bool json = false;
  bool overwrite = false;
};

void run_demo(const DemoCommandOptions& o) {
  const auto t0 = std::chrono::steady_clock::now();
  // Checked before any work; each part is staged and moved into place when it is complete. The
  // dump and run directories follow the same rule inside DIR (their own files only).
  OutputDir top(o.out_dir, "demo", {"demo_office.ifc"}, o.overwrite, true, {"dump", "run"});
  const std::string model_path = top.staging() + "/demo_office.ifc";
  OutputDir dump_out(o.out_dir + "/dump", "simulate", frame_dump_names(), o.overwrite, true);
  OutputDir run_out(o.out_dir + "/run", "run", run_output_names(), o.overwrite, true);
  const std::string dump_dir = dump_out.staging();
  const std::string run_dir = o.out_dir + "/run";
  const int threads = resolve_thread_count(o.threads);
  auto say = [&](const std::string& text) {
    if (!o.json) std::printf("[%5.1f s] %s\n", seconds_since(t0), text.c_str());
    std::fflush(stdout);
  };

  bim::DemoBuildingSettings building;
  building.file_name = "demo_office.ifc";
  const bim::DemoBuildingResult b = bim::write_demo_building(model_path, building);
  say("wrote " + o.out_dir + "/demo_office.ifc (" + std::to_string(b.num_walls) + " walls, " + std::to_string(b.num_doors) +
      " doors, " + std::to_string(b.num_windows) + " windows)");
  const bim::BimMesh mesh = bim::build_mesh(bim::read_ifc(model_path), bim::mesh_settings_with_spaces());

  sim::ScenarioSettings s = sim::scenario_defaults(sim::ScenarioKind::kIndoor);
  s.seed = o.seed;
  s.loops = o.loops;
  s.length = o.length;
  s.num_threads = threads;
  SimulateDumpSettings ds;
  ds.dump.overwrite = false;  // the staging directory is new
  ds.model_name = "demo_office.ifc";
  if (!o.json) ds.progress = terminal_progress("simulate");
  const sim::ScenarioResult sr = simulate_to_dump(mesh, dump_dir, s, ds);
  char line[256];
  std::snprintf(line, sizeof(line), "simulated %zu %s frames, %.1f m driven in %.1f s of robot time -> %s",
                sr.num_frames, s.lidar.name.c_str(), sr.path_length, sr.duration, dump_out.dir().c_str());
  say(line);

  const io::FrameDumpReader dump(dump_dir);
  RunSettings rs;
  rs.odometry.threads = threads;
  rs.odometry.refresh_threads = threads;
  rs.localizer.threads = threads;
  // The first frame is found in the model without any hint (BimLocalizer), unless the operator
  // gives the surveyed start pose.
  if (o.surveyed_start) rs.initial_pose = dump.ground_truth().poses.front();
  // The building as built is estimated while driving: the odometry registers to it, and the run
  // reports the elements that deviate from the model.
  rs.odometry.estimate_as_built = true;
  if (!o.json) rs.progress = terminal_progress("plumb run");
  const RunReport r = run_bim_odometry(dump, mesh, rs);
  print_warnings(r.warnings);
  const nlohmann::json j = run_report_json(r);
  write_run_outputs(r, j, mesh, dump, run_out.staging(),
                    "plumb demo: demo office, " + std::to_string(sr.num_frames) + " frames", "demo_office.ifc");
  // All three parts at the end, so that a failure leaves the previous demo as it was.
  dump_out.commit();
  run_out.commit();
  top.commit();
  PLUMB_CHECK(!r.partial, "plumb demo: the run stopped at " << r.error << "; partial results in " << run_dir);
  if (o.json) {
    nlohmann::json all = j;
    all["simulation"] = {{"frames", sr.num_frames}, {"path_length", sr.path_length}, {"seconds", sr.wall_seconds}};
    all["as_built"] = deviation_summary(r.deviations, r.deviation_tolerance);
    all["seconds"] = seconds_since(t0);
    std::cout << all.dump(2) << '\n';
    return;
  }
  say("BIM-corrected odometry done");
  print_run_summary(r);
  std::printf("as built: %s\n", deviation_summary(r.deviations, r.deviation_tolerance).c_str());
  std::printf("wrote %s/{wheel,lidar,bim}.tum, report.json, trajectory.svg (open it in a browser)\n", run_dir.c_str());
  std::printf("wrote %s/deviations.{json,csv}, deviations.svg (a browser) and deviations.bcf (a BCF viewer)\n",
              run_dir.c_str());
  std::printf("demo done in %.1f s\n", seconds_since(t0));
}

}  // namespace

void register_demo_command(CLI::App& app) {
  auto o = std::make_shared<DemoCommandOptions>();
  CLI::App* cmd = app.add_subcommand(
      "demo", "The whole job on the built-in sample: demo office -> simulated robot -> BIM-corrected odometry -> Table 2");
  cmd->add_option("-o,--output", o->out_dir, "Output directory")->capture_default_str();
  cmd->add_option("--length", o->length, "Metres driven")->check(finite_number(1.0, 10000.0))->capture_default_str();
  cmd->add_option("--loops", o->loops, "Times the route is driven (the length stops it earlier)")
      ->check(finite_number(1, 100))
      ->capture_default_str();
  cmd->add_option("--seed", o->seed, "Seed of the simulation")->check(non_negative_number())->capture_default_str();
  cmd->add_option("--threads", o->threads, "Threads of the simulator and the odometry (0 = every core; the same results for any count)")->check(finite_number(0, 256));
  cmd->add_flag("--surveyed-start", o->surveyed_start,
                "Start at the true (surveyed) pose instead of localizing the first frame in the model");
  cmd->add_flag("--json", o->json, "Print the report as JSON");
  cmd->add_flag("--overwrite", o->overwrite,
                "Write into a directory that holds other files too (plumb's demo files in it are replaced)");
  cmd->callback([o]() { run_demo(*o); });
}

}  // namespace plumb::cli

PLUMB_CLI_COMMAND(demo, plumb::cli::register_demo_command);
