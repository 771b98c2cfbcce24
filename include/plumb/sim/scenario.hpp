// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief Simulation scenarios: a robot driving through (`indoor`) or around (`site`) a real
///        building, with LiDAR frames, wheel encoders, wheel odometry, IMU and exact ground truth,
///        written as a frame dump directory (io/frame_dump.hpp).

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>

#include <Eigen/Geometry>

#include "plumb/bim/floor_plan.hpp"
#include "plumb/bim/mesh.hpp"
#include "plumb/io/frame_dump.hpp"
#include "plumb/sim/imu_model.hpp"
#include "plumb/sim/lidar.hpp"
#include "plumb/sim/robot.hpp"
#include "plumb/sim/route.hpp"
#include "plumb/sim/wheel_model.hpp"
#include "plumb/sim/world.hpp"

namespace plumb::sim {

/// @brief Kind of scenario.
enum class ScenarioKind {
  kIndoor,  ///< loop through the rooms of the storey with the largest free floor area
  kSite,    ///< the building standing in a large flat open site, driven around outside
};

/// @brief Parse "indoor" / "site". @throws plumb::Error otherwise.
ScenarioKind scenario_kind_from_string(const std::string& name);
/// @brief "indoor" / "site".
std::string to_string(ScenarioKind kind);

/// @brief Settings of plan_scenario() and simulate_scenario(). Start from scenario_defaults(kind).
struct ScenarioSettings {
  ScenarioKind kind = ScenarioKind::kIndoor;
  LidarModel lidar;              ///< the LiDAR (indoor default rfans32, site default vlp16)
  int loops = 2;                 ///< times the route is driven
  double length = 0.0;           ///< stop after this distance [m]; 0 = drive all loops
  int storey = -1;               ///< indoor: storey index, -1 = largest free floor area
  double site_min_length = 300.0;   ///< site: the whole drive is at least this long [m]
  double site_margin = 6.0;         ///< site: distance of the route from the building's bounds [m]
  double site_excursion = 40.0;     ///< site: at least this long a stretch away from the building [m]
  double site_ground_margin = 120.0;  ///< site: ground plane beyond the route [m]
  double site_tile = 10.0;          ///< site: ground tile size (each tile gets its own as-built deviation) [m]
  WorldSettings world;           ///< as-built deviations, clutter, people, seed (its seed is overridden by `seed`)
  bim::OccupancyGridSettings floor_plan;
  RouteSettings route;
  RobotSettings robot;
  WheelSettings wheels;          ///< nominal wheel geometry and its true errors (seed overridden)
  ImuSettings imu;               ///< indoor 200 Hz, site 300 Hz (seed overridden)
  SweepSettings sweep;
  Eigen::Isometry3d T_base_lidar = Eigen::Isometry3d::Identity();  ///< LiDAR mounting on the base
  Eigen::Isometry3d T_base_imu = Eigen::Isometry3d::Identity();    ///< IMU mounting on the base
  std::uint64_t seed = 1;        ///< the world, noise of every sensor: everything random depends on this only
  int num_threads = 1;           ///< frames simulated in parallel (results identical for any count)
  io::FrameDumpWriteSettings dump;  ///< PCD encoding, overwrite
  std::string model_name;        ///< recorded in meta.json
  /// Called after each frame is written with (frames done, frames total); may be empty.
  std::function<void(std::size_t, std::size_t)> progress;
};

/// @brief Defaults of a scenario kind (sensors, speeds, mounting).
ScenarioSettings scenario_defaults(ScenarioKind kind);

/// @brief Everything decided before any ray is cast.
struct ScenarioPlan {
  std::shared_ptr<const bim::BimMesh> mesh;  ///< the model (site: plus the ground tiles)
  std::shared_ptr<const World> world;        ///< the as-built world the LiDAR sees
  bim::OccupancyGrid grid;                   ///< indoor: floor plan with clutter; site: empty
  Route route;                               ///< the closed route driven
  RobotTrajectory trajectory;                ///< dense true motion of the base
  std::vector<double> frame_stamps;          ///< start of each LiDAR sweep [s]
  int storey = -1;                           ///< the storey driven (indoor) or standing on (site)
  double floor_z = 0.0;                      ///< z of the floor / ground driven on [m]
};

/// @brief Floor plan, world, route and true motion for a scenario.
/// @throws plumb::Error when the model has no walkable storey (indoor), no storey (site), or bad settings.
ScenarioPlan plan_scenario(const bim::BimMesh& mesh, const ScenarioSettings& settings);

/// @brief Summary of a simulation.
struct ScenarioResult {
  std::size_t num_frames = 0;
  std::size_t num_points = 0;     ///< returns over all frames
  double path_length = 0.0;       ///< distance driven [m]
  double duration = 0.0;          ///< simulated time [s]
  double wall_seconds = 0.0;      ///< time this call took [s]
  int storey = -1;
  std::string storey_name;
};

/// @brief Plan and run a scenario, writing a frame dump into `out_dir` (see io/frame_dump.hpp):
///        one LiDAR sweep per 1 / lidar.rate_hz, wheels at wheels.rate_hz, odometry integrated with
///        the nominal wheel parameters, IMU at imu.rate_hz, gt.tum at the frame stamps and
///        gt_dense.tum at robot.rate_hz.
/// @throws plumb::Error as plan_scenario(), or when the dump cannot be written.
/// @note Deterministic for a seed, whatever num_threads.
ScenarioResult simulate_scenario(const bim::BimMesh& mesh, const std::string& out_dir,
                                 const ScenarioSettings& settings);

/// @brief simulate_scenario() on a plan made before.
ScenarioResult simulate_scenario(const ScenarioPlan& plan, const std::string& out_dir,
                                 const ScenarioSettings& settings);

}  // namespace plumb::sim
