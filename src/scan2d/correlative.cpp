// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/scan2d/correlative.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

#include <Eigen/Geometry>

#include "plumb/core/error.hpp"

namespace plumb {
namespace {


/// One branch-and-bound node: heading `a`, translation window [jx, jx + 2^h) x [jy, jy + 2^h) of
/// cells, and the upper bound of its score (the exact score at h = 0), in likelihood units 0..255.
struct Node {
  int a = 0;
  int jx = 0, jy = 0;
  int h = 0;
  long score = 0;
};

bool by_score(const Node& l, const Node& r) { return l.score > r.score; }

}  // namespace

CorrelativeMap2D::CorrelativeMap2D(const std::vector<Vector2d>& map_points, const CorrelativeMapSettings& s,
                                   const std::function<bool(const Vector2d&)>& allowed,
                                   const std::vector<Vector2d>& map_normals)
    : settings_(s) {
  PLUMB_CHECK(s.orientation_bins == 0 || (s.orientation_bins >= 4 && s.orientation_bins <= 32),
              "CorrelativeMap2D: orientation_bins = " << s.orientation_bins << " must be 0 or in 4..32");
  PLUMB_CHECK(map_normals.empty() || map_normals.size() == map_points.size(),
              "CorrelativeMap2D: " << map_normals.size() << " normals for " << map_points.size() << " points");
  bins_ = map_normals.empty() ? 0 : s.orientation_bins;
  const int channels = bins_ + 1;
  PLUMB_CHECK(std::isfinite(s.resolution) && s.resolution > 0.0,
              "CorrelativeMap2D: resolution = " << s.resolution << " must be > 0");
  PLUMB_CHECK(std::isfinite(s.sigma) && s.sigma > 0.0, "CorrelativeMap2D: sigma = " << s.sigma << " must be > 0");
  PLUMB_CHECK(s.levels >= 1 && s.levels <= 15, "CorrelativeMap2D: levels = " << s.levels << " must be in 1..15");
  PLUMB_CHECK(std::isfinite(s.margin) && s.margin >= 0.0, "CorrelativeMap2D: margin = " << s.margin << " must be >= 0");
  Vector2d lo = Vector2d::Constant(std::numeric_limits<double>::infinity());
  Vector2d hi = -lo;
  std::size_t finite = 0;
  for (const Vector2d& p : map_points) {
    if (!p.allFinite()) continue;
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
    ++finite;
  }
  PLUMB_CHECK(finite > 0, "CorrelativeMap2D: no finite map point");
  if (!s.bounds.isEmpty()) {
    PLUMB_CHECK(s.bounds.min().allFinite() && s.bounds.max().allFinite(), "CorrelativeMap2D: bounds are not finite");
    lo = lo.cwiseMin(s.bounds.min());
    hi = hi.cwiseMax(s.bounds.max());
  }
  const double r = s.resolution;
  origin_ = lo - Vector2d::Constant(s.margin);
  const Vector2d extent = (hi - lo + Vector2d::Constant(2.0 * s.margin)) / r;
  PLUMB_CHECK(extent.maxCoeff() < 1e7, "CorrelativeMap2D: the map spans " << (hi - lo).transpose() << " m at "
                                                                          << r << " m cells: wrong units?");
  width_ = static_cast<int>(std::ceil(extent.x())) + 1;
  height_ = static_cast<int>(std::ceil(extent.y())) + 1;
  pad_ = 1 << (s.levels - 1);
  stride_ = width_ + pad_;
  const std::size_t cells = static_cast<std::size_t>(stride_) * static_cast<std::size_t>(height_ + pad_);
  PLUMB_CHECK(cells <= s.max_cells, "CorrelativeMap2D: " << width_ << " x " << height_ << " cells (map of "
                                                         << (hi - lo).transpose() << " m) exceed max_cells = "
                                                         << s.max_cells << ": wrong units, or raise the resolution");

  levels_.resize(static_cast<std::size_t>(s.levels));
  Level& base = levels_[0];
  cells_ = cells;
  base.value.assign(static_cast<std::size_t>(channels) * cells, 0);
  base.allowed.assign(cells, 0);
  // Occupied cells per channel (a map point with a normal enters its sector and both neighbours,
  // so a scan normal up to 1.5 sectors off still meets it; every point enters "any"), then a
  // Gaussian stamp around each (max where stamps overlap).
  const std::size_t grid_cells = static_cast<std::size_t>(width_) * static_cast<std::size_t>(height_);
  std::vector<std::vector<std::uint8_t>> occupied(static_cast<std::size_t>(channels), std::vector<std::uint8_t>(grid_cells, 0));
  for (std::size_t k = 0; k < map_points.size(); ++k) {
    const Vector2d& p = map_points[k];
    if (!p.allFinite()) continue;
    const int ix = static_cast<int>(std::floor((p.x() - origin_.x()) / r));
    const int iy = static_cast<int>(std::floor((p.y() - origin_.y()) / r));
    if (ix < 0 || iy < 0 || ix >= width_ || iy >= height_) continue;
    const std::size_t cell = static_cast<std::size_t>(iy) * width_ + ix;
    occupied[static_cast<std::size_t>(bins_)][cell] = 1;
    if (bins_ == 0) continue;
    const Vector2d& n = map_normals[k];
    if (!n.allFinite() || n.squaredNorm() == 0.0) {
      for (int b = 0; b < bins_; ++b) occupied[static_cast<std::size_t>(b)][cell] = 1;
      continue;
    }
    const int b = channel_of(std::atan2(n.y(), n.x()));
    for (int d = -1; d <= 1; ++d) occupied[static_cast<std::size_t>((b + d + bins_) % bins_)][cell] = 1;
  }
  const int radius = static_cast<int>(std::ceil(3.0 * s.sigma / r));
  std::vector<std::uint8_t> stamp(static_cast<std::size_t>((2 * radius + 1) * (2 * radius + 1)));
  for (int dy = -radius; dy <= radius; ++dy) {
    for (int dx = -radius; dx <= radius; ++dx) {
      const double d2 = (dx * dx + dy * dy) * r * r;
      const double v = d2 > 9.0 * s.sigma * s.sigma ? 0.0 : std::exp(-d2 / (2.0 * s.sigma * s.sigma));
      stamp[static_cast<std::size_t>((dy + radius) * (2 * radius + 1) + dx + radius)] =
          static_cast<std::uint8_t>(std::lround(255.0 * v));
    }
  }
  for (int c = 0; c < channels; ++c) {
    const std::vector<std::uint8_t>& occ = occupied[static_cast<std::size_t>(c)];
    std::uint8_t* value = &base.value[static_cast<std::size_t>(c) * cells];
    for (int iy = 0; iy < height_; ++iy) {
      for (int ix = 0; ix < width_; ++ix) {
        if (!occ[static_cast<std::size_t>(iy) * width_ + ix]) continue;
        for (int dy = -radius; dy <= radius; ++dy) {
          const int y = iy + dy;
          if (y < 0 || y >= height_) continue;
          for (int dx = -radius; dx <= radius; ++dx) {
            const int x = ix + dx;
            if (x < 0 || x >= width_) continue;
            std::uint8_t& v = value[index(x, y)];
            v = std::max(v, stamp[static_cast<std::size_t>((dy + radius) * (2 * radius + 1) + dx + radius)]);
          }
        }
      }
    }
  }
  for (int iy = 0; iy < height_; ++iy) {
    for (int ix = 0; ix < width_; ++ix) {
      const Vector2d t = origin_ + Vector2d(ix, iy) * r;
      if (!allowed || allowed(t)) {
        base.allowed[index(ix, iy)] = 1;
        ++num_allowed_;
      }
    }
  }
  // Level h at (x, y): the max (value) / any (allowed) over the window [x, x + 2^h) x [y, y + 2^h),
  // from the four level h-1 windows it splits into. Starts reach down to -pad_ so that a window
  // hanging over the grid's low edge still bounds the cells it covers.
  for (int h = 1; h < s.levels; ++h) {
    const Level& prev = levels_[static_cast<std::size_t>(h - 1)];
    Level& cur = levels_[static_cast<std::size_t>(h)];
    cur.value.assign(static_cast<std::size_t>(channels) * cells, 0);
    cur.allowed.assign(cells, 0);
    const int half = 1 << (h - 1);
    for (int y = -pad_; y < height_; ++y) {
      for (int x = -pad_; x < width_; ++x) {
        const std::size_t i = index(x, y);
        for (int k = 0; k < 4; ++k) {
          const int xx = x + (k & 1) * half, yy = y + (k >> 1) * half;
          if (xx >= width_ || yy >= height_) continue;
          const std::size_t j = index(xx, yy);
          for (int c = 0; c < channels; ++c) {
            std::uint8_t& v = cur.value[static_cast<std::size_t>(c) * cells + i];
            v = std::max(v, prev.value[static_cast<std::size_t>(c) * cells + j]);
          }
          cur.allowed[i] = static_cast<std::uint8_t>(cur.allowed[i] | prev.allowed[j]);
        }
      }
    }
  }
}

int CorrelativeMap2D::channel_of(double phi) const {
  if (bins_ == 0 || !std::isfinite(phi)) return bins_;
  const double u = (phi + kPi) / (2.0 * kPi) * bins_;  // [0, bins]
  const int b = static_cast<int>(std::floor(u));
  return ((b % bins_) + bins_) % bins_;
}

double CorrelativeMap2D::likelihood(const Vector2d& p, const Vector2d& normal) const {
  if (!p.allFinite()) return 0.0;
  const int c = normal.allFinite() && normal.squaredNorm() > 0.0 ? channel_of(std::atan2(normal.y(), normal.x())) : bins_;
  const double fx = std::floor((p.x() - origin_.x()) / settings_.resolution);
  const double fy = std::floor((p.y() - origin_.y()) / settings_.resolution);
  if (fx < 0.0 || fy < 0.0 || fx >= width_ || fy >= height_) return 0.0;
  return levels_[0].value[static_cast<std::size_t>(c) * cells_ + index(static_cast<int>(fx), static_cast<int>(fy))] /
         255.0;
}

double CorrelativeMap2D::score(const std::vector<Vector2d>& scan, const Pose2& pose,
                               const std::vector<Vector2d>& normals) const {
  PLUMB_CHECK(normals.empty() || normals.size() == scan.size(),
              "CorrelativeMap2D::score: " << normals.size() << " normals for " << scan.size() << " points");
  if (scan.empty()) return 0.0;
  const Eigen::Rotation2Dd R(pose.theta);
  double sum = 0.0;
  for (std::size_t i = 0; i < scan.size(); ++i) {
    const Vector2d n = normals.empty() ? Vector2d::Constant(std::nan("")) : Vector2d(R * normals[i]);
    sum += likelihood(pose * scan[i], n);
  }
  return sum / static_cast<double>(scan.size());
}

double CorrelativeMap2D::see_through(const std::vector<Vector2d>& scan, const Pose2& pose, const Vector2d& sensor,
                                     double margin) const {
  PLUMB_CHECK(std::isfinite(margin) && margin >= 0.0, "CorrelativeMap2D::see_through: margin = " << margin << " must be >= 0");
  const std::uint8_t* any = &levels_[0].value[static_cast<std::size_t>(bins_) * cells_];
  const double r = settings_.resolution;
  const Vector2d s = pose * sensor;
  std::size_t counted = 0, through = 0;
  for (const Vector2d& q : scan) {
    if (!q.allFinite()) continue;
    const Vector2d p = pose * q;
    const double length = (p - s).norm() - margin;
    ++counted;
    if (length <= 0.0) continue;
    const Vector2d dir = (p - s).normalized();
    // Half-cell steps: a wall is at least two cells thick in the likelihood (sigma >= one cell).
    for (double d = 0.0; d < length; d += 0.5 * r) {
      const Vector2d x = s + d * dir;
      const double fx = std::floor((x.x() - origin_.x()) / r), fy = std::floor((x.y() - origin_.y()) / r);
      if (fx < 0.0 || fy < 0.0 || fx >= width_ || fy >= height_) continue;
      if (any[index(static_cast<int>(fx), static_cast<int>(fy))] >= 128) {
        ++through;
        break;
      }
    }
  }
  return counted == 0 ? 0.0 : static_cast<double>(through) / static_cast<double>(counted);
}

CorrelativeResult CorrelativeMap2D::match(const std::vector<Vector2d>& scan_in, const CorrelativeSearchSettings& s,
                                          const std::vector<Vector2d>& normals_in) const {
  PLUMB_CHECK(normals_in.empty() || normals_in.size() == scan_in.size(),
              "CorrelativeMap2D::match: " << normals_in.size() << " normals for " << scan_in.size() << " points");
  PLUMB_CHECK(std::isfinite(s.angular_step) && s.angular_step >= 0.0,
              "CorrelativeMap2D::match: angular_step = " << s.angular_step << " must be >= 0");
  PLUMB_CHECK(std::isfinite(s.angle_center) && std::isfinite(s.angle_window) && s.angle_window >= 0.0,
              "CorrelativeMap2D::match: angle_center / angle_window must be finite, the window >= 0");
  PLUMB_CHECK(!s.region_center || (s.region_center->allFinite() && std::isfinite(s.region_radius) && s.region_radius > 0.0),
              "CorrelativeMap2D::match: the region centre must be finite and its radius > 0");
  PLUMB_CHECK(std::isfinite(s.min_score) && s.min_score >= 0.0 && s.min_score <= 1.0,
              "CorrelativeMap2D::match: min_score = " << s.min_score << " must be in [0, 1]");
  PLUMB_CHECK(s.max_points > 0, "CorrelativeMap2D::match: max_points must be > 0");
  PLUMB_CHECK(std::isfinite(s.second_distance) && std::isfinite(s.second_angle) && s.second_angle >= 0.0,
              "CorrelativeMap2D::match: second_distance / second_angle must be finite, the angle >= 0");
  const auto t0 = std::chrono::steady_clock::now();
  CorrelativeResult out;
  auto finish = [&]() {
    out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return out;
  };

  // Finite points, evenly thinned to max_points.
  // (a normal's angle, NaN when unknown, per point)
  std::vector<Vector2d> finite;
  std::vector<double> finite_phi;
  finite.reserve(scan_in.size());
  for (std::size_t i = 0; i < scan_in.size(); ++i) {
    if (!scan_in[i].allFinite()) continue;
    finite.push_back(scan_in[i]);
    const bool has_normal = !normals_in.empty() && normals_in[i].allFinite() && normals_in[i].squaredNorm() > 0.0;
    finite_phi.push_back(has_normal ? std::atan2(normals_in[i].y(), normals_in[i].x()) : std::nan(""));
  }
  std::vector<Vector2d> scan;
  std::vector<double> phi;
  if (finite.size() > s.max_points) {
    scan.reserve(s.max_points);
    for (std::size_t i = 0; i < s.max_points; ++i) {
      scan.push_back(finite[i * finite.size() / s.max_points]);
      phi.push_back(finite_phi[i * finite.size() / s.max_points]);
    }
  } else {
    scan = std::move(finite);
    phi = std::move(finite_phi);
  }
  out.num_points = scan.size();
  if (scan.size() < std::max<std::size_t>(s.min_points, 1)) return finish();

  const double r = settings_.resolution;
  double reach = r;
  for (const Vector2d& p : scan) reach = std::max(reach, p.norm());
  double step = s.angular_step;
  if (step <= 0.0) step = std::acos(std::max(-1.0, 1.0 - r * r / (2.0 * reach * reach)));
  std::vector<double> angles;
  if (s.angle_window >= 2.0 * kPi - 1e-9) {
    const int n = std::max(1, static_cast<int>(std::ceil(2.0 * kPi / step)));
    for (int k = 0; k < n; ++k) angles.push_back(s.angle_center - kPi + 2.0 * kPi * k / n);
  } else {
    const int half = static_cast<int>(std::ceil(0.5 * s.angle_window / step));
    for (int k = -half; k <= half; ++k) angles.push_back(s.angle_center + k * step);
  }
  out.num_angles = angles.size();

  // Cell offset of every rotated point: the point lands in cell offset + j for translation
  // origin + j * r (see the header's translation convention).
  // origin + j * r (see the header's translation convention), and its channel (the sector its
  // rotated normal falls in).
  const std::size_t n = scan.size();
  std::vector<int> offsets(angles.size() * n * 3);
  for (std::size_t a = 0; a < angles.size(); ++a) {
    const double c = std::cos(angles[a]), sn = std::sin(angles[a]);
    for (std::size_t i = 0; i < n; ++i) {
      const Vector2d& p = scan[i];
      int* o = &offsets[(a * n + i) * 3];
      o[0] = static_cast<int>(std::floor((c * p.x() - sn * p.y()) / r));
      o[1] = static_cast<int>(std::floor((sn * p.x() + c * p.y()) / r));
      o[2] = channel_of(phi[i] + angles[a]);
    }
  }
  // Per angle, the bounding box of the offsets, and each point's channel and cell offset as one
  // step in a level's flat array (index() is linear in x and y): a window whose points all land
  // inside the grid is scored with one load per point and no bounds check, the common case.
  struct Extent {
    int x0, y0, x1, y1;
  };
  std::vector<Extent> extents(angles.size());
  std::vector<std::ptrdiff_t> steps(angles.size() * n);
  for (std::size_t a = 0; a < angles.size(); ++a) {
    Extent e{std::numeric_limits<int>::max(), std::numeric_limits<int>::max(), std::numeric_limits<int>::min(),
             std::numeric_limits<int>::min()};
    for (std::size_t i = 0; i < n; ++i) {
      const int* o = &offsets[(a * n + i) * 3];
      e.x0 = std::min(e.x0, o[0]);
      e.y0 = std::min(e.y0, o[1]);
      e.x1 = std::max(e.x1, o[0]);
      e.y1 = std::max(e.y1, o[1]);
      steps[a * n + i] = static_cast<std::ptrdiff_t>(o[2]) * static_cast<std::ptrdiff_t>(cells_) +
                         static_cast<std::ptrdiff_t>(o[1]) * stride_ + o[0];
    }
    extents[a] = e;
  }

  // Translation range: the grid, cut to the region.
  int jx0 = 0, jy0 = 0, jx1 = width_ - 1, jy1 = height_ - 1;
  if (s.region_center) {
    const Vector2d lo = (*s.region_center - Vector2d::Constant(s.region_radius) - origin_) / r;
    const Vector2d hi = (*s.region_center + Vector2d::Constant(s.region_radius) - origin_) / r;
    jx0 = std::max(jx0, static_cast<int>(std::floor(lo.x())));
    jy0 = std::max(jy0, static_cast<int>(std::floor(lo.y())));
    jx1 = std::min(jx1, static_cast<int>(std::ceil(hi.x())));
    jy1 = std::min(jy1, static_cast<int>(std::ceil(hi.y())));
    if (jx0 > jx1 || jy0 > jy1) {
      out.status = Status::kRejected;
      return finish();
    }
  }
  const int top = settings_.levels - 1;
  const int top_size = 1 << top;

  std::size_t scored = 0;
  auto bound = [&](int a, int jx, int jy, int h) {
    ++scored;
    const std::uint8_t* v = levels_[static_cast<std::size_t>(h)].value.data();
    long sum = 0;
    const Extent& e = extents[static_cast<std::size_t>(a)];
    if (inside(e.x0 + jx, e.y0 + jy) && inside(e.x1 + jx, e.y1 + jy)) {
      const std::uint8_t* at = v + index(jx, jy);
      const std::ptrdiff_t* cell_step = &steps[static_cast<std::size_t>(a) * n];
      for (std::size_t i = 0; i < n; ++i) sum += at[cell_step[i]];
      return sum;
    }
    const int* o = &offsets[static_cast<std::size_t>(a) * n * 3];
    for (std::size_t i = 0; i < n; ++i) {
      const int x = o[3 * i] + jx, y = o[3 * i + 1] + jy;
      if (inside(x, y)) sum += v[static_cast<std::size_t>(o[3 * i + 2]) * cells_ + index(x, y)];
    }
    return sum;
  };
  auto translation = [&](int jx, int jy) { return Vector2d(origin_ + Vector2d(jx, jy) * r); };
  // Distance range from `c` to the cell corners of a window (translations jx .. jx + size - 1).
  auto window_near_far = [&](const Vector2d& c, int jx, int jy, int size) {
    const Vector2d lo = translation(jx, jy), hi = translation(jx + size - 1, jy + size - 1);
    const Vector2d near = c.cwiseMax(lo).cwiseMin(hi);
    const Vector2d far((c.x() - lo.x() > hi.x() - c.x()) ? lo.x() : hi.x(),
                       (c.y() - lo.y() > hi.y() - c.y()) ? lo.y() : hi.y());
    return std::pair<double, double>((near - c).norm(), (far - c).norm());
  };
  auto in_region = [&](int jx, int jy, int size) {
    if (!s.region_center) return true;
    return window_near_far(*s.region_center, jx, jy, size).first <= s.region_radius;
  };
  auto angle_diff = [&](int a, double theta) { return std::abs(wrap_angle(angles[static_cast<std::size_t>(a)] - theta)); };

  std::vector<Node> roots;
  for (std::size_t a = 0; a < angles.size(); ++a) {
    for (int jy = jy0; jy <= jy1; jy += top_size) {
      for (int jx = jx0; jx <= jx1; jx += top_size) {
        if (!levels_[static_cast<std::size_t>(top)].allowed[index(jx, jy)] || !in_region(jx, jy, top_size)) continue;
        roots.push_back({static_cast<int>(a), jx, jy, top, bound(static_cast<int>(a), jx, jy, top)});
      }
    }
  }
  std::sort(roots.begin(), roots.end(), by_score);

  const long scale = 255 * static_cast<long>(n);
  const long threshold = static_cast<long>(std::ceil(s.min_score * static_cast<double>(scale)));
  // Depth-first branch and bound, children best first. `excluded(node, size)` prunes windows (and
  // leaves) that lie wholly inside the exclusion zone of the second search.
  struct Search {
    Node best;
    bool found = false;
    long floor_score;
    std::size_t rejected = 0;
    bool stopped = false;  ///< max_rejections reached
  };
  std::function<void(const std::vector<Node>&, Search&, const std::function<bool(const Node&, int)>&)> descend;
  descend = [&](const std::vector<Node>& nodes, Search& search, const std::function<bool(const Node&, int)>& excluded) {
    for (const Node& node : nodes) {
      if (node.score <= search.floor_score || search.stopped) return;  // sorted: nothing after can beat it
      const int size = 1 << node.h;
      if (excluded && excluded(node, size)) continue;
      if (node.h == 0) {
        if (!levels_[0].allowed[index(node.jx, node.jy)]) continue;
        if (s.region_center && (translation(node.jx, node.jy) - *s.region_center).norm() > s.region_radius) continue;
        if (s.accept) {
          const Vector2d t = translation(node.jx, node.jy);
          if (!s.accept(Pose2{t.x(), t.y(), wrap_angle(angles[static_cast<std::size_t>(node.a)])})) {
            if (++search.rejected == s.max_rejections) search.stopped = true;
            continue;
          }
        }
        search.best = node;
        search.found = true;
        search.floor_score = node.score;
        continue;
      }
      const int half = size / 2;
      std::vector<Node> children;
      children.reserve(4);
      for (int k = 0; k < 4; ++k) {
        const int jx = node.jx + (k & 1) * half, jy = node.jy + (k >> 1) * half;
        if (jx > jx1 || jy > jy1) continue;
        if (!levels_[static_cast<std::size_t>(node.h - 1)].allowed[index(jx, jy)] || !in_region(jx, jy, half)) continue;
        children.push_back({node.a, jx, jy, node.h - 1, bound(node.a, jx, jy, node.h - 1)});
      }
      std::sort(children.begin(), children.end(), by_score);
      descend(children, search, excluded);
    }
  };

  Search first;
  first.floor_score = threshold - 1;
  descend(roots, first, {});
  out.rejected = first.rejected;
  out.truncated = first.stopped;
  if (!first.found) {
    out.status = Status::kRejected;
    out.nodes_scored = scored;
    return finish();
  }
  out.status = Status::kOk;
  out.pose = Pose2{translation(first.best.jx, first.best.jy).x(), translation(first.best.jx, first.best.jy).y(),
                   wrap_angle(angles[static_cast<std::size_t>(first.best.a)])};
  out.score = static_cast<double>(first.best.score) / static_cast<double>(scale);

  if (s.second_distance >= 0.0) {
    const Vector2d t_best(out.pose.x, out.pose.y);
    auto excluded = [&](const Node& node, int size) {
      if (angle_diff(node.a, out.pose.theta) >= s.second_angle) return false;
      return window_near_far(t_best, node.jx, node.jy, size).second < s.second_distance;
    };
    Search second;
    second.floor_score = threshold - 1;
    descend(roots, second, excluded);
    out.rejected += second.rejected;
    out.truncated = out.truncated || second.stopped;
    if (second.found) {
      out.has_second = true;
      out.second_pose = Pose2{translation(second.best.jx, second.best.jy).x(), translation(second.best.jx, second.best.jy).y(),
                              wrap_angle(angles[static_cast<std::size_t>(second.best.a)])};
      out.second_score = static_cast<double>(second.best.score) / static_cast<double>(scale);
    }
  }
  out.nodes_scored = scored;
  return finish();
}

}  // namespace plumb
