// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief How a building element stands as built relative to its design: the type the simulator
///        hands out (sim::ScenarioRecording::as_built) and a frame dump's as_built.json holds
///        (io/frame_dump.hpp), defined once.

#include <string>

#include <Eigen/Geometry>

namespace plumb {

/// @brief The true displacement of one BIM element: its as-built points are
///        `T_design_asbuilt * design point`, both in the world (BIM mesh) frame.
struct ElementDeviation {
  std::string global_id;  ///< IFC GlobalId of the element
  std::string type;       ///< IFC type, e.g. "IfcWallStandardCase"
  Eigen::Isometry3d T_design_asbuilt = Eigen::Isometry3d::Identity();  ///< rigid motion, world frame
};

}  // namespace plumb
