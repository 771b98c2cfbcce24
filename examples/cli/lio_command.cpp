// SPDX-License-Identifier: BSD-3-Clause
// `plumb lio DIR --mode loam|loam-imu|hybrid -o OUT [--json]`: the LiDAR/IMU hybrid odometry
// (Zhou et al. 2021) over a frame dump. Writes OUT/trajectory.tum (base pose at the frame stamps; the first
// frame at gt.tum's first pose when the dump has one, identity otherwise) and OUT/report.json
// (frames per mode, timings, failures, and with ground truth the RPE over 10 m and the end error).
// OUT is checked before any work and replaced as a whole (OutputDir, run_output.hpp). Frames too
// empty to start the map are skipped; the first usable one starts it (at gt.tum's pose of that
// frame). A frame failing after others were processed still writes the set ("partial": true, exit 1).
// Exit code 3 (kExitJobFailed) when no frame after the first was registered (LOAM or ICP): the set is
// written, but the trajectory is the motion prediction alone.

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "cli_support.hpp"
#include "registry.hpp"
#include "run_output.hpp"
#include "plumb/core/error.hpp"
#include "plumb/eval/metrics.hpp"
#include "plumb/io/frame_dump.hpp"
#include "plumb/io/trajectory.hpp"
#include "plumb/pipeline/hybrid_lio.hpp"

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
  std::string icp_metric = to_string(HybridLioSettings{}.icp_metric);
  bool icp_only = false;
};

void run(const LioOptions& o) {
  const LioMode mode = lio_mode_from_string(o.mode);
  const io::FrameDumpReader dump(o.dump_dir);
  PLUMB_CHECK(dump.num_frames() > 0, o.dump_dir << ": the dump has no frame");
  const bool imu_mode = mode != LioMode::kLoam;
  PLUMB_CHECK(!imu_mode || dump.has_imu(), o.dump_dir << ": --mode " << o.mode << " needs imu.csv in the dump");
  // Before the work: an unwritable or foreign output directory is found now.
  OutputDir out(o.out_dir, "lio", {"trajectory.tum", "report.json"}, o.overwrite, true);

  HybridLioSettings s;
  s.mode = mode;
  s.T_base_lidar = dump.meta().T_base_lidar;
  s.T_base_imu = dump.meta().T_base_imu;
  s.min_plane_points = o.min_plane_points;
  // A handful of points would start a map nothing can be matched to: wait for a real sweep.
  s.min_init_points = 100;
  s.deskew = !o.no_deskew;
  s.icp_metric = icp_metric_from_string(o.icp_metric);
  if (o.icp_only) s.icp_keep_loam = false;
  s.edge_map.max_age = s.plane_map.max_age = s.point_map.max_age = static_cast<std::size_t>(o.map_window);
  for (double e : dump.meta().lidar.elevations_rad) s.image.vertical_angles_deg.push_back(e * 180.0 / 3.14159265358979323846);

  const std::size_t n = o.max_frames > 0 ? std::min(o.max_frames, dump.num_frames()) : dump.num_frames();
  Trajectory gt;
  bool has_gt = false;
  std::vector<std::string> warnings;
  if (dump.has_ground_truth()) {
    gt = dump.ground_truth();
    has_gt = gt.size() >= n;
    if (!has_gt) {
      warnings.push_back(o.dump_dir + "/gt.tum: " + std::to_string(gt.size()) + " poses for " + std::to_string(n) +
                         " frames; no accuracy report (RPE, APE, end error) and the start pose is the identity");
    }
    for (std::size_t i = 0; has_gt && i < n; ++i) {
      PLUMB_CHECK(!gt.has_stamps() || std::abs(gt.stamps[i] - dump.stamp(i)) < 1e-6,
                  o.dump_dir << "/gt.tum: pose " << i << " has stamp " << gt.stamps[i] << ", frame " << i << " has "
                             << dump.stamp(i) << " (gt.tum holds one pose per frame)");
    }
  }
  print_warnings(warnings);
  // Made at the first frame, and again at the next one while no frame has started the map: the
  // start pose is that of the frame that starts it.
  std::optional<HybridLio> lio;
  std::size_t first_frame = n;

  std::vector<io::ImuSample> imu;
  if (imu_mode) imu = dump.imu();
  std::size_t next_imu = 0;
  const double sweep = dump.meta().lidar.rate_hz > 0.0 ? 1.0 / dump.meta().lidar.rate_hz : 0.1;

  Trajectory est;
  std::vector<LioFrameResult> frames;
  frames.reserve(n);
  std::size_t count[5] = {0, 0, 0, 0, 0};
  std::size_t imu_gaps = 0, not_converged = 0;
  double seconds = 0.0;
  std::vector<double> ms;
  std::size_t imu_dropped = 0;
  std::string error;
  for (std::size_t i = 0; i < n; ++i) {
    const double stamp = dump.stamp(i);
    if (!lio) {
      lio.emplace(has_gt ? gt.poses[i] : Eigen::Isometry3d::Identity(), s);
      // A new estimator after a skipped first frame gets the IMU from one sweep before this frame on
      // (the first one gets all of it, as it always did).
      if (i > 0) next_imu = static_cast<std::size_t>(
          std::lower_bound(imu.begin(), imu.end(), stamp - sweep,
                           [](const io::ImuSample& a, double t) { return a.stamp < t; }) -
          imu.begin());
    }
    // The IMU up to the end of this frame's sweep (what a live system has when the sweep is complete).
    while (next_imu < imu.size() && imu[next_imu].stamp <= stamp + sweep + 0.02) {
      lio->add_imu(imu[next_imu]);
      ++next_imu;
    }
    LioFrameResult r;
    try {
      const PointCloud frame = dump.frame(i);
      r = lio->process(frame, stamp);
    } catch (const std::exception& e) {
      // What was computed so far is kept and written marked partial.
      if (first_frame == n) throw;
      error = "frame " + std::to_string(i) + ": " + e.what();
      break;
    }
    if (lio->initialized() && first_frame == n) first_frame = i;
    if (!lio->initialized()) {
      imu_dropped += lio->num_imu_dropped();
      lio.reset();
    }
    ++count[static_cast<int>(r.mode)];
    imu_gaps += r.imu_gap ? 1 : 0;
    not_converged += r.status == Status::kNotConverged ? 1 : 0;
    seconds += r.seconds;
    ms.push_back(r.seconds * 1e3);
    if (r.mode != LioFrameMode::kSkipped) est.push_back(stamp, r.T_world_base);
    frames.push_back(r);
  }
  PLUMB_CHECK(first_frame < n, o.dump_dir << ": none of the " << n << " frames has the " << s.min_init_points
                                          << " points needed to start the map (are the frame files empty?)");
  imu_dropped += lio->num_imu_dropped();
  const bool partial = !error.empty();
  const std::size_t done = frames.size();  // n, or fewer when a frame failed

  io::write_tum(est, out.staging() + "/trajectory.tum");

  nlohmann::json j;
  j["dump"] = o.dump_dir;
  j["mode"] = to_string(mode);
  j["frames"] = done;
  j["frames_requested"] = n;
  j["first_frame"] = first_frame;
  j["partial"] = partial;
  if (partial) j["error"] = error;
  j["warnings"] = warnings;
  j["ground_truth"] = has_gt ? "used" : (dump.has_ground_truth() ? "too_short" : "absent");
  j["map_window"] = o.map_window;
  j["icp_metric"] = to_string(s.icp_metric);
  j["icp_keep_loam"] = s.icp_keep_loam;
  j["frames_per_mode"] = {{"init", count[static_cast<int>(LioFrameMode::kInit)]},
                          {"loam", count[static_cast<int>(LioFrameMode::kLoam)]},
                          {"icp", count[static_cast<int>(LioFrameMode::kIcp)]},
                          {"prediction", count[static_cast<int>(LioFrameMode::kPrediction)]},
                          {"skipped", count[static_cast<int>(LioFrameMode::kSkipped)]}};
  j["failures"] = {{"prediction_only", count[static_cast<int>(LioFrameMode::kPrediction)]},
                   {"skipped", count[static_cast<int>(LioFrameMode::kSkipped)]},
                   {"imu_gaps", imu_gaps},
                   {"not_converged", not_converged},
                   {"imu_samples_dropped", imu_dropped}};
  std::vector<double> sorted = ms;
  std::sort(sorted.begin(), sorted.end());
  j["timing"] = {{"seconds", seconds},
                 {"frames_per_second", seconds > 0.0 ? static_cast<double>(done) / seconds : 0.0},
                 {"mean_ms", sorted.empty() ? 0.0 : seconds * 1e3 / static_cast<double>(sorted.size())},
                 {"median_ms", sorted.empty() ? 0.0 : sorted[sorted.size() / 2]},
                 {"max_ms", sorted.empty() ? 0.0 : sorted.back()}};
  std::size_t planes = 0, structure = 0;
  for (const LioFrameResult& r : frames) {
    planes += r.num_plane_points;
    structure += r.num_structure_planes;
  }
  j["features"] = {{"mean_plane_points", done > 0 ? static_cast<double>(planes) / static_cast<double>(done) : 0.0},
                   {"mean_structure_planes", done > 0 ? static_cast<double>(structure) / static_cast<double>(done) : 0.0}};
  if (has_gt && est.size() >= 2) {
    Trajectory ref;
    for (std::size_t i = 0; i < done; ++i) {
      if (frames[i].mode != LioFrameMode::kSkipped) ref.push_back(gt.stamps[i], gt.poses[i]);
    }
    const std::vector<double> len = eval::path_lengths(ref);
    j["path_length"] = len.back();
    const Vector3d end = est.poses.back().translation() - ref.poses.back().translation();
    j["end_error"] = end.norm();
    j["end_error_xy"] = end.head<2>().norm();
    eval::RpeSettings rs;
    rs.delta = 10.0;
    rs.unit = eval::DeltaUnit::kMeters;
    rs.pairs_along = eval::PathSource::kReference;
    const eval::RpeResult rpe = eval::compute_rpe(est, ref, rs);
    if (rpe.status == Status::kOk) {
      j["rpe_10m"] = {{"translation_mean", rpe.translation.stats.mean},
                      {"translation_rmse", rpe.translation.stats.rmse},
                      {"rotation_mean_deg", rpe.rotation_deg.stats.mean},
                      {"pairs", rpe.translation.stats.count}};
    }
    eval::ApeSettings as;
    as.align = eval::AlignMode::kNone;
    j["ape_rmse"] = eval::compute_ape(est, ref, as).translation.stats.rmse;
  }
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
                to_string(mode), count[1], count[2], count[3], count[4],
                seconds > 0.0 ? static_cast<double>(done) / seconds : 0.0);
    if (j.contains("end_error")) {
      std::printf("path %.1f m: end error %.3f m", j["path_length"].get<double>(), j["end_error"].get<double>());
      if (j.contains("rpe_10m")) std::printf(", mean RPE over 10 m %.3f m", j["rpe_10m"]["translation_mean"].get<double>());
      std::printf("\n");
    }
    std::printf("wrote %s/trajectory.tum, report.json\n", o.out_dir.c_str());
  }
  PLUMB_CHECK(!partial, o.dump_dir << ": stopped at " << error << "; wrote the " << done << " of " << n
                                   << " frames processed to " << o.out_dir << " (report.json: \"partial\": true)");
  const std::size_t registered =
      count[static_cast<int>(LioFrameMode::kLoam)] + count[static_cast<int>(LioFrameMode::kIcp)];
  if (done >= 2 && registered == 0) {
    std::ostringstream os;
    os << o.dump_dir << ": no frame after the first was registered to the map ("
       << count[static_cast<int>(LioFrameMode::kPrediction)] << " prediction-only, "
       << count[static_cast<int>(LioFrameMode::kSkipped)] << " skipped); the trajectory written to " << o.out_dir
       << " is the motion prediction alone";
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
