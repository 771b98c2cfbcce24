// SPDX-License-Identifier: BSD-3-Clause
// `plumb register SOURCE TARGET [--voxel V] [--seed S] [--json]`: global registration of two clouds
// (voxel -> normals -> FPFH -> SAC-IA with the Huber score -> overlap-gated ICP, Liu et al. 2022,
// sec. 1) and the resulting 4x4 T_target_source, which maps source points into the target frame.
// A registration whose status is not "ok" still prints its result (for diagnosis), then says so on
// stderr and exits with code 3 (kExitJobFailed): its T_target_source must not be used.

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <iostream>
#include <limits>
#include <memory>
#include <sstream>
#include <string>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "cli_support.hpp"
#include "registry.hpp"
#include "plumb/core/error.hpp"
#include "plumb/core/parallel.hpp"
#include "plumb/io/cloud_io.hpp"
#include "plumb/registration/localize.hpp"

namespace plumb::cli {
namespace {

struct RegisterOptions {
  std::string source_path;
  std::string target_path;
  double voxel = 0.0;  // 0 = from the target's extent
  std::uint64_t seed = 42;
  int threads = 0;
  bool json = false;
};

/// Coarse voxel from the target's finite bounding box: 1/100 of its diagonal, so a 30 m room gets
/// ~0.3 m and a 0.2 m object ~2 mm.
double default_voxel(const PointCloud& cloud, const std::string& name) {
  Vector3f lo = Vector3f::Constant(std::numeric_limits<float>::infinity());
  Vector3f hi = -lo;
  for (const Vector3f& p : cloud.points) {
    if (!p.allFinite()) continue;
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  const double diag = (hi - lo).cast<double>().norm();
  PLUMB_CHECK(std::isfinite(diag) && diag > 0.0,
              name << ": the target has no extent (all its finite points coincide) to size --voxel from");
  return diag / 100.0;
}

void run_register(const RegisterOptions& o) {
  const PointCloud source = io::read_cloud(o.source_path);
  const PointCloud target = io::read_cloud(o.target_path);
  PLUMB_CHECK(!source.empty(), o.source_path << ": no points");
  PLUMB_CHECK(!target.empty(), o.target_path << ": no points");
  const double voxel = o.voxel > 0.0 ? o.voxel : default_voxel(target, o.target_path);
  LocalizeSettings settings = localize_settings_for_voxel(voxel);
  settings.sac_ia.seed = o.seed;
  settings.threads = resolve_thread_count(o.threads);
  const LocalizeResult r = localize_coarse_to_fine(source, target, settings);
  const Eigen::Matrix4d T = r.T_target_source.matrix();
  const double seconds = r.seconds_prepare + r.seconds_coarse + r.seconds_fine;
  if (o.json) {
    nlohmann::json rows = nlohmann::json::array();
    for (int i = 0; i < 4; ++i) rows.push_back({T(i, 0), T(i, 1), T(i, 2), T(i, 3)});
    const nlohmann::json j = {{"T_target_source", rows},
                              {"status", to_string(r.status)},
                              {"overlap", r.overlap},
                              {"rmse", r.rmse},
                              {"seconds", seconds},
                              {"voxel", voxel},
                              {"coarse", {{"status", to_string(r.coarse.status)},
                                          {"iterations", r.coarse.iterations},
                                          {"overlap", r.coarse.overlap},
                                          {"seconds", r.seconds_coarse}}},
                              {"fine", {{"iterations", r.iterations},
                                        {"num_inliers", r.num_inliers},
                                        {"degeneracy", r.degeneracy},
                                        {"seconds", r.seconds_fine}}}};
    std::cout << j.dump(2) << '\n';
  } else {
    std::printf("T_target_source:\n");
    for (int i = 0; i < 4; ++i) std::printf("  %12.6f %12.6f %12.6f %12.6f\n", T(i, 0), T(i, 1), T(i, 2), T(i, 3));
    std::printf("status %s, overlap %.3f, rmse %.4f m (voxel %.4g m)\n", to_string(r.status), r.overlap, r.rmse, voxel);
    std::printf("time: prepare %.3f s, SAC-IA %.3f s (%d hypotheses), ICP %.3f s (%d iterations), total %.3f s\n",
                r.seconds_prepare, r.seconds_coarse, r.coarse.iterations, r.seconds_fine, r.iterations, seconds);
  }
  if (r.status != Status::kOk) {
    std::ostringstream os;
    os.precision(3);
    os << o.source_path << " in " << o.target_path << ": registration failed (status " << to_string(r.status)
       << ", overlap " << r.overlap << ", coarse stage " << to_string(r.coarse.status)
       << "); the printed T_target_source is not a valid result";
    throw JobFailed(os.str());
  }
}

}  // namespace

void register_register_command(CLI::App& app) {
  auto opts = std::make_shared<RegisterOptions>();
  CLI::App* cmd = app.add_subcommand(
      "register", "Global registration: find SOURCE in TARGET (FPFH + SAC-IA + overlap-gated ICP); prints T_target_source");
  cmd->add_option("source", opts->source_path, "Source cloud (.pcd, .ply or KITTI .bin)")->required()->check(CLI::ExistingFile);
  cmd->add_option("target", opts->target_path, "Target cloud (.pcd, .ply or KITTI .bin)")->required()->check(CLI::ExistingFile);
  cmd->footer(
      "Exit codes: 0 registered (status ok); 1 unusable input (message names it); 3 the result was\n"
      "printed but its status is not ok (stderr says which), so T_target_source must not be used;\n"
      ">= 100 usage errors.");
  cmd->add_option("--voxel", opts->voxel, "Coarse voxel size [m] (default: 1/100 of the target's extent)")
      ->check(positive_number(1e4));
  cmd->add_option("--seed", opts->seed, "Random seed of SAC-IA (default 42)")->check(non_negative_number());
  cmd->add_option("--threads", opts->threads, "Threads (0 = every core; the result is the same for any count)")
      ->check(CLI::Range(0, 256));
  cmd->add_flag("--json", opts->json, "Print the result as JSON");
  cmd->callback([opts] { naming_inputs({opts->source_path, opts->target_path}, [&] { run_register(*opts); }); });
}

}  // namespace plumb::cli

PLUMB_CLI_COMMAND(register, plumb::cli::register_register_command);
