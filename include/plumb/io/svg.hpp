// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief Top-view SVG plots: a floor plan as line segments plus trajectories, in metres, with a
///        legend and a scale bar (the `trajectory.svg` of `plumb run`). x to the right, y up.

#include <array>
#include <string>
#include <vector>

#include "plumb/core/trajectory.hpp"
#include "plumb/core/types.hpp"

namespace plumb::io {

/// @brief One polyline of the plot: a trajectory's (x, y) or any path.
struct SvgPath {
  std::string label;               ///< legend text (empty: not in the legend)
  std::string color = "#1f77b4";   ///< any SVG colour
  double width = 2.0;              ///< stroke width [px]
  bool dashed = false;
  std::vector<Vector2d> points;    ///< [m]
  std::vector<std::size_t> markers; ///< indices of points to mark with a small circle (e.g. observation points)
};

/// @brief A whole plot.
struct SvgPlot {
  std::string title;
  std::vector<std::array<Vector2d, 2>> floor_plan;  ///< wall segments [m], drawn thin grey
  std::vector<SvgPath> paths;
  double width_px = 1000.0;  ///< drawing width; height follows the data's aspect ratio
  double margin_px = 40.0;

  /// @brief Add a trajectory's x, y as a path.
  void add_trajectory(const Trajectory& trajectory, const std::string& label, const std::string& color,
                      bool dashed = false);
};

/// @brief The plot as SVG text. An empty plot (no segment, no point) gives a valid empty drawing.
/// @throws plumb::Error for non-finite coordinates or a non-positive width.
std::string render_svg(const SvgPlot& plot);

/// @brief Write render_svg(plot) to `path`. @throws plumb::Error if the file cannot be written.
void write_svg(const SvgPlot& plot, const std::string& path);

}  // namespace plumb::io
