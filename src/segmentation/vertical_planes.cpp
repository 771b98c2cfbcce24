// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/segmentation/vertical_planes.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

#include "plumb/core/error.hpp"
#include "plumb/segmentation/presegment.hpp"

namespace plumb {

namespace detail {

/// A vertical plane prepared for labelling full-resolution points.
struct VerticalPlaneLabeller {
  float a, b, c, d;     // plane
  float tx, ty;         // horizontal direction along the wall (t = z x n, normalised in xy)
  float s_min, z_lo, z_hi, inv_cell;
  float pad;  // extra cells of dilation (voxel / cell, rounded up)
  const std::vector<std::uint8_t>* cells;

  bool contains(const Vector3f& p, float tau) const {
    if (!(std::abs(a * p.x() + b * p.y() + c * p.z() - d) < tau)) return false;
    if (p.z() < z_lo || p.z() > z_hi) return false;
    const float sc = (tx * p.x() + ty * p.y() - s_min) * inv_cell;
    const float n = static_cast<float>(cells->size());
    if (!(sc > -1.0f - pad && sc < n + 1.0f + pad)) return false;
    const long k = static_cast<long>(std::floor(sc));
    const long r = 1 + static_cast<long>(pad);
    for (long j = k - r; j <= k + r; ++j) {
      if (j >= 0 && j < static_cast<long>(cells->size()) && (*cells)[static_cast<std::size_t>(j)] != 0) return true;
    }
    return false;
  }
};

void check_vertical_plane_inputs(const PointCloud& cloud, const FrameSample& sample, const GroundResult* ground,
                                 bool use_ground, const VerticalPlaneSettings& s) {
  PLUMB_CHECK(std::isfinite(s.max_u_angle) && s.max_u_angle >= 0.0 && s.max_u_angle < 1.5707963267948966,
              "extract_vertical_planes: max_u_angle = " << s.max_u_angle << " must be in [0, pi/2)");
  PLUMB_CHECK(std::isfinite(s.distance_threshold) && s.distance_threshold > 0.0,
              "extract_vertical_planes: distance_threshold = " << s.distance_threshold << " must be finite and > 0");
  PLUMB_CHECK(!std::isnan(s.max_normal_angle), "extract_vertical_planes: max_normal_angle is NaN");
  PLUMB_CHECK(s.min_sample_inliers >= 3,
              "extract_vertical_planes: min_sample_inliers = " << s.min_sample_inliers << " must be >= 3");
  PLUMB_CHECK(s.max_iterations >= 1,
              "extract_vertical_planes: max_iterations = " << s.max_iterations << " must be >= 1");
  PLUMB_CHECK(std::isfinite(s.cell_size) && s.cell_size > 0.0,
              "extract_vertical_planes: cell_size = " << s.cell_size << " must be finite and > 0");
  PLUMB_CHECK(sample.points.size() == sample.normals.size() && sample.points.size() == sample.source.size(),
              "extract_vertical_planes: inconsistent sample");
  for (std::size_t i : sample.source) {
    PLUMB_CHECK(i < cloud.points.size(), "extract_vertical_planes: sample refers to point "
                                             << i << " of a cloud of " << cloud.points.size());
  }
  if (use_ground) {
    for (std::size_t i : ground->sample_inliers) {
      PLUMB_CHECK(i < sample.points.size(), "extract_vertical_planes: ground sample inlier " << i << " out of range");
    }
    for (std::size_t i : ground->inliers) {
      PLUMB_CHECK(i < cloud.points.size(), "extract_vertical_planes: ground inlier " << i << " out of range");
    }
  }
}

/// The RANSAC of one wall among the candidates.
PlaneRansacSettings vertical_plane_ransac_settings(const VerticalPlaneSettings& s) {
  PlaneRansacSettings rs;
  rs.distance_threshold = s.distance_threshold;
  rs.max_iterations = s.max_iterations;
  rs.confidence = s.confidence;
  rs.sampling = PlaneSampling::kPointNormal;  // several walls share the candidates: small w
  rs.constraint = AxisConstraint::kParallel;
  rs.axis = Vector3d::UnitZ();
  rs.max_axis_angle = s.max_u_angle;
  rs.max_normal_angle = s.max_normal_angle;
  rs.min_inliers = s.min_sample_inliers;
  return rs;
}

/// The wall a RANSAC fit found: its extent along the wall and in z, and the cells along it that
/// hold sample inliers. Marks the inliers taken.
VerticalPlane vertical_plane_of_fit(const PlaneRansacResult& r, const FrameSample& sample, double cell_size,
                                    std::vector<std::uint8_t>& taken) {
  VerticalPlane vp;
  vp.plane = r.plane;
  vp.num_sample_inliers = r.inliers.size();
  vp.rmse = r.rmse;
  Eigen::Vector2d t(-vp.plane.normal.y(), vp.plane.normal.x());  // z x n, horizontal
  t.normalize();
  vp.s_min = std::numeric_limits<double>::infinity();
  vp.s_max = -vp.s_min;
  vp.z_min = vp.s_min;
  vp.z_max = -vp.s_min;
  for (std::size_t i : r.inliers) {
    const Vector3f& p = sample.points[i];
    const double sc = t.x() * p.x() + t.y() * p.y();
    vp.s_min = std::min(vp.s_min, sc);
    vp.s_max = std::max(vp.s_max, sc);
    vp.z_min = std::min(vp.z_min, static_cast<double>(p.z()));
    vp.z_max = std::max(vp.z_max, static_cast<double>(p.z()));
    taken[i] = 1;
  }
  const std::size_t num_cells =
      static_cast<std::size_t>(std::min(1e6, std::floor((vp.s_max - vp.s_min) / cell_size))) + 1;
  vp.cells.assign(num_cells, 0);
  for (std::size_t i : r.inliers) {
    const Vector3f& p = sample.points[i];
    const double sc = (t.x() * p.x() + t.y() * p.y() - vp.s_min) / cell_size;
    vp.cells[std::min(num_cells - 1, static_cast<std::size_t>(sc))] = 1;
  }
  return vp;
}

std::vector<VerticalPlaneLabeller> vertical_plane_labellers(const std::vector<VerticalPlane>& planes,
                                                            const FrameSample& sample,
                                                            const VerticalPlaneSettings& s) {
  // Normals within about a neighbourhood of a floor, ceiling or corner are mixed, so sample inliers
  // stop short of the wall's true ends: widen the observed extent by one cell (and a voxel).
  const double widen = s.cell_size + sample.voxel_size;
  std::vector<VerticalPlaneLabeller> lab;
  lab.reserve(planes.size());
  for (const VerticalPlane& vp : planes) {
    const Eigen::Vector2d t = Eigen::Vector2d(-vp.plane.normal.y(), vp.plane.normal.x()).normalized();
    VerticalPlaneLabeller l;
    l.a = static_cast<float>(vp.plane.normal.x());
    l.b = static_cast<float>(vp.plane.normal.y());
    l.c = static_cast<float>(vp.plane.normal.z());
    l.d = static_cast<float>(vp.plane.offset);
    l.tx = static_cast<float>(t.x());
    l.ty = static_cast<float>(t.y());
    l.s_min = static_cast<float>(vp.s_min);
    l.z_lo = static_cast<float>(vp.z_min - widen);
    l.z_hi = static_cast<float>(vp.z_max + widen);
    l.inv_cell = static_cast<float>(1.0 / s.cell_size);
    l.pad = static_cast<float>(std::ceil(sample.voxel_size / s.cell_size));
    l.cells = &vp.cells;
    lab.push_back(l);
  }
  return lab;
}

/// Full-resolution labelling: each point not on the ground goes to the first plane that contains it.
void label_vertical_plane_points(const PointCloud& cloud, const GroundResult* ground, bool use_ground,
                                 const std::vector<VerticalPlaneLabeller>& lab, float tau,
                                 VerticalPlanesResult& out) {
  std::vector<std::uint8_t> is_ground(cloud.points.size(), 0);
  if (use_ground) {
    for (std::size_t i : ground->inliers) is_ground[i] = 1;
  }
  const std::vector<Vector3f>& pts = cloud.points;
  const std::size_t n = pts.size();
  // Points in chunks that stay in L1, planes in groups of 32: one branch-free pass per plane marks
  // the chunk's points within tau of it (the same float test as contains(), so no point is
  // missed), then only marked points are checked against the planes' extents, in plane order (the
  // first plane that contains a point wins).
  constexpr std::size_t kChunk = 1024;
  float x[kChunk], y[kChunk], z[kChunk];  // the chunk's coordinates as arrays: the passes vectorize
  std::uint32_t near[kChunk];
  for (std::size_t base = 0; base < n; base += kChunk) {
    const std::size_t len = std::min(kChunk, n - base);
    for (std::size_t i = 0; i < len; ++i) {
      x[i] = pts[base + i].x();
      y[i] = pts[base + i].y();
      z[i] = pts[base + i].z();
    }
    for (std::size_t first = 0; first < lab.size(); first += 32) {
      const std::size_t last = std::min(lab.size(), first + 32);
      std::fill(near, near + len, 0u);
      for (std::size_t k = first; k < last; ++k) {
        const float a = lab[k].a, b = lab[k].b, c = lab[k].c, d = lab[k].d;
        const std::uint32_t bit = std::uint32_t{1} << (k - first);
        for (std::size_t i = 0; i < len; ++i) {
          near[i] |= std::abs(a * x[i] + b * y[i] + c * z[i] - d) < tau ? bit : 0u;  // NaN: no
        }
      }
      for (std::size_t i = 0; i < len; ++i) {
        std::uint32_t m = near[i];
        const std::size_t g = base + i;
        if (m == 0 || is_ground[g] != 0 || out.plane_of_point[g] >= 0) continue;
        while (m != 0) {
          const std::size_t k = first + static_cast<std::size_t>(__builtin_ctz(m));
          m &= m - 1;
          if (lab[k].contains(pts[g], tau)) {
            out.plane_of_point[g] = static_cast<std::int32_t>(k);
            out.planes[k].num_points += 1;
            out.num_points += 1;
            break;
          }
        }
      }
    }
  }
}

}  // namespace detail

VerticalPlanesResult extract_vertical_planes(const PointCloud& cloud, const FrameSample& sample,
                                             const GroundResult* ground,
                                             const VerticalPlaneSettings& settings) {
  const auto t0 = std::chrono::steady_clock::now();
  const VerticalPlaneSettings& s = settings;
  const bool use_ground = ground != nullptr && ground->status == Status::kOk;
  detail::check_vertical_plane_inputs(cloud, sample, ground, use_ground, s);

  VerticalPlanesResult out;
  out.plane_of_point.assign(cloud.points.size(), -1);
  auto stamp = [&]() {
    out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  };
  if (sample.status != Status::kOk || sample.points.size() < 3) {
    stamp();
    return out;
  }

  // Liu et al. 2022, eq. 12, pre-segmentation, ground sample points removed.
  std::vector<std::uint8_t> taken(sample.points.size(), 0);
  if (use_ground) {
    for (std::size_t i : ground->sample_inliers) taken[i] = 1;
  }
  PresegmentSettings ps;
  ps.angle_kind = PresegmentAngle::kVerticalU;
  ps.max_angle = s.max_u_angle;
  std::vector<std::size_t> candidates;
  for (std::size_t i : presegment(sample.points, sample.normals, ps)) {
    if (taken[i] == 0) candidates.push_back(i);
  }
  out.num_candidates = candidates.size();

  PlaneRansacSettings rs = detail::vertical_plane_ransac_settings(s);
  for (std::size_t k = 0; k < s.max_planes && candidates.size() >= s.min_sample_inliers; ++k) {
    rs.seed = s.seed + k;
    PlaneRansacResult r = fit_plane_ransac(sample.points, candidates, sample.normals, rs);
    out.iterations += r.iterations;
    if (r.status != Status::kOk) break;
    out.planes.push_back(detail::vertical_plane_of_fit(r, sample, s.cell_size, taken));
    std::vector<std::size_t> rest;
    rest.reserve(candidates.size());
    for (std::size_t i : candidates) {
      if (taken[i] == 0) rest.push_back(i);
    }
    candidates.swap(rest);
  }

  const std::vector<detail::VerticalPlaneLabeller> lab = detail::vertical_plane_labellers(out.planes, sample, s);
  if (!lab.empty()) {
    detail::label_vertical_plane_points(cloud, ground, use_ground, lab, static_cast<float>(s.distance_threshold), out);
  }
  out.status = out.planes.empty() ? Status::kInsufficientData : Status::kOk;
  {
    stamp();
    return out;
  }
}

}  // namespace plumb
