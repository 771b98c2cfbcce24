// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/sim/robot.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "plumb/core/error.hpp"

namespace plumb::sim {

RobotState integrate_robot_step(const RobotState& s0, double jerk, double angular_jerk, double dt) {
  auto advance = [&](double h) {
    RobotState s = s0;
    s.t = s0.t + h;
    s.a = s0.a + jerk * h;
    s.v = s0.v + s0.a * h + 0.5 * jerk * h * h;
    s.s = s0.s + s0.v * h + 0.5 * s0.a * h * h + jerk * h * h * h / 6.0;
    s.alpha = s0.alpha + angular_jerk * h;
    s.w = s0.w + s0.alpha * h + 0.5 * angular_jerk * h * h;
    s.pose.theta = s0.pose.theta + s0.w * h + 0.5 * s0.alpha * h * h + angular_jerk * h * h * h / 6.0;
    return s;
  };
  const RobotState mid = advance(0.5 * dt);
  RobotState end = advance(dt);
  // Simpson's rule for the position: exact for the speed (cubic) times a smooth heading up to O(dt^5).
  end.pose.x = s0.pose.x + dt / 6.0 *
                               (s0.v * std::cos(s0.pose.theta) + 4.0 * mid.v * std::cos(mid.pose.theta) +
                                end.v * std::cos(end.pose.theta));
  end.pose.y = s0.pose.y + dt / 6.0 *
                               (s0.v * std::sin(s0.pose.theta) + 4.0 * mid.v * std::sin(mid.pose.theta) +
                                end.v * std::sin(end.pose.theta));
  return end;
}

RobotState RobotTrajectory::state_at(double t) const {
  PLUMB_CHECK(!states.empty(), "RobotTrajectory::state_at: empty trajectory");
  if (states.size() == 1 || t <= states.front().t) return states.front();
  if (t >= states.back().t) return states.back();
  const double dt = states[1].t - states[0].t;
  std::size_t k = static_cast<std::size_t>(std::floor((t - states.front().t) / dt));
  k = std::min(k, states.size() - 2);
  while (k > 0 && states[k].t > t) --k;
  while (k + 2 < states.size() && states[k + 1].t <= t) ++k;
  const RobotState& s0 = states[k];
  const RobotState& s1 = states[k + 1];
  const double h = s1.t - s0.t;
  const double jerk = (s1.a - s0.a) / h, angular_jerk = (s1.alpha - s0.alpha) / h;
  RobotState s = integrate_robot_step(s0, jerk, angular_jerk, t - s0.t);
  s.t = t;
  return s;
}

Eigen::Isometry3d RobotTrajectory::T_world_base(double t) const {
  const RobotState s = state_at(t);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(s.pose.theta, Vector3d::UnitZ()).toRotationMatrix();
  T.translation() = Vector3d(s.pose.x, s.pose.y, floor_z);
  return T;
}

namespace {

/// The polyline driven: the route repeated `loops` times, cut at max_length, with arc lengths.
struct Polyline {
  std::vector<Vector2d> points;
  std::vector<double> cum;  // arc length at each point
  double length() const { return cum.back(); }
  Vector2d at(double s) const {
    s = std::clamp(s, 0.0, length());
    const auto it = std::upper_bound(cum.begin(), cum.end(), s);
    std::size_t j = static_cast<std::size_t>(std::max<std::ptrdiff_t>(1, it - cum.begin()));
    j = std::min(j, points.size() - 1);
    const double seg = cum[j] - cum[j - 1];
    const double f = seg > 0.0 ? (s - cum[j - 1]) / seg : 0.0;
    return points[j - 1] + f * (points[j] - points[j - 1]);
  }
};

Polyline build_polyline(const std::vector<Vector2d>& path, bool closed, int loops, double max_length) {
  Polyline p;
  for (int l = 0; l < loops; ++l) {
    for (const Vector2d& q : path) {
      if (p.points.empty() || (q - p.points.back()).norm() > 1e-9) p.points.push_back(q);
    }
    if (!closed) break;
  }
  if (closed && (p.points.back() - path.front()).norm() > 1e-9) p.points.push_back(path.front());
  p.cum.assign(1, 0.0);
  for (std::size_t i = 1; i < p.points.size(); ++i) p.cum.push_back(p.cum.back() + (p.points[i] - p.points[i - 1]).norm());
  if (max_length > 0.0 && max_length < p.length()) {
    const Vector2d end = p.at(max_length);
    std::size_t keep = 1;
    while (keep < p.cum.size() && p.cum[keep] < max_length) ++keep;
    p.points.resize(keep);
    p.cum.resize(keep);
    p.points.push_back(end);
    p.cum.push_back(max_length);
  }
  return p;
}

}  // namespace

RobotTrajectory drive_route(const std::vector<Vector2d>& path, bool closed, int loops, double max_length,
                            double floor_z, const RobotSettings& rs) {
  PLUMB_CHECK(path.size() >= 2, "drive_route: the path needs at least 2 points, got " << path.size());
  PLUMB_CHECK(loops >= 1, "drive_route: loops must be at least 1, got " << loops);
  PLUMB_CHECK(max_length >= 0.0 && std::isfinite(max_length), "drive_route: bad max_length " << max_length);
  PLUMB_CHECK(rs.rate_hz > 0.0 && rs.max_speed > 0.0 && rs.max_turn_rate > 0.0 && rs.max_acceleration > 0.0 &&
                  rs.max_angular_acceleration > 0.0 && rs.max_jerk > 0.0 && rs.max_angular_jerk > 0.0 &&
                  rs.max_lateral_acceleration > 0.0 && rs.lookahead > 0.0,
              "drive_route: every RobotSettings limit and rate must be positive");
  for (const Vector2d& q : path) PLUMB_CHECK(q.allFinite(), "drive_route: non-finite path point");
  const Polyline line = build_polyline(path, closed, loops, max_length);
  PLUMB_CHECK(line.length() > 1e-6, "drive_route: the path has zero length");

  const double dt = 1.0 / rs.rate_hz;
  RobotTrajectory traj;
  traj.floor_z = floor_z;
  RobotState state;
  state.t = rs.start_time;
  state.pose = Pose2{line.points[0].x(), line.points[0].y(),
                     std::atan2(line.points[1].y() - line.points[0].y(), line.points[1].x() - line.points[0].x())};
  const std::size_t still_steps = static_cast<std::size_t>(std::llround(rs.still_before * rs.rate_hz));
  std::size_t step = 0;
  traj.states.push_back(state);

  // Second-order tracking of a commanded rate: desired acceleration proportional to the rate error
  // (gain k_rate), jerk proportional to the acceleration error (gain k_acc); both clamped. The
  // closed loop s^2 + k_acc s + k_acc k_rate has real poles (overdamped) for k_acc >= 4 k_rate.
  constexpr double k_rate = 4.0, k_acc = 16.0;
  auto jerk_for = [&](double rate, double acc, double cmd, double max_acc, double max_jerk) {
    const double acc_des = std::clamp(k_rate * (cmd - rate), -max_acc, max_acc);
    return std::clamp(k_acc * (acc_des - acc), -max_jerk, max_jerk);
  };

  double progress = 0.0;  // arc length of the closest point on the polyline [m]
  std::vector<double> window_q, window_d;
  bool turning_in_place = false;
  double settled_time = -1.0;
  const double max_steps = (rs.max_duration + rs.still_before + rs.still_after) * rs.rate_hz;
  for (;;) {
    double v_cmd = 0.0, w_cmd = 0.0;
    bool arrived = false;
    if (step >= still_steps) {
      // Progress along the path: it only moves forward, by at most 1 m per step, to the furthest
      // local minimum of the distance to the robot that is within 5 cm of the smallest (so that
      // where the path doubles back the robot is taken to be on the way back, never stuck at the
      // turning point).
      const Vector2d p(state.pose.x, state.pose.y);
      const double window_end = std::min(progress + 1.0, line.length());
      window_q.clear();
      window_d.clear();
      for (double q = progress; q <= window_end + 1e-12; q += 0.01) {
        window_q.push_back(q);
        window_d.push_back((line.at(q) - p).norm());
      }
      const double d_min = *std::min_element(window_d.begin(), window_d.end());
      for (std::size_t i = 0; i < window_q.size(); ++i) {
        const bool local_min = (i == 0 || window_d[i] <= window_d[i - 1]) &&
                               (i + 1 == window_q.size() || window_d[i] <= window_d[i + 1]);
        if (local_min && window_d[i] <= d_min + 0.05) progress = std::max(progress, window_q[i]);
      }
      const double best_s = progress;
      const double remaining = line.length() - best_s;
      if (remaining < 0.05) {
        arrived = true;
      } else {
        // Lookahead target: lookahead further along the path, and at least half of it away from the
        // robot (where the path doubles back on itself the point ahead can be right under it).
        Vector2d target = line.at(best_s + rs.lookahead);
        for (double ahead = rs.lookahead; ahead < rs.lookahead + 4.0 && best_s + ahead < line.length();
             ahead += 0.05) {
          target = line.at(best_s + ahead);
          if ((target - p).norm() >= 0.5 * rs.lookahead) break;
        }
        const double c = std::cos(state.pose.theta), s = std::sin(state.pose.theta);
        const Vector2d d = target - p;
        const Vector2d d_base(c * d.x() + s * d.y(), -s * d.x() + c * d.y());
        const double heading_error = std::atan2(d_base.y(), d_base.x());
        if (std::abs(heading_error) > 1.0) turning_in_place = true;
        if (std::abs(heading_error) < 0.3) turning_in_place = false;
        if (turning_in_place) {
          w_cmd = std::copysign(0.6 * rs.max_turn_rate, heading_error);
        } else {
          const double curvature = 2.0 * d_base.y() / std::max(d_base.squaredNorm(), 1e-9);
          const double abs_k = std::abs(curvature);
          v_cmd = rs.max_speed;
          if (abs_k > 1e-9) {
            v_cmd = std::min({v_cmd, rs.max_turn_rate / abs_k, std::sqrt(rs.max_lateral_acceleration / abs_k)});
          }
          v_cmd = std::min(v_cmd, std::sqrt(rs.max_acceleration * std::max(remaining - 0.03, 0.0)));
          // Slow down before corners: wherever the path ahead turns by more than ~20 degrees, be at
          // corner speed by then (half the acceleration limit, the rate loop lags).
          const Vector2d dir0 = line.at(best_s + 0.1) - line.at(best_s);
          for (double ahead = 0.25; ahead <= 4.0; ahead += 0.25) {
            const Vector2d dir1 = line.at(best_s + ahead + 0.1) - line.at(best_s + ahead);
            if (dir0.norm() < 1e-9 || dir1.norm() < 1e-9) continue;
            const double turn = std::atan2(dir0.x() * dir1.y() - dir0.y() * dir1.x(), dir0.dot(dir1));
            if (std::abs(turn) < 0.35) continue;
            const double v_corner = std::max(0.15, std::min(rs.max_speed, 0.25 / std::abs(turn)));
            v_cmd = std::min(v_cmd, std::sqrt(v_corner * v_corner +
                                              rs.max_acceleration * std::max(ahead - 0.5 * rs.lookahead, 0.0)));
            break;
          }
          w_cmd = std::clamp(std::max(state.v, 0.0) * curvature, -rs.max_turn_rate, rs.max_turn_rate);
        }
      }
    }
    if (arrived) {
      const bool at_rest = std::abs(state.v) < 1e-3 && std::abs(state.w) < 1e-3 && std::abs(state.a) < 1e-3 &&
                           std::abs(state.alpha) < 1e-3;
      if (at_rest && settled_time < 0.0) settled_time = state.t;
      if (settled_time >= 0.0 && state.t - settled_time >= rs.still_after) break;
    }
    const double j = jerk_for(state.v, state.a, v_cmd, rs.max_acceleration, rs.max_jerk);
    const double jw = jerk_for(state.w, state.alpha, w_cmd, rs.max_angular_acceleration, rs.max_angular_jerk);
    state = integrate_robot_step(state, j, jw, dt);
    ++step;
    state.t = rs.start_time + static_cast<double>(step) * dt;
    traj.states.push_back(state);
    PLUMB_CHECK(static_cast<double>(step) < max_steps,
                "drive_route: the robot did not reach the end of the " << line.length() << " m route within "
                                                                       << rs.max_duration << " s");
  }
  return traj;
}

}  // namespace plumb::sim
