// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/io/svg.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <sstream>

#include "plumb/core/error.hpp"
#include "xml_text.hpp"

namespace plumb::io {
namespace {

using detail::xml_escape;

std::string fmt(double v) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.2f", v);
  return buf;
}

/// Largest "nice" length (1, 2, 5 x 10^k) not above `limit`.
double nice_length(double limit) {
  const double p = std::pow(10.0, std::floor(std::log10(limit)));
  for (double m : {5.0, 2.0, 1.0})
    if (m * p <= limit) return m * p;
  return p;
}

}  // namespace

void SvgPlot::add_trajectory(const Trajectory& trajectory, const std::string& label, const std::string& color,
                             bool dashed) {
  SvgPath path;
  path.label = label;
  path.color = color;
  path.dashed = dashed;
  path.points.reserve(trajectory.size());
  for (const auto& T : trajectory.poses) path.points.emplace_back(T.translation().x(), T.translation().y());
  paths.push_back(std::move(path));
}

std::string render_svg(const SvgPlot& plot) {
  PLUMB_CHECK(plot.width_px > 0.0 && std::isfinite(plot.width_px) && plot.margin_px >= 0.0 &&
                  2.0 * plot.margin_px < plot.width_px,
              "render_svg: width_px = " << plot.width_px << " and margin_px = " << plot.margin_px
                                        << " leave no drawing area");
  const double inf = std::numeric_limits<double>::infinity();
  Vector2d lo(inf, inf), hi(-inf, -inf);
  auto grow = [&](const Vector2d& p, const char* what) {
    PLUMB_CHECK(p.allFinite(), "render_svg: non-finite coordinate in " << what);
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  };
  for (const auto& s : plot.floor_plan) {
    grow(s[0], "the floor plan");
    grow(s[1], "the floor plan");
  }
  for (const auto& path : plot.paths)
    for (const auto& p : path.points) grow(p, path.label.empty() ? "a path" : path.label.c_str());
  if (!(lo.x() <= hi.x())) lo = hi = Vector2d::Zero();
  const Vector2d extent = (hi - lo).cwiseMax(Vector2d::Constant(1.0));
  const double inner = plot.width_px - 2.0 * plot.margin_px;
  const double scale = inner / std::max(extent.x(), extent.y() * 0.5);  // px per metre; at most 2:1 tall
  const double height = 2.0 * plot.margin_px + extent.y() * scale + 30.0;
  auto X = [&](double x) { return plot.margin_px + (x - lo.x()) * scale; };
  auto Y = [&](double y) { return plot.margin_px + (hi.y() - y) * scale; };

  std::ostringstream o;
  o << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" << fmt(plot.width_px) << "\" height=\"" << fmt(height)
    << "\" viewBox=\"0 0 " << fmt(plot.width_px) << ' ' << fmt(height) << "\">\n";
  o << "<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n";
  if (!plot.title.empty()) {
    o << "<text x=\"" << fmt(plot.margin_px) << "\" y=\"" << fmt(plot.margin_px * 0.6)
      << "\" font-family=\"sans-serif\" font-size=\"16\">" << xml_escape(plot.title) << "</text>\n";
  }
  if (!plot.floor_plan.empty()) {
    o << "<g stroke=\"#888888\" stroke-width=\"1\">\n";
    for (const auto& s : plot.floor_plan) {
      o << "<line x1=\"" << fmt(X(s[0].x())) << "\" y1=\"" << fmt(Y(s[0].y())) << "\" x2=\"" << fmt(X(s[1].x()))
        << "\" y2=\"" << fmt(Y(s[1].y())) << "\"/>\n";
    }
    o << "</g>\n";
  }
  for (const auto& path : plot.paths) {
    if (path.points.empty()) continue;
    o << "<polyline fill=\"none\" stroke=\"" << xml_escape(path.color) << "\" stroke-width=\"" << fmt(path.width)
      << "\"" << (path.dashed ? " stroke-dasharray=\"6,4\"" : "") << " points=\"";
    for (std::size_t i = 0; i < path.points.size(); ++i) {
      o << (i ? " " : "") << fmt(X(path.points[i].x())) << ',' << fmt(Y(path.points[i].y()));
    }
    o << "\"/>\n";
    for (std::size_t m : path.markers) {
      if (m >= path.points.size()) continue;
      o << "<circle cx=\"" << fmt(X(path.points[m].x())) << "\" cy=\"" << fmt(Y(path.points[m].y()))
        << "\" r=\"4\" fill=\"" << xml_escape(path.color) << "\"/>\n";
    }
  }
  // Legend, top right.
  double ly = plot.margin_px;
  for (const auto& path : plot.paths) {
    if (path.label.empty()) continue;
    const double lx = plot.width_px - plot.margin_px - 180.0;
    o << "<line x1=\"" << fmt(lx) << "\" y1=\"" << fmt(ly) << "\" x2=\"" << fmt(lx + 30) << "\" y2=\"" << fmt(ly)
      << "\" stroke=\"" << xml_escape(path.color) << "\" stroke-width=\"3\""
      << (path.dashed ? " stroke-dasharray=\"6,4\"" : "") << "/>\n";
    o << "<text x=\"" << fmt(lx + 36) << "\" y=\"" << fmt(ly + 5)
      << "\" font-family=\"sans-serif\" font-size=\"13\">" << xml_escape(path.label) << "</text>\n";
    ly += 20.0;
  }
  // Scale bar, bottom left.
  const double bar_m = nice_length(extent.x() / 4.0);
  const double by = height - 15.0;
  o << "<line x1=\"" << fmt(plot.margin_px) << "\" y1=\"" << fmt(by) << "\" x2=\"" << fmt(plot.margin_px + bar_m * scale)
    << "\" y2=\"" << fmt(by) << "\" stroke=\"black\" stroke-width=\"2\"/>\n";
  o << "<text x=\"" << fmt(plot.margin_px + bar_m * scale + 6) << "\" y=\"" << fmt(by + 4)
    << "\" font-family=\"sans-serif\" font-size=\"12\">" << bar_m << " m</text>\n";
  o << "</svg>\n";
  return o.str();
}

void write_svg(const SvgPlot& plot, const std::string& path) {
  const std::string text = render_svg(plot);
  std::ofstream out(path, std::ios::binary);
  PLUMB_CHECK(out.is_open(), path << ": cannot open file for writing");
  out << text;
  out.flush();
  PLUMB_CHECK(out.good(), path << ": write error");
}

}  // namespace plumb::io
