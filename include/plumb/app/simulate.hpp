// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief A simulated scenario written as a frame dump directory (what `plumb simulate` does): the
///        frames of sim::simulate_scenario() streamed to DIR/frames as they are made, then the wheel
///        encoders, wheel odometry, IMU, ground truth and the elements as built (io/frame_dump.hpp).
///        Also the LiDAR model file of `plumb simulate --lidar FILE.json`.

#include <cstddef>
#include <functional>
#include <string>

#include "plumb/bim/mesh.hpp"
#include "plumb/io/frame_dump.hpp"
#include "plumb/sim/lidar.hpp"
#include "plumb/sim/scenario.hpp"

namespace plumb {

/// @brief Settings of simulate_to_dump(): how the dump is written (what is simulated is sim::ScenarioSettings).
struct SimulateDumpSettings {
  io::FrameDumpWriteSettings dump;  ///< PCD encoding, overwrite
  std::string model_name;           ///< recorded in meta.json
  /// Called after each frame is written with (frames done, frames total); may be empty.
  std::function<void(std::size_t done, std::size_t total)> progress;
};

/// @brief meta.json of a simulated dump: the LiDAR, mountings and nominal wheels of `scenario`, the
///        origin offset of the planned model, the seed (in `source`), `model_name` and the scenario kind.
io::FrameDumpMeta simulated_dump_meta(const sim::ScenarioPlan& plan, const sim::ScenarioSettings& scenario,
                                      const std::string& model_name);

/// @brief Plan and run a scenario (sim::plan_scenario(), sim::simulate_scenario()), writing a frame
///        dump into `out_dir`: meta.json (simulated_dump_meta()), frames.csv and frames/NNNNNN.pcd
///        (one per LiDAR sweep, written as it is made), wheels.csv, odom.csv, imu.csv, gt.tum at the
///        frame stamps, gt_dense.tum at robot.rate_hz and as_built.json (every element's true
///        as-built displacement, sim::ScenarioRecording::as_built).
/// @throws plumb::Error as sim::plan_scenario() (before anything is written), or when the dump cannot
///         be written (an existing dump without `settings.dump.overwrite`: before any frame is simulated).
/// @note Deterministic for a seed, whatever num_threads.
sim::ScenarioResult simulate_to_dump(const bim::BimMesh& mesh, const std::string& out_dir,
                                     const sim::ScenarioSettings& scenario, const SimulateDumpSettings& settings = {});

/// @brief Read a LiDAR model file (sim::parse_lidar_model() on its text).
/// @throws plumb::Error naming the path when it cannot be opened or read, or as sim::parse_lidar_model().
sim::LidarModel read_lidar_model(const std::string& path);

}  // namespace plumb
