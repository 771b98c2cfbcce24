// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/scan2d/correlative.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

#include <Eigen/Geometry>

#include "plumb/core/error.hpp"
#include "plumb/core/parallel.hpp"

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
  PLUMB_CHECK(std::isfinite(s.resolution) && s.resolution > 0.0,
              "CorrelativeMap2D: resolution = " << s.resolution << " must be > 0");
  PLUMB_CHECK(std::isfinite(s.sigma) && s.sigma > 0.0, "CorrelativeMap2D: sigma = " << s.sigma << " must be > 0");
  PLUMB_CHECK(s.levels >= 1 && s.levels <= 15, "CorrelativeMap2D: levels = " << s.levels << " must be in 1..15");
  PLUMB_CHECK(std::isfinite(s.margin) && s.margin >= 0.0, "CorrelativeMap2D: margin = " << s.margin << " must be >= 0");
  place_grid(map_points);
  const int channels = bins_ + 1;
  levels_.resize(static_cast<std::size_t>(s.levels));
  Level& base = levels_[0];
  base.value.assign(static_cast<std::size_t>(channels) * cells_, 0);
  base.allowed.assign(cells_, 0);
  stamp_likelihood(occupied_cells(map_points, map_normals));
  mark_allowed(allowed);
  build_pyramid();
}

void CorrelativeMap2D::place_grid(const std::vector<Vector2d>& map_points) {
  const CorrelativeMapSettings& s = settings_;
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
  cells_ = cells;
}

std::vector<std::vector<std::uint8_t>> CorrelativeMap2D::occupied_cells(
    const std::vector<Vector2d>& map_points, const std::vector<Vector2d>& map_normals) const {
  // Occupied cells per channel (a map point with a normal enters its sector and both neighbours,
  // so a scan normal up to 1.5 sectors off still meets it; every point enters "any"), then a
  // Gaussian stamp around each (max where stamps overlap).
  const double r = settings_.resolution;
  const int channels = bins_ + 1;
  const std::size_t grid_cells = static_cast<std::size_t>(width_) * static_cast<std::size_t>(height_);
  std::vector<std::vector<std::uint8_t>> occupied(static_cast<std::size_t>(channels),
                                                  std::vector<std::uint8_t>(grid_cells, 0));
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
  return occupied;
}

void CorrelativeMap2D::stamp_likelihood(const std::vector<std::vector<std::uint8_t>>& occupied) {
  const double r = settings_.resolution;
  const double sigma = settings_.sigma;
  const int radius = static_cast<int>(std::ceil(3.0 * sigma / r));
  std::vector<std::uint8_t> stamp(static_cast<std::size_t>((2 * radius + 1) * (2 * radius + 1)));
  for (int dy = -radius; dy <= radius; ++dy) {
    for (int dx = -radius; dx <= radius; ++dx) {
      const double d2 = (dx * dx + dy * dy) * r * r;
      const double v = d2 > 9.0 * sigma * sigma ? 0.0 : std::exp(-d2 / (2.0 * sigma * sigma));
      stamp[static_cast<std::size_t>((dy + radius) * (2 * radius + 1) + dx + radius)] =
          static_cast<std::uint8_t>(std::lround(255.0 * v));
    }
  }
  for (std::size_t c = 0; c < occupied.size(); ++c) {
    const std::vector<std::uint8_t>& occ = occupied[c];
    std::uint8_t* value = &levels_[0].value[c * cells_];
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
}

void CorrelativeMap2D::mark_allowed(const std::function<bool(const Vector2d&)>& allowed) {
  for (int iy = 0; iy < height_; ++iy) {
    for (int ix = 0; ix < width_; ++ix) {
      const Vector2d t = origin_ + Vector2d(ix, iy) * settings_.resolution;
      if (!allowed || allowed(t)) {
        levels_[0].allowed[index(ix, iy)] = 1;
        ++num_allowed_;
      }
    }
  }
}

void CorrelativeMap2D::build_pyramid() {
  // Level h at (x, y): the max (value) / any (allowed) over the window [x, x + 2^h) x [y, y + 2^h),
  // from the four level h-1 windows it splits into. Starts reach down to -pad_ so that a window
  // hanging over the grid's low edge still bounds the cells it covers.
  const int channels = bins_ + 1;
  for (int h = 1; h < settings_.levels; ++h) {
    const Level& prev = levels_[static_cast<std::size_t>(h - 1)];
    Level& cur = levels_[static_cast<std::size_t>(h)];
    cur.value.assign(static_cast<std::size_t>(channels) * cells_, 0);
    cur.allowed.assign(cells_, 0);
    const int half = 1 << (h - 1);
    for (int y = -pad_; y < height_; ++y) {
      for (int x = -pad_; x < width_; ++x) {
        const std::size_t i = index(x, y);
        for (int k = 0; k < 4; ++k) {
          const int xx = x + (k & 1) * half, yy = y + (k >> 1) * half;
          if (xx >= width_ || yy >= height_) continue;
          const std::size_t j = index(xx, yy);
          for (int c = 0; c < channels; ++c) {
            std::uint8_t& v = cur.value[static_cast<std::size_t>(c) * cells_ + i];
            v = std::max(v, prev.value[static_cast<std::size_t>(c) * cells_ + j]);
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

namespace {

void check_search_settings(const CorrelativeSearchSettings& s, std::size_t num_points, std::size_t num_normals) {
  PLUMB_CHECK(num_normals == 0 || num_normals == num_points,
              "CorrelativeMap2D::match: " << num_normals << " normals for " << num_points << " points");
  PLUMB_CHECK(std::isfinite(s.angular_step) && s.angular_step >= 0.0,
              "CorrelativeMap2D::match: angular_step = " << s.angular_step << " must be >= 0");
  PLUMB_CHECK(std::isfinite(s.angle_center) && std::isfinite(s.angle_window) && s.angle_window >= 0.0,
              "CorrelativeMap2D::match: angle_center / angle_window must be finite, the window >= 0");
  PLUMB_CHECK(!s.region_center ||
                  (s.region_center->allFinite() && std::isfinite(s.region_radius) && s.region_radius > 0.0),
              "CorrelativeMap2D::match: the region centre must be finite and its radius > 0");
  PLUMB_CHECK(std::isfinite(s.min_score) && s.min_score >= 0.0 && s.min_score <= 1.0,
              "CorrelativeMap2D::match: min_score = " << s.min_score << " must be in [0, 1]");
  PLUMB_CHECK(s.max_points > 0, "CorrelativeMap2D::match: max_points must be > 0");
  PLUMB_CHECK(std::isfinite(s.second_distance) && std::isfinite(s.second_angle) && s.second_angle >= 0.0,
              "CorrelativeMap2D::match: second_distance / second_angle must be finite, the angle >= 0");
  PLUMB_CHECK(s.threads >= 0, "CorrelativeMap2D::match: threads = " << s.threads << " must be >= 0 (0 = every core)");
}

/// Scan points with the angle of their normal (NaN when unknown).
struct ScanWithNormals {
  std::vector<Vector2d> points;
  std::vector<double> phi;
};

/// Finite points, evenly thinned to max_points.
ScanWithNormals thin_scan(const std::vector<Vector2d>& scan_in, const std::vector<Vector2d>& normals_in,
                          std::size_t max_points) {
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
  ScanWithNormals out;
  if (finite.size() > max_points) {
    out.points.reserve(max_points);
    for (std::size_t i = 0; i < max_points; ++i) {
      out.points.push_back(finite[i * finite.size() / max_points]);
      out.phi.push_back(finite_phi[i * finite.size() / max_points]);
    }
  } else {
    out.points = std::move(finite);
    out.phi = std::move(finite_phi);
  }
  return out;
}

/// One branch-and-bound search's state: the best leaf so far and its score, the floor a node must
/// beat.
/// A single pose a search tested (CorrelativeSearchSettings::accept), in the order it did.
struct Visit {
  Node node;
  bool accepted = false;
};

struct Search {
  Node best;
  bool found = false;
  long floor_score;
  std::size_t rejected = 0;
  bool stopped = false;  ///< max_rejections reached
  std::size_t scored = 0;  ///< windows and poses scored
  /// Set: the search records every pose it tests, for Matcher::replay().
  std::vector<Visit>* record = nullptr;
};

}  // namespace

/// One match(): the scan rotated to every heading, the translation range, and the branch-and-bound
/// searches over the map's pyramid.
class CorrelativeMap2D::Matcher {
 public:
  Matcher(const CorrelativeMap2D& map, const CorrelativeSearchSettings& s, const std::vector<Vector2d>& scan,
          const std::vector<double>& phi)
      : map_(map), s_(s), n_(scan.size()), r_(map.settings_.resolution) {
    headings(scan);
    rotate(scan, phi);
  }

  std::size_t num_angles() const { return angles_.size(); }

  /// Translation range: the grid, cut to the region; false when the region misses the grid.
  bool cut_to_region() {
    jx1_ = map_.width_ - 1;
    jy1_ = map_.height_ - 1;
    if (!s_.region_center) return true;
    const Vector2d lo = (*s_.region_center - Vector2d::Constant(s_.region_radius) - map_.origin_) / r_;
    const Vector2d hi = (*s_.region_center + Vector2d::Constant(s_.region_radius) - map_.origin_) / r_;
    jx0_ = std::max(jx0_, static_cast<int>(std::floor(lo.x())));
    jy0_ = std::max(jy0_, static_cast<int>(std::floor(lo.y())));
    jx1_ = std::min(jx1_, static_cast<int>(std::ceil(hi.x())));
    jy1_ = std::min(jy1_, static_cast<int>(std::ceil(hi.y())));
    return jx0_ <= jx1_ && jy0_ <= jy1_;
  }

  /// The best pose, then (with second_distance >= 0) the best one outside its exclusion zone.
  void search(CorrelativeResult& out) {
    const std::vector<Node> roots = root_nodes();
    const long scale = 255 * static_cast<long>(n_);
    const long threshold = static_cast<long>(std::ceil(s_.min_score * static_cast<double>(scale)));
    Search first;
    first.floor_score = threshold - 1;
    descend_roots(roots, first, {});
    scored_ += first.scored;
    out.rejected = first.rejected;
    out.truncated = first.stopped;
    if (!first.found) {
      out.status = Status::kRejected;
      out.nodes_scored = scored_;
      return;
    }
    out.status = Status::kOk;
    out.pose = Pose2{translation(first.best.jx, first.best.jy).x(), translation(first.best.jx, first.best.jy).y(),
                     wrap_angle(angles_[static_cast<std::size_t>(first.best.a)])};
    out.score = static_cast<double>(first.best.score) / static_cast<double>(scale);

    if (s_.second_distance >= 0.0) {
      const Vector2d t_best(out.pose.x, out.pose.y);
      auto excluded = [&](const Node& node, int size) {
        if (angle_diff(node.a, out.pose.theta) >= s_.second_angle) return false;
        return window_near_far(t_best, node.jx, node.jy, size).second < s_.second_distance;
      };
      Search second;
      second.floor_score = threshold - 1;
      descend_roots(roots, second, excluded);
      scored_ += second.scored;
      out.rejected += second.rejected;
      out.truncated = out.truncated || second.stopped;
      if (second.found) {
        out.has_second = true;
        out.second_pose = Pose2{translation(second.best.jx, second.best.jy).x(),
                                translation(second.best.jx, second.best.jy).y(),
                                wrap_angle(angles_[static_cast<std::size_t>(second.best.a)])};
        out.second_score = static_cast<double>(second.best.score) / static_cast<double>(scale);
      }
    }
    out.nodes_scored = scored_;
  }

 private:
  /// The bounding box of one heading's cell offsets.
  struct Extent {
    int x0, y0, x1, y1;
  };
  using Exclusion = std::function<bool(const Node&, int)>;

  void headings(const std::vector<Vector2d>& scan) {
    double reach = r_;
    for (const Vector2d& p : scan) reach = std::max(reach, p.norm());
    double step = s_.angular_step;
    if (step <= 0.0) step = std::acos(std::max(-1.0, 1.0 - r_ * r_ / (2.0 * reach * reach)));
    if (s_.angle_window >= 2.0 * kPi - 1e-9) {
      const int n = std::max(1, static_cast<int>(std::ceil(2.0 * kPi / step)));
      for (int k = 0; k < n; ++k) angles_.push_back(s_.angle_center - kPi + 2.0 * kPi * k / n);
    } else {
      const int half = static_cast<int>(std::ceil(0.5 * s_.angle_window / step));
      for (int k = -half; k <= half; ++k) angles_.push_back(s_.angle_center + k * step);
    }
  }

  void rotate(const std::vector<Vector2d>& scan, const std::vector<double>& phi) {
    // Cell offset of every rotated point: the point lands in cell offset + j for translation
    // origin + j * r (see the header's translation convention), and its channel (the sector its
    // rotated normal falls in).
    const std::size_t n = n_;
    offsets_.resize(angles_.size() * n * 3);
    for (std::size_t a = 0; a < angles_.size(); ++a) {
      const double c = std::cos(angles_[a]), sn = std::sin(angles_[a]);
      for (std::size_t i = 0; i < n; ++i) {
        const Vector2d& p = scan[i];
        int* o = &offsets_[(a * n + i) * 3];
        o[0] = static_cast<int>(std::floor((c * p.x() - sn * p.y()) / r_));
        o[1] = static_cast<int>(std::floor((sn * p.x() + c * p.y()) / r_));
        o[2] = map_.channel_of(phi[i] + angles_[a]);
      }
    }
    // Per angle, the bounding box of the offsets, and each point's channel and cell offset as one
    // step in a level's flat array (index() is linear in x and y): a window whose points all land
    // inside the grid is scored with one load per point and no bounds check, the common case.
    extents_.resize(angles_.size());
    steps_.resize(angles_.size() * n);
    for (std::size_t a = 0; a < angles_.size(); ++a) {
      Extent e{std::numeric_limits<int>::max(), std::numeric_limits<int>::max(), std::numeric_limits<int>::min(),
               std::numeric_limits<int>::min()};
      for (std::size_t i = 0; i < n; ++i) {
        const int* o = &offsets_[(a * n + i) * 3];
        e.x0 = std::min(e.x0, o[0]);
        e.y0 = std::min(e.y0, o[1]);
        e.x1 = std::max(e.x1, o[0]);
        e.y1 = std::max(e.y1, o[1]);
        steps_[a * n + i] = static_cast<std::ptrdiff_t>(o[2]) * static_cast<std::ptrdiff_t>(map_.cells_) +
                            static_cast<std::ptrdiff_t>(o[1]) * map_.stride_ + o[0];
      }
      extents_[a] = e;
    }
  }

  /// The score bound of heading `a` over the level-h window at (jx, jy); counts into `scored`.
  long bound(int a, int jx, int jy, int h, std::size_t& scored) const {
    ++scored;
    const std::uint8_t* v = map_.levels_[static_cast<std::size_t>(h)].value.data();
    long sum = 0;
    const Extent& e = extents_[static_cast<std::size_t>(a)];
    if (map_.inside(e.x0 + jx, e.y0 + jy) && map_.inside(e.x1 + jx, e.y1 + jy)) {
      const std::uint8_t* at = v + map_.index(jx, jy);
      const std::ptrdiff_t* cell_step = &steps_[static_cast<std::size_t>(a) * n_];
      for (std::size_t i = 0; i < n_; ++i) sum += at[cell_step[i]];
      return sum;
    }
    const int* o = &offsets_[static_cast<std::size_t>(a) * n_ * 3];
    for (std::size_t i = 0; i < n_; ++i) {
      const int x = o[3 * i] + jx, y = o[3 * i + 1] + jy;
      if (map_.inside(x, y)) sum += v[static_cast<std::size_t>(o[3 * i + 2]) * map_.cells_ + map_.index(x, y)];
    }
    return sum;
  }

  Vector2d translation(int jx, int jy) const { return Vector2d(map_.origin_ + Vector2d(jx, jy) * r_); }

  /// Distance range from `c` to the cell corners of a window (translations jx .. jx + size - 1).
  std::pair<double, double> window_near_far(const Vector2d& c, int jx, int jy, int size) const {
    const Vector2d lo = translation(jx, jy), hi = translation(jx + size - 1, jy + size - 1);
    const Vector2d near = c.cwiseMax(lo).cwiseMin(hi);
    const Vector2d far((c.x() - lo.x() > hi.x() - c.x()) ? lo.x() : hi.x(),
                       (c.y() - lo.y() > hi.y() - c.y()) ? lo.y() : hi.y());
    return std::pair<double, double>((near - c).norm(), (far - c).norm());
  }

  bool in_region(int jx, int jy, int size) const {
    if (!s_.region_center) return true;
    return window_near_far(*s_.region_center, jx, jy, size).first <= s_.region_radius;
  }

  double angle_diff(int a, double theta) const {
    return std::abs(wrap_angle(angles_[static_cast<std::size_t>(a)] - theta));
  }

  /// The top-level windows of every heading, best first (scored on the search's threads, in
  /// chunks of headings fixed by their number, appended in heading order).
  std::vector<Node> root_nodes() {
    const int top = map_.settings_.levels - 1;
    const int top_size = 1 << top;
    const std::size_t grain = 16;
    std::vector<std::size_t> scored(chunk_count(angles_.size(), grain), 0);
    std::vector<Node> roots;
    parallel_append(s_.threads, angles_.size(), grain, roots, [&](std::size_t begin, std::size_t end, std::vector<Node>& out) {
      std::size_t& count = scored[begin / grain];
      for (std::size_t a = begin; a < end; ++a) {
        for (int jy = jy0_; jy <= jy1_; jy += top_size) {
          for (int jx = jx0_; jx <= jx1_; jx += top_size) {
            const bool allowed = map_.levels_[static_cast<std::size_t>(top)].allowed[map_.index(jx, jy)] != 0;
            if (!allowed || !in_region(jx, jy, top_size)) continue;
            out.push_back({static_cast<int>(a), jx, jy, top, bound(static_cast<int>(a), jx, jy, top, count)});
          }
        }
      }
    });
    for (const std::size_t c : scored) scored_ += c;
    std::sort(roots.begin(), roots.end(), by_score);
    return roots;
  }

  /// descend() over the sorted roots. With threads, the roots are taken in batches of a fixed size:
  /// each root of a batch is searched on its own (in parallel) from the floor the batch starts
  /// with, recording every pose it tests; replay() then walks the records in root order with the
  /// floor a serial search would have had. A subtree searched from a lower floor tests every pose
  /// the serial search tests there (and more), so the replay gives its best pose, its rejections and
  /// its stop exactly: the results do not depend on the thread count. (The windows scored do.)
  void descend_roots(const std::vector<Node>& roots, Search& search, const Exclusion& excluded) const {
    if (resolve_thread_count(s_.threads) == 1) {
      descend(roots, search, excluded);
      return;
    }
    constexpr std::size_t kBatch = 32;
    for (std::size_t b = 0; b < roots.size() && !search.stopped; b += kBatch) {
      if (roots[b].score <= search.floor_score) return;
      const std::size_t e = std::min(roots.size(), b + kBatch);
      std::vector<Search> local(e - b);
      std::vector<std::vector<Visit>> visits(e - b);
      parallel_chunks(s_.threads, e - b, [&](std::size_t k) {
        if (roots[b + k].score <= search.floor_score) return;
        local[k].floor_score = search.floor_score;
        local[k].record = &visits[k];
        descend({roots[b + k]}, local[k], excluded);
      });
      for (std::size_t k = 0; k < e - b; ++k) {
        search.scored += local[k].scored;
        if (roots[b + k].score <= search.floor_score || search.stopped) return;
        replay(visits[k], local[k].stopped, roots[b + k], search, excluded);
      }
    }
  }

  /// The effect on `search` of a serial descend() into `root`, from the poses a search of it from a
  /// lower floor tested (`visits`, in order). `cut`: that search stopped at max_rejections before
  /// it ended; if the serial one would go on, the root is searched again serially.
  void replay(const std::vector<Visit>& visits, bool cut, const Node& root, Search& search,
              const Exclusion& excluded) const {
    const Search before = search;
    for (const Visit& v : visits) {
      if (v.node.score <= search.floor_score) continue;
      if (!v.accepted) {
        if (++search.rejected == s_.max_rejections) {
          search.stopped = true;
          return;
        }
        continue;
      }
      search.best = v.node;
      search.found = true;
      search.floor_score = v.node.score;
    }
    if (cut) {
      const std::size_t scored = search.scored;
      search = before;
      search.scored = scored;
      descend({root}, search, excluded);
    }
  }

  // Depth-first branch and bound, children best first. `excluded(node, size)` prunes windows (and
  // leaves) that lie wholly inside the exclusion zone of the second search.
  void descend(const std::vector<Node>& nodes, Search& search, const Exclusion& excluded) const {
    for (const Node& node : nodes) {
      if (node.score <= search.floor_score || search.stopped) return;  // sorted: nothing after can beat it
      const int size = 1 << node.h;
      if (excluded && excluded(node, size)) continue;
      if (node.h == 0) {
        visit_leaf(node, search);
        continue;
      }
      const int half = size / 2;
      std::vector<Node> children;
      children.reserve(4);
      for (int k = 0; k < 4; ++k) {
        const int jx = node.jx + (k & 1) * half, jy = node.jy + (k >> 1) * half;
        if (jx > jx1_ || jy > jy1_) continue;
        const bool allowed = map_.levels_[static_cast<std::size_t>(node.h - 1)].allowed[map_.index(jx, jy)] != 0;
        if (!allowed || !in_region(jx, jy, half)) continue;
        children.push_back({node.a, jx, jy, node.h - 1, bound(node.a, jx, jy, node.h - 1, search.scored)});
      }
      std::sort(children.begin(), children.end(), by_score);
      descend(children, search, excluded);
    }
  }

  /// A single pose that beats the search's best: taken unless it is not allowed, out of the region
  /// or turned down by `accept`.
  void visit_leaf(const Node& node, Search& search) const {
    if (!map_.levels_[0].allowed[map_.index(node.jx, node.jy)]) return;
    if (s_.region_center && (translation(node.jx, node.jy) - *s_.region_center).norm() > s_.region_radius) return;
    if (s_.accept) {
      const Vector2d t = translation(node.jx, node.jy);
      const bool accepted = s_.accept(Pose2{t.x(), t.y(), wrap_angle(angles_[static_cast<std::size_t>(node.a)])});
      if (search.record) search.record->push_back(Visit{node, accepted});
      if (!accepted) {
        if (++search.rejected == s_.max_rejections) search.stopped = true;
        return;
      }
    } else if (search.record) {
      search.record->push_back(Visit{node, true});
    }
    search.best = node;
    search.found = true;
    search.floor_score = node.score;
  }

  const CorrelativeMap2D& map_;
  const CorrelativeSearchSettings& s_;
  const std::size_t n_;  ///< scan points
  const double r_;       ///< cell size [m]
  std::vector<double> angles_;
  std::vector<int> offsets_;  ///< per heading and point: cell offset x, y and channel
  std::vector<Extent> extents_;
  std::vector<std::ptrdiff_t> steps_;
  int jx0_ = 0, jy0_ = 0, jx1_ = 0, jy1_ = 0;
  std::size_t scored_ = 0;
};

CorrelativeResult CorrelativeMap2D::match(const std::vector<Vector2d>& scan_in, const CorrelativeSearchSettings& s,
                                          const std::vector<Vector2d>& normals_in) const {
  check_search_settings(s, scan_in.size(), normals_in.size());
  const auto t0 = std::chrono::steady_clock::now();
  CorrelativeResult out;
  auto finish = [&]() {
    out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return out;
  };

  const ScanWithNormals scan = thin_scan(scan_in, normals_in, s.max_points);
  out.num_points = scan.points.size();
  if (scan.points.size() < std::max<std::size_t>(s.min_points, 1)) return finish();

  Matcher matcher(*this, s, scan.points, scan.phi);
  out.num_angles = matcher.num_angles();
  if (!matcher.cut_to_region()) {
    out.status = Status::kRejected;
    return finish();
  }
  matcher.search(out);
  return finish();
}

}  // namespace plumb
