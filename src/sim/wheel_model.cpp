// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/sim/wheel_model.hpp"

#include <cmath>

#include "plumb/core/error.hpp"
#include "plumb/core/rng.hpp"

namespace plumb::sim {

std::vector<WheelEncoderReading> simulate_wheels(const RobotTrajectory& trajectory, const WheelSettings& ws) {
  PLUMB_CHECK(!trajectory.states.empty(), "simulate_wheels: empty trajectory");
  PLUMB_CHECK(ws.radius > 0.0 && ws.axle > 0.0 && ws.rate_hz > 0.0,
              "simulate_wheels: radius, axle and rate_hz must be positive (" << ws.radius << ", " << ws.axle << ", "
                                                                            << ws.rate_hz << ")");
  PLUMB_CHECK(ws.radius_error_left > -1.0 && ws.radius_error_right > -1.0 && ws.axle_error > -1.0 &&
                  ws.slip_sigma >= 0.0,
              "simulate_wheels: radius/axle errors must exceed -1 and slip_sigma must not be negative");
  const double r_left = ws.radius * (1.0 + ws.radius_error_left);
  const double r_right = ws.radius * (1.0 + ws.radius_error_right);
  const double half_axle = 0.5 * ws.axle * (1.0 + ws.axle_error);
  Rng rng(ws.seed);
  const double t0 = trajectory.start_time(), t1 = trajectory.end_time();
  const RobotState s0 = trajectory.states.front();
  std::vector<WheelEncoderReading> out;
  double prev_left = 0.0, prev_right = 0.0;  // true angles at the previous reading
  double left = 0.0, right = 0.0;            // measured (slipping) angles
  for (std::size_t k = 0;; ++k) {
    const double t = t0 + static_cast<double>(k) / ws.rate_hz;
    if (t > t1 + 1e-9) break;
    const RobotState s = trajectory.state_at(t);
    const double dtheta = s.pose.theta - s0.pose.theta, ds = s.s - s0.s;
    const double true_left = (ds - half_axle * dtheta) / r_left;
    const double true_right = (ds + half_axle * dtheta) / r_right;
    if (k > 0) {
      left += (true_left - prev_left) * (1.0 + ws.slip_sigma * rng.normal());
      right += (true_right - prev_right) * (1.0 + ws.slip_sigma * rng.normal());
    }
    prev_left = true_left;
    prev_right = true_right;
    out.push_back({t, left, right});
  }
  return out;
}

std::vector<OdomSample> integrate_wheel_odometry(const std::vector<WheelEncoderReading>& wheels,
                                                     double radius_left, double radius_right, double axle,
                                                     const Pose2& start) {
  PLUMB_CHECK(radius_left > 0.0 && radius_right > 0.0 && axle > 0.0,
              "integrate_wheel_odometry: radii and axle must be positive (" << radius_left << ", " << radius_right
                                                                            << ", " << axle << ")");
  std::vector<OdomSample> out;
  out.reserve(wheels.size());
  Pose2 pose = start;
  for (std::size_t k = 0; k < wheels.size(); ++k) {
    if (k > 0) {
      PLUMB_CHECK(wheels[k].stamp > wheels[k - 1].stamp,
                  "integrate_wheel_odometry: reading " << k << ": stamp " << wheels[k].stamp << " does not increase");
      const double dl = radius_left * (wheels[k].left - wheels[k - 1].left);
      const double dr = radius_right * (wheels[k].right - wheels[k - 1].right);
      const double ds = 0.5 * (dl + dr), dtheta = (dr - dl) / axle;
      Pose2 step{ds, 0.0, dtheta};
      if (std::abs(dtheta) > 1e-9) {  // chord of the arc of length ds turning by dtheta
        step.x = ds * std::sin(dtheta) / dtheta;
        step.y = ds * (1.0 - std::cos(dtheta)) / dtheta;
      } else {
        step.y = 0.5 * ds * dtheta;
      }
      pose = pose.oplus(step);
    }
    out.push_back({wheels[k].stamp, pose});
  }
  return out;
}

}  // namespace plumb::sim
