// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief The short simulated site run the LiDAR/IMU odometry tests share, as a frame dump.

#include <unistd.h>

#include <filesystem>
#include <string>

#include "plumb/app/simulate.hpp"
#include "plumb/bim/ifc.hpp"
#include "plumb/bim/mesh.hpp"
#include "plumb/sim/scenario.hpp"
#include "test_data.hpp"

namespace plumb::test {

/// @brief Simulates a short site run into a fresh frame dump under the build tree: 1 s standing,
///        then 3 m along FZK-Haus (the kSite scenario's defaults with seed 4: 16-line LiDAR, 300 Hz
///        IMU). `dir` is set to the dump's path (`name`, then the process id) before the run starts,
///        so a teardown removes a partial dump too; it stays as it is when the model is not in the
///        data directory.
inline void simulate_fzk_site_run(const std::string& name, std::string& dir) {
  const std::string ifc = data_path("ifc/buildings/AC20-FZK-Haus.ifc");
  if (!file_exists(ifc)) return;
  dir = temp_path(name + "_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  sim::ScenarioSettings s = sim::scenario_defaults(sim::ScenarioKind::kSite);
  s.length = 3.0;
  s.seed = 4;
  simulate_to_dump(bim::build_mesh(bim::read_ifc(ifc)), dir, s);
}

}  // namespace plumb::test
