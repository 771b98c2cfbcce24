// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief An IFC model: the indexed STEP file plus its schema and units (Liu et al. 2022, sec. 1.1).

#include <string>
#include <vector>

#include "plumb/bim/step.hpp"

namespace plumb::bim {

/// @brief Units of an IFC project (IfcUnitAssignment), as factors to SI.
struct IfcUnits {
  double length_to_m = 1.0;     ///< one file length unit in metres (0.001 for millimetres)
  double angle_to_rad = 1.0;    ///< one file plane-angle unit in radians (pi/180 for degrees)
  std::string length_name = "METRE";  ///< e.g. "MILLI METRE", "FOOT"
  std::string angle_name = "RADIAN";  ///< e.g. "RADIAN", "DEGREE"
};

/// @brief A parsed IFC file: STEP index + units. Geometry is built from it by build_mesh().
struct IfcModel {
  StepFile step;
  IfcUnits units;
  std::vector<std::string> warnings;  ///< non-fatal problems found while reading units
};

/// @brief Read an IFC (STEP physical file) from disk.
/// @throws plumb::Error `path:LINE: message` on a malformed file or a schema other than IFC2X3/IFC4/IFC4X3.
IfcModel read_ifc(const std::string& path);

/// @brief Parse an IFC held in memory; `name` is used in messages. @see read_ifc
IfcModel parse_ifc(std::string buffer, const std::string& name = "<memory>");

/// @brief Units of a STEP file from its IfcUnitAssignment (metre / radian when absent).
/// @param warnings receives non-fatal problems (missing or odd units).
IfcUnits read_ifc_units(const StepFile& step, std::vector<std::string>* warnings = nullptr);

/// @brief Mixed-case IFC name from the file's upper-case one ("IFCWALLSTANDARDCASE" ->
/// "IfcWallStandardCase"); unknown names become "Ifc" + the rest in lower case.
std::string ifc_type_display_name(const std::string& upper);

}  // namespace plumb::bim
