// SPDX-License-Identifier: BSD-3-Clause
// `plumb run DIR --bim MODEL.ifc -o OUT [--json]`: the BIM-corrected odometry over a frame dump.
// Writes OUT/wheel.tum, OUT/lidar.tum, OUT/bim.tum (BIM frame, frame stamps), OUT/report.json and
// OUT/trajectory.svg; with ground truth in the dump, prints the seed's Table 2.

#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <string>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "registry.hpp"
#include "plumb/bim/ifc.hpp"
#include "plumb/bim/mesh.hpp"
#include "plumb/bim/sample.hpp"
#include "plumb/core/error.hpp"
#include "plumb/io/frame_dump.hpp"
#include "plumb/io/svg.hpp"
#include "plumb/io/trajectory.hpp"
#include "plumb/pipeline/run.hpp"

namespace plumb::cli {
namespace {

struct RunOptions {
  std::string dump_dir;
  std::string model;
  std::string out_dir;
  bool json = false;
  bool no_bim = false;
  bool gt_start = false;
  std::size_t max_frames = 0;
  std::size_t correct_every = 1;
};

nlohmann::json pose_json(const Eigen::Isometry3d& T) {
  nlohmann::json rows = nlohmann::json::array();
  for (int r = 0; r < 4; ++r) rows.push_back({T(r, 0), T(r, 1), T(r, 2), T(r, 3)});
  return rows;
}

void run(const RunOptions& o) {
  const io::FrameDumpReader dump(o.dump_dir);
  const bim::BimMesh mesh = bim::build_mesh(bim::read_ifc(o.model));
  RunSettings settings;
  settings.max_frames = o.max_frames;
  settings.odometry.use_bim = !o.no_bim;
  settings.odometry.correct_every = o.correct_every;
  if (o.gt_start) {
    PLUMB_CHECK(dump.has_ground_truth(), o.dump_dir << ": --gt-start needs gt.tum in the dump");
    settings.initial_pose = dump.ground_truth().poses.front();
  }
  const bool tty = isatty(fileno(stderr)) != 0;
  if (tty) {
    settings.progress = [](std::size_t done, std::size_t total) {
      if (done % 10 == 0 || done == total) std::fprintf(stderr, "\r  frame %zu / %zu", done, total);
      if (done == total) std::fprintf(stderr, "\n");
    };
  }
  const RunReport r = run_bim_odometry(dump, mesh, settings);
  std::filesystem::create_directories(o.out_dir);
  nlohmann::json j;
  j["frames"] = r.frames.size();
  j["localized"] = r.localized;
  j["localization_status"] = to_string(r.localization_status);
  j["T_bim_base0"] = pose_json(r.T_bim_base0);
  j["bim_points"] = r.bim_points;
  j["anchors"] = {{"attempted", r.anchors_attempted}, {"accepted", r.anchors_accepted}, {"rejected", r.anchors_rejected}};
  j["fallbacks"] = r.fallbacks;
  j["seconds_localize"] = r.seconds_localize;
  j["seconds_frames"] = r.seconds_frames;
  j["frames_per_second"] = r.frames_per_second;
  if (r.has_ground_truth) {
    j["initial_error"] = {{"xy", r.initial_error_xy}, {"yaw_deg", r.initial_error_yaw_deg}};
    j["path_length"] = r.path_length;
    nlohmann::json table = nlohmann::json::array();
    for (const ObservationRow& row : r.table) {
      auto pct = [&](double e) { return row.distance > 0 ? 100.0 * e / row.distance : 0.0; };
      table.push_back({{"point", row.name}, {"frame", row.frame}, {"distance", row.distance},
                       {"wheel", {{"error", row.error_wheel}, {"percent", pct(row.error_wheel)}}},
                       {"lidar", {{"error", row.error_lidar}, {"percent", pct(row.error_lidar)}}},
                       {"bim", {{"error", row.error_bim}, {"percent", pct(row.error_bim)}}}});
    }
    j["table"] = table;
    j["ape_rmse_xy"] = {{"wheel", r.ape_rmse_wheel}, {"lidar", r.ape_rmse_lidar}, {"bim", r.ape_rmse_bim}};
  }
  {
    std::ofstream out(o.out_dir + "/report.json");
    out << j.dump(2) << '\n';
    PLUMB_CHECK(out.good(), o.out_dir << "/report.json: write error");
  }
  if (r.localization_status != Status::kOk) {
    PLUMB_THROW(o.dump_dir << ": the first frame could not be localized in " << o.model << " ("
                           << to_string(r.localization_status) << ", overlap " << r.localization.overlap
                           << "); give --gt-start or check that the dump was recorded in this building");
  }
  io::write_tum(r.wheel, o.out_dir + "/wheel.tum");
  io::write_tum(r.lidar, o.out_dir + "/lidar.tum");
  io::write_tum(r.bim, o.out_dir + "/bim.tum");

  io::SvgPlot plot;
  plot.title = "plumb run: " + o.dump_dir;
  if (!mesh.storeys.empty()) {
    const double z = r.T_bim_base0.translation().z() + 1.0;
    const bim::FloorPlan fp = bim::slice_floor_plan(mesh, z);
    for (std::size_t i = 0; i < fp.segment_start.size(); ++i) plot.floor_plan.push_back({fp.segment_start[i], fp.segment_end[i]});
  }
  if (r.has_ground_truth) plot.add_trajectory(dump.ground_truth(), "ground truth", "#000000", true);
  plot.add_trajectory(r.wheel, "wheel odometry", "#d62728");
  plot.add_trajectory(r.lidar, "LiDAR (no BIM)", "#ff7f0e");
  plot.add_trajectory(r.bim, "BIM-corrected", "#2ca02c");
  io::write_svg(plot, o.out_dir + "/trajectory.svg");

  if (o.json) {
    std::cout << j.dump(2) << '\n';
    return;
  }
  std::printf("%zu frames, %.1f frames/s; anchors %zu accepted / %zu rejected of %zu attempted; %zu fallbacks\n",
              r.frames.size(), r.frames_per_second, r.anchors_accepted, r.anchors_rejected, r.anchors_attempted,
              r.fallbacks);
  if (r.has_ground_truth) {
    std::printf("initial localization error: %.1f mm, %.3f deg\n", r.initial_error_xy * 1e3, r.initial_error_yaw_deg);
    std::printf("%-6s %10s %18s %18s %18s\n", "point", "path [m]", "wheel", "LiDAR", "BIM-corrected");
    for (const ObservationRow& row : r.table) {
      auto cell = [&](double e) {
        static char buf[64];
        std::snprintf(buf, sizeof(buf), "%.3f m %6.3f %%", e, row.distance > 0 ? 100.0 * e / row.distance : 0.0);
        return std::string(buf);
      };
      std::printf("%-6s %10.2f %18s %18s %18s\n", row.name.c_str(), row.distance, cell(row.error_wheel).c_str(),
                  cell(row.error_lidar).c_str(), cell(row.error_bim).c_str());
    }
    std::printf("APE rmse (xy): wheel %.3f m, LiDAR %.3f m, BIM-corrected %.3f m\n", r.ape_rmse_wheel, r.ape_rmse_lidar,
                r.ape_rmse_bim);
  }
  std::printf("wrote %s/{wheel,lidar,bim}.tum, report.json, trajectory.svg\n", o.out_dir.c_str());
}

}  // namespace

void register_run_command(CLI::App& app) {
  auto o = std::make_shared<RunOptions>();
  CLI::App* cmd = app.add_subcommand("run", "BIM-corrected laser odometry over a frame dump (SEEDS A3)");
  cmd->add_option("DIR", o->dump_dir, "Frame dump directory (plumb simulate, or your robot's own)")->required();
  cmd->add_option("--bim", o->model, "The building model (IFC)")->required();
  cmd->add_option("-o,--output", o->out_dir, "Output directory")->required();
  cmd->add_flag("--json", o->json, "Print the report as JSON");
  cmd->add_flag("--no-bim", o->no_bim, "Plain scan-matching odometry (no BIM corrections)");
  cmd->add_flag("--gt-start", o->gt_start, "Start at the dump's first ground-truth pose instead of localizing");
  cmd->add_option("--max-frames", o->max_frames, "Process only the first N frames");
  cmd->add_option("--correct-every", o->correct_every, "BIM correction every k-th frame")
      ->check(CLI::Range(1, 1000))
      ->capture_default_str();
  cmd->callback([o]() { run(*o); });
}

}  // namespace plumb::cli

PLUMB_CLI_COMMAND(run, plumb::cli::register_run_command);
