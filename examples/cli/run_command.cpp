// SPDX-License-Identifier: BSD-3-Clause
// `plumb run DIR --bim MODEL.ifc -o OUT [--json]`: the BIM-corrected odometry over a frame dump.
// Writes OUT/wheel.tum, OUT/lidar.tum, OUT/bim.tum (BIM frame, frame stamps), OUT/report.json and
// OUT/trajectory.svg (with --as-built also OUT/deviations.{json,csv,svg,bcf}); with ground truth in
// the dump, prints the error table of Liu et al. 2022, Table 2.
// OUT is checked before any work and the set is replaced as a whole (OutputDir, run_output.hpp): a
// directory with files plumb did not write is refused unless --overwrite. A frame failing after
// others were processed still writes the set, report.json saying "partial": true, and exits 1.
// Exit code 3 (kExitJobFailed) when no frame after the first was matched by the front end and no
// BIM anchor after the first frame was accepted: the set is written, but it holds nothing measured by the LiDAR.

#include <iostream>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "cli_support.hpp"
#include "registry.hpp"
#include "run_output.hpp"
#include "plumb/app/deviation_files.hpp"
#include "plumb/bim/ifc.hpp"
#include "plumb/core/error.hpp"
#include "plumb/core/parallel.hpp"
#include "plumb/core/types.hpp"

namespace plumb::cli {
namespace {

struct RunOptions {
  std::string dump_dir;
  std::string model;
  std::string out_dir;
  bool json = false;
  bool no_bim = false;
  bool as_built = false;
  bool refine = false;
  double tolerance = 0.02;
  double as_built_sigma = 0.01;
  double as_built_deg = 0.2;
  bool gt_start = false;
  bool overwrite = false;
  std::size_t max_frames = 0;
  std::size_t correct_every = 1;
  std::vector<double> start_hint;
  double start_hint_radius = 3.0;
  double start_search_distance = 15.0;
  int threads = 0;
};

void run(const RunOptions& o) {
  const io::FrameDumpReader dump(o.dump_dir);
  // Before the work: an unwritable or foreign output directory is found now, not after the last frame.
  OutputDir out(o.out_dir, "run", run_output_names(), o.overwrite, true);
  const bim::BimMesh mesh = bim::build_mesh(bim::read_ifc(o.model), bim::mesh_settings_with_spaces());
  RunSettings settings;
  settings.max_frames = o.max_frames;
  settings.odometry.use_bim = !o.no_bim;
  settings.odometry.correct_every = o.correct_every;
  settings.odometry.threads = resolve_thread_count(o.threads);
  settings.localizer.threads = settings.odometry.threads;
  settings.odometry.refresh_threads = settings.odometry.threads;
  settings.odometry.estimate_as_built = o.as_built;
  settings.refine_as_built = o.refine;
  settings.deviation_tolerance = o.tolerance;
  settings.odometry.as_built.sigma_translation = o.as_built_sigma;
  settings.odometry.as_built.sigma_rotation = o.as_built_deg * kPi / 180.0;
  if (o.gt_start) {
    PLUMB_CHECK(dump.has_ground_truth(), o.dump_dir << ": --gt-start needs gt.tum in the dump");
    settings.initial_pose = dump.ground_truth().poses.front();
  }
  settings.start_search_distance = o.start_search_distance;
  if (!o.start_hint.empty()) {
    settings.start_hint = Eigen::Vector3d(o.start_hint[0], o.start_hint[1], 0.0);
    settings.start_hint_radius = o.start_hint_radius;
  }
  if (!o.json) settings.progress = terminal_progress("plumb run");
  const RunReport r = run_bim_odometry(dump, mesh, settings);
  print_warnings(r.warnings);
  const nlohmann::json j = run_report_json(r);
  write_run_outputs(r, j, mesh, dump, out.staging(), "plumb run: " + o.dump_dir, o.model);
  out.commit();
  if (o.json) {
    std::cout << j.dump(2) << '\n';
  } else {
    print_run_summary(r);
    std::printf("wrote %s/{wheel,lidar,bim%s}.tum, report.json, trajectory.svg\n", o.out_dir.c_str(),
                r.bim_refined.empty() ? "" : ",bim_refined");
    if (!r.deviations.empty()) {
      std::printf("as built: %s\n", deviation_summary(r.deviations, r.deviation_tolerance).c_str());
      std::printf("wrote %s/deviations.{json,csv,svg,bcf}\n", o.out_dir.c_str());
    }
  }
  PLUMB_CHECK(!r.partial, o.dump_dir << ": stopped at " << r.error << "; wrote the " << r.frames.size() << " of "
                                     << r.frames_requested << " frames processed to " << o.out_dir
                                     << " (report.json: \"partial\": true)");
  // Nothing of the LiDAR reached the trajectories: they are the wheel odometry under another name.
  std::size_t later_anchors = 0;  // the first frame's anchor only confirms the start pose
  for (std::size_t k = 1; k < r.frames.size(); ++k) {
    later_anchors += r.frames[k].anchor.decision == AnchorDecision::kAccepted ? 1 : 0;
  }
  if (r.frames.size() >= 2 && r.fallbacks + 1 >= r.frames.size() && later_anchors == 0) {
    std::ostringstream os;
    os << o.dump_dir << ": no frame after the first was matched by the scan front end (" << r.fallbacks
       << " fallbacks to the wheel prior) and no BIM anchor after it was accepted; the trajectories written to "
       << o.out_dir << " are the wheel odometry";
    throw JobFailed(os.str());
  }
}

}  // namespace

void register_run_command(CLI::App& app) {
  auto o = std::make_shared<RunOptions>();
  CLI::App* cmd =
      app.add_subcommand("run", "BIM-corrected laser odometry over a frame dump (Liu et al. 2022, sec. 3)");
  cmd->add_option("DIR", o->dump_dir, "Frame dump directory (plumb simulate, or your robot's own)")->required();
  cmd->add_option("--bim", o->model, "The building model (IFC)")->required();
  cmd->add_option("-o,--output", o->out_dir, "Output directory")->required();
  cmd->add_flag("--json", o->json, "Print the report as JSON");
  CLI::Option* no_bim = cmd->add_flag("--no-bim", o->no_bim, "Plain scan-matching odometry (no BIM corrections)");
  CLI::Option* as_built = cmd->add_flag(
      "--as-built", o->as_built,
      "Estimate each element's deviation from the design while driving and register to the "
      "building as estimated; writes deviations.json, .csv, .svg (floor plan) and .bcf (issues for BIM viewers)");
  cmd->add_flag("--refine", o->refine,
                "With --as-built: after the run, register every frame again, from the same start, to the building "
                "as estimated at its end; writes bim_refined.tum (offline: the frames are processed twice)")
      ->needs(as_built);
  as_built->excludes(no_bim);  // the as-built is estimated from the BIM registrations
  cmd->add_option("--tolerance", o->tolerance,
                  "Construction tolerance the --as-built deviations are judged against [m] (default 0.02)")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--as-built-sigma", o->as_built_sigma,
                  "How far elements may stand from the design, std dev per axis [m]: the --as-built estimate's "
                  "prior (default 0.01)")
      ->check(CLI::Range(1e-4, 1.0));
  cmd->add_option("--as-built-deg", o->as_built_deg,
                  "How far elements may be turned from the design, std dev about each axis [deg] (default 0.2)")
      ->check(CLI::Range(1e-3, 10.0));
  cmd->add_flag("--gt-start", o->gt_start, "Start at the dump's first ground-truth pose instead of localizing");
  cmd->add_option("--start-hint", o->start_hint, "Rough start position X Y in the BIM frame (e.g. the room's centre)")
      ->expected(2);
  cmd->add_option("--start-hint-radius", o->start_hint_radius, "How far from --start-hint the robot may be [m]")
      ->check(positive_number())
      ->capture_default_str();
  cmd->add_option("--start-search-distance", o->start_search_distance,
                  "When the first frame alone fits several places, drive on up to this far [m] and localize it from "
                  "the frames seen on the way (0 = the first frame decides)")
      ->check(non_negative_number())
      ->capture_default_str();
  // Unsigned: the check rejects "-3", which would otherwise wrap to a huge count.
  cmd->add_option("--threads", o->threads, "Threads (0 = every core; the results are the same for any count)")
      ->check(CLI::Range(0, 256));
  cmd->add_option("--max-frames", o->max_frames, "Process only the first N frames (0 = all)")
      ->check(non_negative_number());
  cmd->add_flag("--overwrite", o->overwrite,
                "Write into a directory holding files plumb did not write (plumb's run files in it are replaced)");
  cmd->add_option("--correct-every", o->correct_every, "BIM correction every k-th frame")
      ->check(finite_number(1, 1000))
      ->capture_default_str();
  cmd->callback([o]() { naming_inputs({o->dump_dir, o->model}, [&] { run(*o); }); });
}

}  // namespace plumb::cli

PLUMB_CLI_COMMAND(run, plumb::cli::register_run_command);
