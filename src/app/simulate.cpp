// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/app/simulate.hpp"

#include <chrono>
#include <fstream>
#include <sstream>

#include "plumb/core/error.hpp"
#include "plumb/io/input_file.hpp"
#include "plumb/sim/lidar_model_json.hpp"

namespace plumb {

io::FrameDumpMeta simulated_dump_meta(const sim::ScenarioPlan& plan, const sim::ScenarioSettings& s,
                                      const std::string& model_name) {
  io::FrameDumpMeta meta;
  meta.lidar.name = s.lidar.name;
  meta.lidar.rate_hz = s.lidar.rate_hz;
  meta.lidar.columns = s.lidar.columns;
  meta.lidar.elevations_rad = s.lidar.elevations_rad;
  meta.lidar.min_range = s.lidar.min_range;
  meta.lidar.max_range = s.lidar.max_range;
  meta.T_base_lidar = s.T_base_lidar;
  meta.T_base_imu = s.T_base_imu;
  meta.wheel_radius_left = s.wheels.radius;
  meta.wheel_radius_right = s.wheels.radius;
  meta.axle = s.wheels.axle;
  meta.imu_rate_hz = s.imu.rate_hz;
  meta.origin_offset = plan.mesh->origin_offset;
  meta.source = "plumb simulate (seed " + std::to_string(s.seed) + ")";
  meta.model = model_name;
  meta.scenario = sim::to_string(s.kind);
  return meta;
}

sim::ScenarioResult simulate_to_dump(const bim::BimMesh& mesh, const std::string& out_dir,
                                     const sim::ScenarioSettings& scenario, const SimulateDumpSettings& settings) {
  const auto start = std::chrono::steady_clock::now();
  const sim::ScenarioPlan plan = sim::plan_scenario(mesh, scenario);
  io::FrameDumpWriter writer(out_dir, simulated_dump_meta(plan, scenario, settings.model_name), settings.dump);
  const std::size_t total = plan.frame_stamps.size();
  const sim::ScenarioRecording r =
      sim::simulate_scenario(plan, scenario, [&](std::size_t index, double stamp, const PointCloud& cloud) {
        writer.add_frame(stamp, cloud);
        if (settings.progress) settings.progress(index + 1, total);
      });
  writer.close();
  writer.write_wheels(r.wheels);
  writer.write_odometry(r.odometry);
  writer.write_imu(r.imu);
  if (!r.ground_truth.empty()) writer.write_ground_truth(r.ground_truth);
  writer.write_ground_truth_dense(r.ground_truth_dense);
  writer.write_as_built(r.as_built);
  sim::ScenarioResult summary = r.summary;
  summary.wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return summary;
}

sim::LidarModel read_lidar_model(const std::string& path) {
  std::ifstream in = io::open_input_file(path);
  std::ostringstream text;
  text << in.rdbuf();
  PLUMB_CHECK(!in.bad(), path << ": read error");
  return sim::parse_lidar_model(text.str(), path);
}

}  // namespace plumb
