// SPDX-License-Identifier: BSD-3-Clause
// `plumb lio DIR --mode loam|loam-imu|hybrid -o OUT [--json]`: the LiDAR/IMU hybrid odometry
// (Zhou et al. 2021) over a frame dump. Writes OUT/trajectory.tum (base pose at the frame stamps; the first
// frame at gt.tum's first pose when the dump has one, identity otherwise) and OUT/report.json
// (frames per mode, timings, failures, and with ground truth the RPE over 10 m and the end error).

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "registry.hpp"
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

  HybridLioSettings s;
  s.mode = mode;
  s.T_base_lidar = dump.meta().T_base_lidar;
  s.T_base_imu = dump.meta().T_base_imu;
  s.min_plane_points = o.min_plane_points;
  s.deskew = !o.no_deskew;
  s.icp_metric = icp_metric_from_string(o.icp_metric);
  if (o.icp_only) s.icp_keep_loam = false;
  s.edge_map.max_age = s.plane_map.max_age = s.point_map.max_age = static_cast<std::size_t>(o.map_window);
  for (double e : dump.meta().lidar.elevations_rad) s.image.vertical_angles_deg.push_back(e * 180.0 / 3.14159265358979323846);

  const std::size_t n = o.max_frames > 0 ? std::min(o.max_frames, dump.num_frames()) : dump.num_frames();
  Trajectory gt;
  bool has_gt = false;
  if (dump.has_ground_truth()) {
    gt = dump.ground_truth();
    has_gt = gt.size() >= n;
  }
  const Eigen::Isometry3d T0 = has_gt ? gt.poses.front() : Eigen::Isometry3d::Identity();
  HybridLio lio(T0, s);

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
  for (std::size_t i = 0; i < n; ++i) {
    const double stamp = dump.stamp(i);
    // The IMU up to the end of this frame's sweep (what a live system has when the sweep is complete).
    while (next_imu < imu.size() && imu[next_imu].stamp <= stamp + sweep + 0.02) {
      ImuSample sample;
      sample.stamp = imu[next_imu].stamp;
      sample.gyro = imu[next_imu].w_imu;
      sample.accel = imu[next_imu].f_imu;
      lio.add_imu(sample);
      ++next_imu;
    }
    const PointCloud frame = dump.frame(i);
    LioFrameResult r = lio.process(frame, stamp);
    ++count[static_cast<int>(r.mode)];
    imu_gaps += r.imu_gap ? 1 : 0;
    not_converged += r.status == Status::kNotConverged ? 1 : 0;
    seconds += r.seconds;
    ms.push_back(r.seconds * 1e3);
    if (r.mode != LioFrameMode::kSkipped) est.push_back(stamp, r.T_world_base);
    frames.push_back(r);
  }

  std::filesystem::create_directories(o.out_dir);
  io::write_tum(est, o.out_dir + "/trajectory.tum");

  nlohmann::json j;
  j["dump"] = o.dump_dir;
  j["mode"] = to_string(mode);
  j["frames"] = n;
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
                   {"imu_samples_dropped", lio.num_imu_dropped()}};
  std::vector<double> sorted = ms;
  std::sort(sorted.begin(), sorted.end());
  j["timing"] = {{"seconds", seconds},
                 {"frames_per_second", seconds > 0.0 ? static_cast<double>(n) / seconds : 0.0},
                 {"mean_ms", sorted.empty() ? 0.0 : seconds * 1e3 / static_cast<double>(sorted.size())},
                 {"median_ms", sorted.empty() ? 0.0 : sorted[sorted.size() / 2]},
                 {"max_ms", sorted.empty() ? 0.0 : sorted.back()}};
  std::size_t planes = 0, structure = 0;
  for (const LioFrameResult& r : frames) {
    planes += r.num_plane_points;
    structure += r.num_structure_planes;
  }
  j["features"] = {{"mean_plane_points", n > 0 ? static_cast<double>(planes) / static_cast<double>(n) : 0.0},
                   {"mean_structure_planes", n > 0 ? static_cast<double>(structure) / static_cast<double>(n) : 0.0}};
  if (has_gt && est.size() >= 2) {
    Trajectory ref;
    for (std::size_t i = 0; i < n; ++i) {
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
    std::ofstream out(o.out_dir + "/report.json");
    out << j.dump(2) << '\n';
    PLUMB_CHECK(out.good(), o.out_dir << "/report.json: write error");
  }
  if (o.json) {
    std::cout << j.dump(2) << '\n';
    return;
  }
  std::printf("%zu frames (%s): %zu loam, %zu icp, %zu prediction-only, %zu skipped; %.1f frames/s\n", n,
              to_string(mode), count[1], count[2], count[3], count[4],
              seconds > 0.0 ? static_cast<double>(n) / seconds : 0.0);
  if (j.contains("end_error")) {
    std::printf("path %.1f m: end error %.3f m", j["path_length"].get<double>(), j["end_error"].get<double>());
    if (j.contains("rpe_10m")) std::printf(", mean RPE over 10 m %.3f m", j["rpe_10m"]["translation_mean"].get<double>());
    std::printf("\n");
  }
  std::printf("wrote %s/trajectory.tum, report.json\n", o.out_dir.c_str());
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
  // Unsigned options would take "-3" as a huge count: the checks reject negative input.
  cmd->add_option("--max-frames", o->max_frames, "Process only the first N frames")->check(CLI::NonNegativeNumber);
  cmd->add_option("--min-plane-points", o->min_plane_points, "Hybrid switch: fewer plane points off the ground -> ICP")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  cmd->add_flag("--no-deskew", o->no_deskew, "Do not undo the motion distortion of the frames");
  cmd->add_option("--map-window", o->map_window,
                  "Local maps keep only what the last N frames filled (no implicit loop closure when the "
                  "route comes back; 0: everything within 60 m)")
      ->check(CLI::Range(0, 1000000000));
  cmd->add_option("--icp-metric", o->icp_metric,
                  "Hybrid ICP frames: point-to-point (Zhou et al. 2021, eq. 20) or point-to-distribution "
                  "(each pair weighted by the covariance of its map neighbours)")
      ->check(CLI::IsMember({"point-to-point", "point-to-distribution"}))
      ->capture_default_str();
  cmd->add_flag("--icp-only", o->icp_only,
                "Hybrid ICP frames use the ICP residuals alone (Zhou et al. 2021, eq. 21: E_B + E_L2), "
                "not with the LOAM ones the map still gives");
  cmd->callback([o]() { run(*o); });
}

}  // namespace plumb::cli

PLUMB_CLI_COMMAND(lio, plumb::cli::register_lio_command);
