// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief Top-view SVG plots: a floor plan as line segments plus trajectories and coloured shapes,
///        in metres, with a legend, a colour bar and a scale bar (the `trajectory.svg` and
///        `deviations.svg` of `plumb run`). x to the right, y up.

#include <array>
#include <string>
#include <utility>
#include <vector>

#include "plumb/core/trajectory.hpp"
#include "plumb/core/types.hpp"

namespace plumb::io {

/// @brief One polyline of the plot: a trajectory's (x, y) or any path. A path without points shows
///        only in the legend.
struct SvgPath {
  std::string label;               ///< legend text (empty: not in the legend)
  std::string color = "#1f77b4";   ///< any SVG colour
  double width = 2.0;              ///< stroke width [px]
  bool dashed = false;
  std::vector<Vector2d> points;    ///< [m]
  std::vector<std::size_t> markers; ///< indices of points to mark with a small circle (e.g. observation points)
};

/// @brief One object drawn over the floor plan (e.g. a building element): segments and diamond
///        markers in one colour, as one SVG group `<g>`.
struct SvgShape {
  std::string id;               ///< the group's id attribute, an XML name (empty: none)
  std::string css_class;        ///< the group's class attribute (empty: none)
  std::string tooltip;          ///< the group's `<title>`, which browsers show on hover (empty: none)
  std::string color = "#1f77b4";  ///< any SVG colour: the segments' stroke, the markers' fill
  std::string outline;          ///< colour of an outline around segments and markers (empty: none)
  double width = 4.0;           ///< stroke width of the segments [px]
  bool dashed = false;
  std::vector<std::array<Vector2d, 2>> segments;  ///< [m]
  std::vector<Vector2d> markers;                  ///< diamond centres [m]
  std::string label;            ///< text beside the first segment's midpoint, else the first marker (empty: none)
};

/// @brief A horizontal colour bar: a linear gradient through colour stops, with labelled ticks.
struct SvgColorBar {
  std::string title;  ///< e.g. "offset [cm]", left of the bar
  /// (value, colour) by increasing value, at least two to draw a bar (empty: no bar). Values are in
  /// the caller's unit, as are the ticks.
  std::vector<std::pair<double, std::string>> stops;
  std::vector<double> ticks;  ///< values labelled under the bar (within the stops' range)
};

/// @brief A whole plot.
struct SvgPlot {
  std::string title;
  std::vector<std::array<Vector2d, 2>> floor_plan;  ///< wall segments [m], drawn thin grey
  std::vector<SvgShape> shapes;  ///< drawn over the floor plan, under the paths
  std::vector<SvgPath> paths;
  SvgColorBar color_bar;         ///< bottom right
  double width_px = 1000.0;  ///< drawing width; height follows the data's aspect ratio
  double margin_px = 40.0;

  /// @brief Add a trajectory's x, y as a path.
  void add_trajectory(const Trajectory& trajectory, const std::string& label, const std::string& color,
                      bool dashed = false);
};

/// @brief Colour of `value` on a diverging scale, "#RRGGBB": blue (#2166AC) at -limit, light grey
///        (#F7F7F7) at 0, red (#B2182B) at +limit, linear in between in each 8-bit channel (rounded
///        to nearest), clipped beyond +-limit.
/// @throws plumb::Error for a non-finite value or a limit that is not positive and finite.
std::string diverging_color(double value, double limit);

/// @brief The stops of diverging_color() over [-limit, limit], for SvgColorBar::stops.
std::vector<std::pair<double, std::string>> diverging_color_stops(double limit);

/// @brief The plot as SVG text. An empty plot (no segment, no point) gives a valid empty drawing.
/// @throws plumb::Error for non-finite coordinates or a non-positive width, or colour-bar stops that do
///         not increase.
std::string render_svg(const SvgPlot& plot);

/// @brief Write render_svg(plot) to `path`. @throws plumb::Error if the file cannot be written.
void write_svg(const SvgPlot& plot, const std::string& path);

}  // namespace plumb::io
