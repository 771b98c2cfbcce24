// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/io/svg.hpp"

#include <cmath>
#include <sstream>
#include <string>
#include <utility>

#include <gtest/gtest.h>

#include "io_test_util.hpp"
#include "test_data.hpp"

namespace {

using plumb::Vector2d;
using plumb::io::render_svg;
using plumb::io::SvgPlot;

/// The numbers of the `points` attribute of the n-th polyline.
std::vector<double> polyline_numbers(const std::string& svg, int n) {
  std::size_t pos = 0;
  for (int i = 0; i <= n; ++i) {
    pos = svg.find("<polyline", pos);
    if (pos == std::string::npos) return {};
    if (i < n) ++pos;
  }
  const std::size_t a = svg.find("points=\"", pos) + 8, b = svg.find('"', a);
  std::string s = svg.substr(a, b - a);
  for (char& c : s)
    if (c == ',') c = ' ';
  std::istringstream in(s);
  std::vector<double> v;
  for (double x; in >> x;) v.push_back(x);
  return v;
}

TEST(SvgTest, PathsAreScaledUniformlyWithYUp) {
  SvgPlot plot;
  plot.width_px = 1040;
  plot.margin_px = 20;
  plot.paths.push_back({"a", "red", 2.0, false, {{0, 0}, {10, 0}, {10, 5}}, {}});
  const std::string svg = render_svg(plot);
  const auto v = polyline_numbers(svg, 0);
  ASSERT_EQ(v.size(), 6u);
  // 10 m wide into 1000 px: 100 px per metre, origin at the margin, y flipped.
  EXPECT_DOUBLE_EQ(v[0], 20.0);
  EXPECT_DOUBLE_EQ(v[2], 1020.0);
  EXPECT_DOUBLE_EQ(v[1], v[3]);
  EXPECT_DOUBLE_EQ(v[1] - v[5], 500.0);  // 5 m up = 500 px towards the top
  EXPECT_EQ(svg.rfind("</svg>\n"), svg.size() - 7);
}

TEST(SvgTest, TrajectoriesFloorPlanLegendAndEscaping) {
  SvgPlot plot;
  plot.title = "run <1> & \"2\"";
  plot.floor_plan.push_back({Vector2d(-1, -1), Vector2d(4, -1)});
  plumb::Trajectory t;
  for (int i = 0; i < 5; ++i) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.translation() << i, 0.5 * i, 9.0;  // z is ignored
    t.push_back(i, T);
  }
  plot.add_trajectory(t, "bim", "#2ca02c");
  plot.add_trajectory(t, "", "black", true);
  plot.paths[0].markers = {2, 99};  // out-of-range markers are skipped
  const std::string svg = render_svg(plot);
  EXPECT_NE(svg.find("run &lt;1&gt; &amp; &quot;2&quot;"), std::string::npos);
  EXPECT_NE(svg.find(">bim</text>"), std::string::npos);
  EXPECT_EQ(polyline_numbers(svg, 0).size(), 10u);
  EXPECT_NE(svg.find("stroke-dasharray"), std::string::npos);
  std::size_t circles = 0;
  for (std::size_t pos = svg.find("<circle"); pos != std::string::npos; pos = svg.find("<circle", pos + 1)) ++circles;
  EXPECT_EQ(circles, 1u);
  EXPECT_NE(svg.find("<line x1"), std::string::npos);
  const std::string path = plumb::test::temp_path("plot.svg");
  plumb::io::write_svg(plot, path);
  std::ifstream in(path);
  EXPECT_EQ(std::string(std::istreambuf_iterator<char>(in), {}), svg);
}

TEST(SvgTest, EmptyPlotIsValidAndBadInputThrows) {
  const std::string svg = render_svg(SvgPlot{});
  EXPECT_EQ(svg.find("<svg"), 0u);
  EXPECT_NE(svg.find("</svg>"), std::string::npos);
  SvgPlot bad;
  bad.paths.push_back({"x", "red", 1.0, false, {{0, NAN}}, {}});
  plumb::test::expect_error([&] { render_svg(bad); }, {"non-finite", "x"});
  SvgPlot narrow;
  narrow.width_px = 10;
  plumb::test::expect_error([&] { render_svg(narrow); }, {"width_px"});
  plumb::test::expect_error([&] { plumb::io::write_svg(SvgPlot{}, "/nonexistent/dir/p.svg"); }, {"/nonexistent/dir/p.svg"});
}

// The diverging scale: its three end and middle colours, linear in each channel between them
// (+1 of 3: a third of the way from #F7F7F7 to #B2182B, rounded), clipped beyond the limit.
TEST(SvgTest, DivergingColoursRunFromBlueThroughGreyToRed) {
  using plumb::io::diverging_color;
  EXPECT_EQ(diverging_color(-3.0, 3.0), "#2166AC");
  EXPECT_EQ(diverging_color(0.0, 3.0), "#F7F7F7");
  EXPECT_EQ(diverging_color(3.0, 3.0), "#B2182B");
  EXPECT_EQ(diverging_color(1.0, 3.0), "#E0ADB3");
  EXPECT_EQ(diverging_color(-1.0, 3.0), "#B0C7DE");  // 0x21 + (0xF7 - 0x21) * 2 / 3 = 175.7 -> 0xB0, ...
  EXPECT_EQ(diverging_color(-90.0, 3.0), "#2166AC");
  EXPECT_EQ(diverging_color(90.0, 3.0), "#B2182B");
  const auto stops = plumb::io::diverging_color_stops(3.0);
  ASSERT_EQ(stops.size(), 3u);
  EXPECT_EQ(stops.front(), std::make_pair(-3.0, std::string("#2166AC")));
  EXPECT_EQ(stops.back(), std::make_pair(3.0, std::string("#B2182B")));
  plumb::test::expect_error([] { diverging_color(1.0, 0.0); }, {"limit"});
  plumb::test::expect_error([] { diverging_color(NAN, 1.0); }, {"not finite"});
}

// A shape is one group with its id, class and tooltip, its segments in its colour (dashed when
// asked, under an outline when given) and its markers as diamonds; the colour bar is a gradient
// through the stops with the ticks in its range labelled, and stops that do not increase are refused.
TEST(SvgTest, ShapesAndColourBar) {
  SvgPlot plot;
  plumb::io::SvgShape wall;
  wall.id = "element-7";
  wall.css_class = "element deviates";
  wall.tooltip = "Wall <north> & co";
  wall.color = "#B2182B";
  wall.outline = "#000000";
  wall.label = "north +4.0 cm";
  wall.segments = {{Vector2d(0, 0), Vector2d(10, 0)}, {Vector2d(10, 0), Vector2d(10, 5)}};
  plumb::io::SvgShape slab;
  slab.color = "#BBBBBB";
  slab.dashed = true;
  slab.markers = {Vector2d(5, 2)};
  plot.shapes = {wall, slab};
  plot.color_bar.title = "offset [cm]";
  plot.color_bar.stops = plumb::io::diverging_color_stops(3.0);
  plot.color_bar.ticks = {-3.0, 0.0, 3.0, 7.0};
  const std::string svg = render_svg(plot);
  EXPECT_NE(svg.find("<g id=\"element-7\" class=\"element deviates\">\n<title>Wall &lt;north&gt; &amp; co</title>"),
            std::string::npos);
  EXPECT_NE(svg.find("<g stroke=\"#000000\" stroke-width=\"8.00\""), std::string::npos);
  EXPECT_NE(svg.find("<g stroke=\"#B2182B\" stroke-width=\"4.00\">"), std::string::npos);
  EXPECT_NE(svg.find(">north +4.0 cm</text>"), std::string::npos);
  std::size_t lines = 0, polygons = 0;
  for (std::size_t p = svg.find("<line x1"); p != std::string::npos; p = svg.find("<line x1", p + 1)) ++lines;
  for (std::size_t p = svg.find("<polygon"); p != std::string::npos; p = svg.find("<polygon", p + 1)) ++polygons;
  EXPECT_EQ(polygons, 1u);
  EXPECT_NE(svg.find("fill=\"#BBBBBB\""), std::string::npos);
  EXPECT_EQ(lines, 2u * 2u + 3u + 1u);  // outline and colour, three ticks in range, the scale bar
  EXPECT_NE(svg.find("<stop offset=\"0.50\" stop-color=\"#F7F7F7\"/>"), std::string::npos);
  EXPECT_NE(svg.find(">offset [cm]</text>"), std::string::npos);
  for (const char* tick : {">-3</text>", ">0</text>", ">+3</text>"}) EXPECT_NE(svg.find(tick), std::string::npos) << tick;
  EXPECT_EQ(svg.find(">+7</text>"), std::string::npos);
  plot.color_bar.stops = {{1.0, "#000000"}, {1.0, "#FFFFFF"}};
  plumb::test::expect_error([&] { render_svg(plot); }, {"do not increase"});
}

}  // namespace
