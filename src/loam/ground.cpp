// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/loam/ground.hpp"

#include <algorithm>
#include <cmath>

#include <Eigen/Cholesky>

#include "plumb/core/error.hpp"

namespace plumb {

RingGroundResult classify_ground(const PointCloud& cloud, const RangeImage& image,
                                 const Eigen::Matrix3d& R_level, const RingGroundSettings& settings) {
  PLUMB_CHECK(settings.max_slope_deg >= 0.0 && settings.max_slope_deg < 90.0,
              "classify_ground: max_slope_deg must be in [0, 90), got " << settings.max_slope_deg);
  PLUMB_CHECK(std::isfinite(settings.plane_tolerance) && settings.plane_tolerance >= 0.0,
              "classify_ground: plane_tolerance must be >= 0 [m], got " << settings.plane_tolerance);
  PLUMB_CHECK(R_level.allFinite(), "classify_ground: R_level is not finite");
  PLUMB_CHECK(image.point_row.size() == cloud.size() &&
                  image.index.size() == static_cast<std::size_t>(image.num_rows) * static_cast<std::size_t>(image.num_columns),
              "classify_ground: the range image was not built from this cloud (" << image.point_row.size()
                                                                                << " points vs " << cloud.size() << ")");
  RingGroundResult out;
  out.ground.assign(cloud.size(), 0);
  const double slope = std::tan(settings.max_slope_deg * 3.14159265358979323846 / 180.0);

  // 1. LeGO-LOAM's pair test on the rows below the horizon.
  for (int r = 0; r + 1 < image.num_rows; ++r) {
    if (!(image.row_elevation[static_cast<std::size_t>(r)] < 0.0)) continue;
    for (int c = 0; c < image.num_columns; ++c) {
      const std::int32_t i0 = image.at(r, c), i1 = image.at(r + 1, c);
      if (i0 < 0 || i1 < 0) continue;
      const Eigen::Vector3d d =
          R_level * (cloud.points[static_cast<std::size_t>(i1)] - cloud.points[static_cast<std::size_t>(i0)]).cast<double>();
      if (std::abs(d.z()) <= slope * d.head<2>().norm()) {
        out.ground[static_cast<std::size_t>(i0)] = 1;
        out.ground[static_cast<std::size_t>(i1)] = 1;
      }
    }
  }

  // 2. The plane through the pair test's ground, and every return below the sensor close to it.
  if (settings.plane_tolerance > 0.0) {
    std::vector<Eigen::Vector3d> lev(cloud.size());
    for (std::size_t i = 0; i < cloud.size(); ++i) lev[i] = R_level * cloud.points[i].cast<double>();
    auto height = [&](const Eigen::Vector3d& q) { return q.z() - out.plane.dot(Eigen::Vector3d(q.x(), q.y(), 1.0)); };
    bool fitted = true;
    for (int round = 0; round < 3 && fitted; ++round) {
      Eigen::Matrix3d A = Eigen::Matrix3d::Zero();
      Eigen::Vector3d rhs = Eigen::Vector3d::Zero();
      std::size_t n = 0;
      for (std::size_t i = 0; i < cloud.size(); ++i) {
        const Eigen::Vector3d& q = lev[i];
        if (!out.ground[i] || !q.allFinite()) continue;
        if (round > 0 && std::abs(height(q)) > settings.plane_tolerance) continue;
        const Eigen::Vector3d u(q.x(), q.y(), 1.0);
        A.noalias() += u * u.transpose();
        rhs += u * q.z();
        ++n;
      }
      const Eigen::LDLT<Eigen::Matrix3d> ldlt(A);
      const Eigen::Vector3d abc = ldlt.solve(rhs);
      fitted = n >= std::max<std::size_t>(settings.min_plane_points, 3) && ldlt.info() == Eigen::Success &&
               abc.allFinite();
      if (fitted) out.plane = abc;
    }
    out.plane_used = fitted && out.plane.head<2>().norm() <= slope && out.plane.z() < 0.0;
    if (out.plane_used) {
      for (std::size_t i = 0; i < cloud.size(); ++i) {
        const Eigen::Vector3d& q = lev[i];
        if (out.ground[i] || !q.allFinite() || !(q.z() < 0.0)) continue;
        if (std::abs(height(q)) <= settings.plane_tolerance) {
          out.ground[i] = 1;
          ++out.num_from_plane;
        }
      }
    } else {
      out.plane.setZero();
    }
  }
  for (char g : out.ground) out.num_ground += g ? 1 : 0;
  return out;
}

}  // namespace plumb
