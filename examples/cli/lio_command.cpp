// SPDX-License-Identifier: BSD-3-Clause
// `plumb lio DIR --mode loam|loam-imu|hybrid -o OUT [--json]`: the LiDAR/IMU hybrid odometry
// (Zhou et al. 2021) over a frame dump. Writes OUT/trajectory.tum (base pose at the frame stamps; the first
// frame at gt.tum's first pose when the dump has one, identity otherwise) and OUT/report.json
// (frames per mode, timings, failures, and with ground truth the RPE over 10 m and the end error).
// OUT is checked before any work and replaced as a whole (OutputDir, run_output.hpp). Frames too
// empty to start the map are skipped; the first usable one starts it (at gt.tum's pose of that
// frame). A frame failing after others were processed still writes the set ("partial": true, exit 1).
// Exit code 3 (kExitJobFailed) when no frame after the first was registered (LOAM or ICP): the set is
// written, but the trajectory is the motion prediction alone. The run itself is the library's
// run_lio() (app/lio_run.hpp); this file turns options into its settings and its report into files.

#include <cstdio>
#include <fstream>
#include <iostream>
#include <memory>
#include <sstream>
#include <string>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "cli_support.hpp"
#include "registry.hpp"
#include "run_output.hpp"
#include "plumb/app/lio_run.hpp"
#include "plumb/core/error.hpp"
#include "plumb/core/parallel.hpp"
#include "plumb/io/frame_dump.hpp"
#include "plumb/io/trajectory.hpp"

namespace plumb::cli {
namespace {

struct LioOptions {
  std::string dump_dir;
  std::string mode = "hybrid";
  std::string out_dir;
  bool json = false;
  bool overwrite = false;
  std::size_t max_frames = 0;
  std::size_t min_plane_points = 48;
  bool no_deskew = false;
  int map_window = 0;
  int threads = 0;
  std::string icp_metric = to_string(HybridLioSettings{}.solver.icp_metric);
  bool icp_only = false;
};

// The report as `plumb lio` writes it (report.json, --json).
nlohmann::json lio_report_json(const LioRunReport& r, const LioOptions& o, const HybridLioSettings& s) {
  nlohmann::json j;
  j["dump"] = o.dump_dir;
  j["mode"] = to_string(s.mode);
  j["frames"] = r.frames.size();
  j["frames_requested"] = r.frames_requested;
  j["first_frame"] = r.first_frame;
  j["partial"] = r.partial;
  if (r.partial) j["error"] = r.error;
  j["warnings"] = r.warnings;
  j["ground_truth"] = r.ground_truth_note;
  j["map_window"] = o.map_window;
  j["icp_metric"] = to_string(s.solver.icp_metric);
  j["icp_keep_loam"] = s.solver.icp_keep_loam;
  j["frames_per_mode"] = {{"init", r.frames_in(LioFrameMode::kInit)},
                          {"loam", r.frames_in(LioFrameMode::kLoam)},
                          {"icp", r.frames_in(LioFrameMode::kIcp)},
                          {"prediction", r.frames_in(LioFrameMode::kPrediction)},
                          {"skipped", r.frames_in(LioFrameMode::kSkipped)}};
  j["failures"] = {{"prediction_only", r.frames_in(LioFrameMode::kPrediction)},
                   {"skipped", r.frames_in(LioFrameMode::kSkipped)},
                   {"imu_gaps", r.imu_gaps},
                   {"not_converged", r.not_converged},
                   {"imu_samples_dropped", r.imu_samples_dropped}};
  j["timing"] = {{"seconds", r.seconds_process},
                 {"frames_per_second", r.frames_per_second},
                 {"mean_ms", r.mean_seconds_process * 1e3},
                 {"median_ms", r.median_seconds_process * 1e3},
                 {"max_ms", r.max_seconds_process * 1e3}};
  j["peak_rss_mib"] = peak_rss_mib();
  j["features"] = {{"mean_plane_points", r.mean_plane_points}, {"mean_structure_planes", r.mean_structure_planes}};
  if (r.has_metrics) {
    j["path_length"] = r.path_length;
    j["end_error"] = r.end_error;
    j["end_error_xy"] = r.end_error_xy;
    if (r.rpe_pairs > 0) {
      j["rpe_10m"] = {{"translation_mean", r.rpe_translation_mean},
                      {"translation_rmse", r.rpe_translation_rmse},
                      {"rotation_mean_deg", r.rpe_rotation_mean_deg},
                      {"pairs", r.rpe_pairs}};
    }
    j["ape_rmse"] = r.ape_rmse;
  }
  return j;
}

void run(const LioOptions& o) {
  const LioMode mode = lio_mode_from_string(o.mode);
  const io::FrameDumpReader dump(o.dump_dir);
  // Checked before the output directory too, naming the option.
  PLUMB_CHECK(dump.num_frames() > 0, o.dump_dir << ": the dump has no frame");
  PLUMB_CHECK(mode == LioMode::kLoam || dump.has_imu(), o.dump_dir << ": --mode " << o.mode << " needs imu.csv in the dump");
  // Before the work: an unwritable or foreign output directory is found now.
  OutputDir out(o.out_dir, "lio", {"trajectory.tum", "report.json"}, o.overwrite, true);

  LioRunSettings settings;
  HybridLioSettings& s = settings.lio;
  s.mode = mode;
  s.features.min_plane_points = o.min_plane_points;
  // A handful of points would start a map nothing can be matched to: wait for a real sweep.
  s.features.min_init_points = 100;
  s.motion.deskew = !o.no_deskew;
  s.solver.icp_metric = icp_metric_from_string(o.icp_metric);
  if (o.icp_only) s.solver.icp_keep_loam = false;
  s.map.edge_map.max_age = s.map.plane_map.max_age = s.map.point_map.max_age = static_cast<std::size_t>(o.map_window);
  settings.max_frames = o.max_frames;
  s.threads = resolve_thread_count(o.threads);
  const LioRunReport r = run_lio(dump, settings);
  print_warnings(r.warnings);
  const std::size_t done = r.frames.size();  // frames_requested, or fewer when a frame failed

  io::write_tum(r.trajectory, out.staging() + "/trajectory.tum");
  const nlohmann::json j = lio_report_json(r, o, s);
  {
    std::ofstream file(out.staging() + "/report.json");
    file << j.dump(2) << '\n';
    PLUMB_CHECK(file.good(), o.out_dir << "/report.json: write error");
  }
  out.commit();
  if (o.json) {
    std::cout << j.dump(2) << '\n';
  } else {
    std::printf("%zu frames (%s): %zu loam, %zu icp, %zu prediction-only, %zu skipped; %.1f frames/s\n", done,
                to_string(mode), r.frames_in(LioFrameMode::kLoam), r.frames_in(LioFrameMode::kIcp),
                r.frames_in(LioFrameMode::kPrediction), r.frames_in(LioFrameMode::kSkipped), r.frames_per_second);
    if (r.has_metrics) {
      std::printf("path %.1f m: end error %.3f m", r.path_length, r.end_error);
      if (r.rpe_pairs > 0) std::printf(", mean RPE over 10 m %.3f m", r.rpe_translation_mean);
      std::printf("\n");
    }
    std::printf("wrote %s/trajectory.tum, report.json\n", o.out_dir.c_str());
  }
  PLUMB_CHECK(!r.partial, o.dump_dir << ": stopped at " << r.error << "; wrote the " << done << " of "
                                     << r.frames_requested << " frames processed to " << o.out_dir
                                     << " (report.json: \"partial\": true)");
  if (done >= 2 && r.frames_in(LioFrameMode::kLoam) + r.frames_in(LioFrameMode::kIcp) == 0) {
    std::ostringstream os;
    os << o.dump_dir << ": no frame after the first was registered to the map ("
       << r.frames_in(LioFrameMode::kPrediction) << " prediction-only, " << r.frames_in(LioFrameMode::kSkipped)
       << " skipped); the trajectory written to " << o.out_dir << " is the motion prediction alone";
    throw JobFailed(os.str());
  }
}

}  // namespace

void register_lio_command(CLI::App& app) {
  auto o = std::make_shared<LioOptions>();
  CLI::App* cmd = app.add_subcommand("lio", "LiDAR/IMU hybrid odometry over a frame dump (Zhou et al. 2021)");
  cmd->add_option("DIR", o->dump_dir, "Frame dump directory (plumb simulate, or your robot's own)")->required();
  cmd->add_option("--mode", o->mode, "loam (LiDAR only), loam-imu (IMU + LOAM), hybrid (IMU + LOAM or ICP)")
      ->check(CLI::IsMember({"loam", "loam-imu", "hybrid"}))
      ->capture_default_str();
  cmd->add_option("-o,--output", o->out_dir, "Output directory")->required();
  cmd->add_flag("--json", o->json, "Print the report as JSON");
  cmd->add_flag("--overwrite", o->overwrite,
                "Write into a directory holding files plumb did not write (plumb's lio files in it are replaced)");
  // Unsigned options would take "-3" as a huge count: the checks reject negative input.
  cmd->add_option("--threads", o->threads, "Threads (0 = every core; the results are the same for any count)")
      ->check(CLI::Range(0, 256));
  cmd->add_option("--max-frames", o->max_frames, "Process only the first N frames")->check(non_negative_number());
  cmd->add_option("--min-plane-points", o->min_plane_points, "Hybrid switch: fewer plane points off the ground -> ICP")
      ->capture_default_str()
      ->check(non_negative_number());
  cmd->add_flag("--no-deskew", o->no_deskew, "Do not undo the motion distortion of the frames");
  cmd->add_option("--map-window", o->map_window,
                  "Local maps keep only what the last N frames filled (no implicit loop closure when the "
                  "route comes back; 0: everything within 60 m)")
      ->check(finite_number(0, 1000000000));
  cmd->add_option("--icp-metric", o->icp_metric,
                  "Hybrid ICP frames: point-to-point (Zhou et al. 2021, eq. 20) or point-to-distribution "
                  "(each pair weighted by the covariance of its map neighbours)")
      ->check(CLI::IsMember({"point-to-point", "point-to-distribution"}))
      ->capture_default_str();
  cmd->add_flag("--icp-only", o->icp_only,
                "Hybrid ICP frames use the ICP residuals alone (Zhou et al. 2021, eq. 21: E_B + E_L2), "
                "not with the LOAM ones the map still gives");
  cmd->callback([o]() { naming_inputs({o->dump_dir}, [&] { run(*o); }); });
}

}  // namespace plumb::cli

PLUMB_CLI_COMMAND(lio, plumb::cli::register_lio_command);
