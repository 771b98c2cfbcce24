// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief Simulation scenarios: a robot driving through (`indoor`) or around (`site`) a real
///        building, with LiDAR frames, wheel encoders, wheel odometry, IMU and exact ground truth.
///        The frames are handed to a callback as they are made; app/simulate.hpp writes them, with
///        the rest, as a frame dump directory.

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "plumb/bim/floor_plan.hpp"
#include "plumb/bim/mesh.hpp"
#include "plumb/core/as_built.hpp"
#include "plumb/core/point_cloud.hpp"
#include "plumb/core/sensor_data.hpp"
#include "plumb/core/trajectory.hpp"
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

/// @brief Everything a simulation gives besides its LiDAR frames (those go to the ScenarioFrameSink).
struct ScenarioRecording {
  ScenarioResult summary;
  std::vector<WheelEncoderReading> wheels;  ///< at wheels.rate_hz over the whole drive
  std::vector<OdomSample> odometry;         ///< `wheels` integrated with the nominal wheel parameters
  std::vector<ImuSample> imu;               ///< at imu.rate_hz, IMU frame
  Trajectory ground_truth;                  ///< true T_world_base at the frame stamps
  Trajectory ground_truth_dense;            ///< true T_world_base at robot.rate_hz
  /// World::element_deviation() of every element of the planned model (ScenarioPlan::mesh; site:
  /// the ground tiles too), in element order, with its global_id and type.
  std::vector<ElementDeviation> as_built;
};

/// @brief Receives each LiDAR frame as soon as it is made, in order: its index, its stamp (start of
///        the sweep [s]) and its points in the LiDAR frame (x y z intensity ring time label; time [s]
///        since the stamp). The cloud is valid during the call only (copy what you keep). Called
///        on the calling thread; an exception thrown by it ends the simulation. May be empty.
using ScenarioFrameSink = std::function<void(std::size_t index, double stamp, const PointCloud& cloud_lidar)>;

/// @brief Plan and run a scenario: one LiDAR sweep per 1 / lidar.rate_hz handed to `on_frame`,
///        wheels at wheels.rate_hz, odometry integrated with the nominal wheel parameters, IMU at
///        imu.rate_hz, ground truth at the frame stamps and at robot.rate_hz. Frames are not held:
///        at most num_threads of them are in memory at a time.
/// @throws plumb::Error as plan_scenario(); what `on_frame` throws.
/// @note Deterministic for a seed, whatever num_threads.
ScenarioRecording simulate_scenario(const bim::BimMesh& mesh, const ScenarioSettings& settings,
                                    const ScenarioFrameSink& on_frame);

/// @brief simulate_scenario() on a plan made before.
/// @throws plumb::Error on bad settings or an empty plan; what `on_frame` throws.
ScenarioRecording simulate_scenario(const ScenarioPlan& plan, const ScenarioSettings& settings,
                                    const ScenarioFrameSink& on_frame);

}  // namespace plumb::sim
