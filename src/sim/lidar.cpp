// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/sim/lidar.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "plumb/core/error.hpp"

namespace plumb::sim {

namespace {


/// Reflectivity of each class, scaled so a head-on return reads 255 * albedo.
float albedo_of(SimLabel label) {
  switch (label) {
    case kSimGround: return 0.35f;
    case kSimWall: return 0.7f;
    case kSimOtherElement: return 0.5f;
    case kSimClutter: return 0.3f;
    default: return 0.5f;
  }
}

}  // namespace

PointCloud simulate_sweep(const World& world, const LidarModel& lidar,
                          const std::function<Eigen::Isometry3d(double)>& T_world_lidar, double stamp, Rng& rng,
                          const SweepSettings& settings) {
  lidar.validate();
  PLUMB_CHECK(static_cast<bool>(T_world_lidar), "simulate_sweep: T_world_lidar is empty");
  PLUMB_CHECK(std::isfinite(stamp), "simulate_sweep: stamp " << stamp << " is not finite");
  const std::size_t rows = lidar.elevations_rad.size();
  const auto cols = static_cast<std::size_t>(lidar.columns);
  const double cos_max_incidence = std::cos(settings.max_incidence_rad);
  const bool noisy = settings.noise && lidar.range_sigma > 0.0;
  const bool drops = settings.dropouts && lidar.dropout > 0.0;

  std::vector<double> cos_el(rows), sin_el(rows);
  for (std::size_t r = 0; r < rows; ++r) {
    cos_el[r] = std::cos(lidar.elevations_rad[r]);
    sin_el[r] = std::sin(lidar.elevations_rad[r]);
  }
  PointCloud cloud;
  cloud.points.reserve(rows * cols);
  cloud.intensities.reserve(rows * cols);
  cloud.rings.reserve(rows * cols);
  cloud.times.reserve(rows * cols);
  cloud.labels.reserve(rows * cols);

  const double column_dt = 1.0 / (static_cast<double>(cols) * lidar.rate_hz);
  const Eigen::Isometry3d T_stamp = T_world_lidar(stamp);
  for (std::size_t c = 0; c < cols; ++c) {
    const double dt = static_cast<double>(c) * column_dt;
    const Eigen::Isometry3d T = settings.motion_distortion ? T_world_lidar(stamp + dt) : T_stamp;
    PLUMB_CHECK(T.matrix().allFinite(), "simulate_sweep: T_world_lidar(" << stamp + dt << ") is not finite");
    const Matrix3d R = T.linear();
    const Vector3d o = T.translation();
    const double az = lidar.azimuth_offset_rad + 2.0 * kPi * static_cast<double>(c) / static_cast<double>(cols);
    const double ca = std::cos(az), sa = std::sin(az);
    for (std::size_t r = 0; r < rows; ++r) {
      const Vector3d d_lidar(cos_el[r] * ca, cos_el[r] * sa, sin_el[r]);
      const Vector3d d_world = R * d_lidar;
      const RayHit hit = world.cast(o, d_world, lidar.max_range, stamp + dt);
      if (!hit.hit()) continue;
      const double cos_inc = -hit.normal.dot(d_world);
      double range = hit.range;
      if (noisy) range += lidar.range_sigma * rng.normal();
      if (drops && rng.uniform() < lidar.dropout) continue;
      if (cos_inc < cos_max_incidence) continue;
      if (range < lidar.min_range || range >= lidar.max_range) continue;
      const SimLabel label = world.label_of(hit);
      cloud.points.push_back((range * d_lidar).cast<float>());
      cloud.intensities.push_back(255.0f * albedo_of(label) * static_cast<float>(std::clamp(cos_inc, 0.0, 1.0)));
      cloud.rings.push_back(static_cast<std::uint16_t>(r));
      cloud.times.push_back(static_cast<float>(dt));
      cloud.labels.push_back(static_cast<std::int32_t>(label));
    }
  }
  return cloud;
}

}  // namespace plumb::sim
