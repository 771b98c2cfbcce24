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

/// Metres to pixels: x to the right, y up.
struct PixelFrame {
  Vector2d lo, hi;
  double scale = 1.0, margin = 0.0;
  double x(double v) const { return margin + (v - lo.x()) * scale; }
  double y(double v) const { return margin + (hi.y() - v) * scale; }
};

void write_lines(std::ostringstream& o, const std::vector<std::array<Vector2d, 2>>& segments, const PixelFrame& f) {
  for (const auto& s : segments) {
    o << "<line x1=\"" << fmt(f.x(s[0].x())) << "\" y1=\"" << fmt(f.y(s[0].y())) << "\" x2=\"" << fmt(f.x(s[1].x()))
      << "\" y2=\"" << fmt(f.y(s[1].y())) << "\"/>\n";
  }
}

void write_shape(std::ostringstream& o, const SvgShape& shape, const PixelFrame& f) {
  o << "<g";
  if (!shape.id.empty()) o << " id=\"" << xml_escape(shape.id) << '"';
  if (!shape.css_class.empty()) o << " class=\"" << xml_escape(shape.css_class) << '"';
  o << ">\n";
  if (!shape.tooltip.empty()) o << "<title>" << xml_escape(shape.tooltip) << "</title>\n";
  const std::string dash = shape.dashed ? " stroke-dasharray=\"6,4\"" : "";
  if (!shape.outline.empty() && !shape.segments.empty()) {
    o << "<g stroke=\"" << xml_escape(shape.outline) << "\" stroke-width=\"" << fmt(shape.width + 4.0)
      << "\" stroke-linecap=\"round\">\n";
    write_lines(o, shape.segments, f);
    o << "</g>\n";
  }
  if (!shape.segments.empty()) {
    o << "<g stroke=\"" << xml_escape(shape.color) << "\" stroke-width=\"" << fmt(shape.width) << '"' << dash << ">\n";
    write_lines(o, shape.segments, f);
    o << "</g>\n";
  }
  const double r = 3.0 + shape.width;
  for (const Vector2d& m : shape.markers) {
    const double cx = f.x(m.x()), cy = f.y(m.y());
    o << "<polygon points=\"" << fmt(cx) << ',' << fmt(cy - r) << ' ' << fmt(cx + r) << ',' << fmt(cy) << ' '
      << fmt(cx) << ',' << fmt(cy + r) << ' ' << fmt(cx - r) << ',' << fmt(cy) << "\" fill=\"" << xml_escape(shape.color)
      << "\" stroke=\"" << xml_escape(shape.outline.empty() ? std::string("#555555") : shape.outline)
      << "\" stroke-width=\"" << (shape.outline.empty() ? "1" : "2") << "\"/>\n";
  }
  if (!shape.label.empty() && (!shape.segments.empty() || !shape.markers.empty())) {
    const Vector2d at = shape.segments.empty() ? shape.markers.front()
                                               : Vector2d(0.5 * (shape.segments.front()[0] + shape.segments.front()[1]));
    o << "<text x=\"" << fmt(f.x(at.x()) + r + 2.0) << "\" y=\"" << fmt(f.y(at.y()) - r - 2.0)
      << "\" font-family=\"sans-serif\" font-size=\"12\">" << xml_escape(shape.label) << "</text>\n";
  }
  o << "</g>\n";
}

/// The colour bar, 200 px wide, bottom right.
void write_color_bar(std::ostringstream& o, const SvgColorBar& bar, double width, double height, double margin) {
  if (bar.stops.size() < 2) return;
  const double v0 = bar.stops.front().first, v1 = bar.stops.back().first;
  const double bar_px = 200.0, x0 = width - margin - bar_px, y0 = height - 42.0;
  auto X = [&](double v) { return x0 + bar_px * (v - v0) / (v1 - v0); };
  o << "<defs><linearGradient id=\"plumb-color-bar\" x1=\"0\" x2=\"1\" y1=\"0\" y2=\"0\">\n";
  for (const auto& [value, color] : bar.stops) {
    o << "<stop offset=\"" << fmt((value - v0) / (v1 - v0)) << "\" stop-color=\"" << xml_escape(color) << "\"/>\n";
  }
  o << "</linearGradient></defs>\n";
  o << "<rect x=\"" << fmt(x0) << "\" y=\"" << fmt(y0) << "\" width=\"" << fmt(bar_px)
    << "\" height=\"12\" fill=\"url(#plumb-color-bar)\" stroke=\"#555555\" stroke-width=\"1\"/>\n";
  if (!bar.title.empty()) {
    o << "<text x=\"" << fmt(x0 - 8.0) << "\" y=\"" << fmt(y0 + 10.0)
      << "\" text-anchor=\"end\" font-family=\"sans-serif\" font-size=\"12\">" << xml_escape(bar.title) << "</text>\n";
  }
  for (double t : bar.ticks) {
    if (!(t >= v0 && t <= v1)) continue;
    o << "<line x1=\"" << fmt(X(t)) << "\" y1=\"" << fmt(y0 + 12.0) << "\" x2=\"" << fmt(X(t)) << "\" y2=\""
      << fmt(y0 + 16.0) << "\" stroke=\"#555555\"/>\n";
    char text[32];
    std::snprintf(text, sizeof(text), "%g", t);
    o << "<text x=\"" << fmt(X(t)) << "\" y=\"" << fmt(y0 + 28.0)
      << "\" text-anchor=\"middle\" font-family=\"sans-serif\" font-size=\"11\">" << (t > 0 ? "+" : "") << text
      << "</text>\n";
  }
}

/// A diverging scale's stops: (position in [-1, 1], red, green, blue).
constexpr std::array<std::array<double, 4>, 3> kDiverging = {
    {{-1.0, 0x21, 0x66, 0xAC}, {0.0, 0xF7, 0xF7, 0xF7}, {1.0, 0xB2, 0x18, 0x2B}}};

std::string hex_color(double r, double g, double b) {
  char buf[8];
  std::snprintf(buf, sizeof(buf), "#%02lX%02lX%02lX", std::lround(r), std::lround(g), std::lround(b));
  return buf;
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
  for (const auto& shape : plot.shapes) {
    const char* what = shape.id.empty() ? "a shape" : shape.id.c_str();
    for (const auto& s : shape.segments) {
      grow(s[0], what);
      grow(s[1], what);
    }
    for (const auto& m : shape.markers) grow(m, what);
  }
  const auto& stops = plot.color_bar.stops;
  for (std::size_t i = 1; i < stops.size(); ++i) {
    PLUMB_CHECK(std::isfinite(stops[i - 1].first) && std::isfinite(stops[i].first) && stops[i - 1].first < stops[i].first,
                "render_svg: the colour bar's stop values do not increase (" << stops[i - 1].first << ", "
                                                                            << stops[i].first << ")");
  }
  if (!(lo.x() <= hi.x())) lo = hi = Vector2d::Zero();
  const Vector2d extent = (hi - lo).cwiseMax(Vector2d::Constant(1.0));
  const double inner = plot.width_px - 2.0 * plot.margin_px;
  const double scale = inner / std::max(extent.x(), extent.y() * 0.5);  // px per metre; at most 2:1 tall
  const double height = 2.0 * plot.margin_px + extent.y() * scale + 30.0;
  const PixelFrame frame{lo, hi, scale, plot.margin_px};
  auto X = [&](double x) { return frame.x(x); };
  auto Y = [&](double y) { return frame.y(y); };

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
    write_lines(o, plot.floor_plan, frame);
    o << "</g>\n";
  }
  for (const auto& shape : plot.shapes) write_shape(o, shape, frame);
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
  write_color_bar(o, plot.color_bar, plot.width_px, height, plot.margin_px);
  o << "</svg>\n";
  return o.str();
}

std::string diverging_color(double value, double limit) {
  PLUMB_CHECK(std::isfinite(limit) && limit > 0.0, "diverging_color: the limit must be positive and finite, not " << limit);
  PLUMB_CHECK(std::isfinite(value), "diverging_color: the value is not finite");
  const double t = std::clamp(value / limit, -1.0, 1.0);
  const auto& a = t < 0.0 ? kDiverging[0] : kDiverging[1];
  const auto& b = t < 0.0 ? kDiverging[1] : kDiverging[2];
  const double u = (t - a[0]) / (b[0] - a[0]);
  return hex_color(a[1] + u * (b[1] - a[1]), a[2] + u * (b[2] - a[2]), a[3] + u * (b[3] - a[3]));
}

std::vector<std::pair<double, std::string>> diverging_color_stops(double limit) {
  std::vector<std::pair<double, std::string>> stops;
  for (const auto& s : kDiverging) stops.emplace_back(s[0] * limit, diverging_color(s[0] * limit, limit));
  return stops;
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
