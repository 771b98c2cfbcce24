// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/scan2d/scan_odometry.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

#include "plumb/core/error.hpp"

namespace plumb {

ScanOdometry::ScanOdometry(const ScanOdometrySettings& settings) : settings_(settings) {
  PLUMB_CHECK(settings.local_map_size >= 1, "ScanOdometry: local_map_size must be >= 1");
}

void ScanOdometry::add_keyframe(const LaserScan& scan, const Pose2& T_world_laser) {
  keyframes_.push_back({scan, T_world_laser});
  while (keyframes_.size() > settings_.local_map_size) keyframes_.pop_front();
  // The local map lives in the newest keyframe's laser frame.
  const Pose2 T_kf_world = keyframes_.back().T_world_laser.ominus();
  std::vector<const LaserScan*> scans;
  std::vector<Pose2> poses;
  for (const Keyframe& k : keyframes_) {
    scans.push_back(&k.scan);
    poses.push_back(T_kf_world.oplus(k.T_world_laser));
  }
  map_ = PlicpReference(scans, poses, settings_.reference);
}

bool ScanOdometry::passes_gate(const PlicpResult& m, const Pose2& start) const {
  const Pose2 dev = start.ominus().oplus(m.T_ref_cur);
  return (m.status == Status::kOk || m.status == Status::kNotConverged) &&
         m.valid_fraction >= settings_.min_valid_fraction && std::sqrt(m.mse) <= settings_.max_rmse &&
         std::hypot(dev.x, dev.y) <= settings_.max_prior_deviation_xy &&
         std::abs(wrap_angle(dev.theta)) <= settings_.max_prior_deviation_theta;
}

Pose2 ScanOdometry::fuse_with_prior(const PlicpResult& m, const Pose2& prior, const Pose2& motion) {
  const ScanOdometrySettings& s = settings_;
  const double dist = std::hypot(motion.x, motion.y);
  const double sxy = s.odometry_sigma_xy_min + s.odometry_sigma_xy_per_m * dist;
  const double sth = s.odometry_sigma_theta_min + s.odometry_sigma_theta_per_rad * std::abs(wrap_angle(motion.theta)) +
                     s.odometry_sigma_theta_per_m * dist;
  // The odometry's own disagreement with recent confident matches, when larger than the model.
  const double vxy = std::max(sxy * sxy, residual_xy2_);
  const double vth = std::max(sth * sth, residual_th2_);
  // Translation noise is isotropic, so it reads the same in the keyframe frame as in the robot's.
  Matrix3d C_prior = Matrix3d::Zero();
  C_prior(0, 0) = C_prior(1, 1) = vxy;
  C_prior(2, 2) = vth;
  const Matrix3d C_match = s.match_covariance_scale * m.covariance;
  const Matrix3d sum = C_prior + C_match;
  const Eigen::LDLT<Matrix3d> ldlt(sum);
  if (ldlt.info() != Eigen::Success || !ldlt.isPositive()) return m.T_ref_cur;
  const Vector3d d(m.T_ref_cur.x - prior.x, m.T_ref_cur.y - prior.y, wrap_angle(m.T_ref_cur.theta - prior.theta));
  const double w = residual_count_ < 20 ? 1.0 / static_cast<double>(++residual_count_) : 0.05;
  residual_xy2_ += w * (0.5 * d.head<2>().squaredNorm() - residual_xy2_);
  residual_th2_ += w * (d.z() * d.z() - residual_th2_);
  // x = prior + C_prior (C_prior + C_match)^-1 (match - prior): the information-form mean.
  const Vector3d gain_input = ldlt.solve(d);
  // A prior that disagrees with the match beyond both budgets (an odometry glitch, a slip the gate
  // let through) is not fused: the match stands.
  if (d.dot(gain_input) > settings_.fusion_max_chi2) return m.T_ref_cur;
  const Vector3d step = C_prior * gain_input;
  if (!step.allFinite()) return m.T_ref_cur;
  return Pose2{prior.x + step.x(), prior.y + step.y(), wrap_angle(prior.theta + step.z())};
}

ScanOdometryStep ScanOdometry::add(const LaserScan& scan, const Pose2& odom_pose) {
  PLUMB_CHECK(std::isfinite(odom_pose.x) && std::isfinite(odom_pose.y) && std::isfinite(odom_pose.theta),
              "ScanOdometry::add: odometry pose is not finite");
  scan.check_consistent("ScanOdometry::add");
  const Pose2& l = settings_.T_base_laser;
  ScanOdometryStep step;
  if (!started_) {
    started_ = true;
    T_world_base_ = odom_pose;
    last_odom_ = odom_pose;
    fresh_odom_ = odom_pose;
    T_world_base_at_fresh_ = odom_pose;
    add_keyframe(scan, T_world_base_.oplus(l));
    step.T_world_base = T_world_base_;
    return step;
  }
  // Prediction from wheel odometry (Liu et al. 2022, sec. 3.3, loop steps (1)-(2)).
  const Pose2 T_world_base_prev = T_world_base_;
  // The odometry's motion is measured from the last reading that changed, applied to the
  // estimate at that scan: odometry that arrives less often than the scans (a slow topic, stamps
  // quantised to seconds) repeats its last pose for a while, then jumps by everything since. A
  // repeated reading says nothing about the motion since the last scan; the prior then is
  // standing still, which the gate and the prior-free retry judge like any other.
  const bool repeated =
      odom_pose.x == last_odom_.x && odom_pose.y == last_odom_.y && odom_pose.theta == last_odom_.theta;
  const Pose2 odom_motion =
      repeated ? Pose2{}
               : T_world_base_prev.ominus().oplus(T_world_base_at_fresh_).oplus(fresh_odom_.ominus().oplus(odom_pose));
  last_odom_ = odom_pose;
  const Pose2 T_world_laser_guess = T_world_base_.oplus(odom_motion).oplus(l);
  const Pose2& T_world_kf = keyframes_.back().T_world_laser;
  const Pose2 T_kf_cur_guess = T_world_kf.ominus().oplus(T_world_laser_guess);

  const auto t0 = std::chrono::steady_clock::now();
  step.match = plicp(scan, map_, T_kf_cur_guess, settings_.plicp);
  step.match_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();

  const PlicpResult& m = step.match;
  const bool good = passes_gate(m, T_kf_cur_guess);
  Pose2 T_kf_cur = T_kf_cur_guess;
  if (good) {
    T_kf_cur = m.T_ref_cur;
    step.mode = ScanMatchMode::kMatched;
    if (m.degenerate && settings_.prior_along_degenerate_direction) {
      // Replace the match's component along the weak direction (normalized x, y, L theta) by the prior's.
      const double L = m.characteristic_length;
      Vector3d delta(m.T_ref_cur.x - T_kf_cur_guess.x, m.T_ref_cur.y - T_kf_cur_guess.y,
                     L * wrap_angle(m.T_ref_cur.theta - T_kf_cur_guess.theta));
      delta -= delta.dot(m.weakest_direction) * m.weakest_direction;
      T_kf_cur = Pose2{T_kf_cur_guess.x + delta.x(), T_kf_cur_guess.y + delta.y(),
                       T_kf_cur_guess.theta + delta.z() / L};
      step.mode = ScanMatchMode::kDegenerate;
    } else if (settings_.fuse_prior) {
      T_kf_cur = fuse_with_prior(m, T_kf_cur_guess, laser_motion(odom_motion, l));
    }
  } else {
    step.mode = ScanMatchMode::kFallback;
    if (settings_.prior_free_retry) {
      // Starts that do not use this step's odometry: the previous step repeated, and standing still.
      const Pose2 T_kf_prev = T_world_kf.ominus().oplus(T_world_base_prev.oplus(l));
      const Pose2 starts[2] = {T_kf_prev.oplus(laser_motion(last_motion_, l)), T_kf_prev};
      // What the prior's own match explained (step.match is overwritten by an accepted retry).
      const double prior_valid_fraction = m.num_points == 0 ? 0.0 : m.valid_fraction;
      double best_mse = std::numeric_limits<double>::infinity();
      for (const Pose2& start : starts) {
        const Pose2 d = T_kf_cur_guess.ominus().oplus(start);
        if (std::hypot(d.x, d.y) < 1e-3 && std::abs(wrap_angle(d.theta)) < 1e-3) continue;  // the prior's own start
        const auto t1 = std::chrono::steady_clock::now();
        PlicpResult r = plicp(scan, map_, start, settings_.plicp);
        step.match_ms += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t1).count();
        // Without a prior, a weak direction (along a corridor) holds no information at all: a
        // degenerate match from a guessed start is the guess, not a measurement. And a match that
        // pairs fewer of the scan's points than the prior's own match did has merely found a
        // smaller part of the scan that fits (a corridor's walls a metre back): the prior stands.
        const bool explains_as_much = r.valid_fraction >= prior_valid_fraction;
        if (passes_gate(r, start) && !r.degenerate && explains_as_much && r.mse < best_mse) {
          best_mse = r.mse;
          T_kf_cur = r.T_ref_cur;
          step.match = r;
          step.mode = ScanMatchMode::kPriorFree;
        }
      }
    }
  }
  const Pose2 T_world_laser = T_world_kf.oplus(T_kf_cur);
  T_world_base_ = T_world_laser.oplus(l.ominus());
  T_world_base_.theta = wrap_angle(T_world_base_.theta);
  last_motion_ = T_world_base_prev.ominus().oplus(T_world_base_);
  step.T_world_base = T_world_base_;
  if (!repeated) {
    fresh_odom_ = odom_pose;
    T_world_base_at_fresh_ = T_world_base_;
  }

  const Pose2 since_kf = T_world_kf.ominus().oplus(T_world_laser);
  if (std::hypot(since_kf.x, since_kf.y) >= settings_.keyframe_distance ||
      std::abs(wrap_angle(since_kf.theta)) >= settings_.keyframe_angle) {
    add_keyframe(scan, T_world_laser);
  }
  return step;
}

ScanOdometryResult run_scan_odometry(const std::vector<LaserScan>& scans,
                                     const std::vector<Pose2>& odometry,
                                     const ScanOdometrySettings& settings) {
  PLUMB_CHECK(scans.size() == odometry.size(), "run_scan_odometry: " << scans.size() << " scans but "
                                                   << odometry.size() << " odometry poses");
  ScanOdometry so(settings);
  ScanOdometryResult r;
  double sum_it = 0.0, sum_ms = 0.0;
  std::size_t attempts = 0;
  for (std::size_t k = 0; k < scans.size(); ++k) {
    const ScanOdometryStep s = so.add(scans[k], odometry[k]);
    r.poses.push_back(s.T_world_base);
    r.modes.push_back(s.mode);
    r.iterations.push_back(s.match.iterations);
    if (s.mode == ScanMatchMode::kInitial) continue;
    ++attempts;
    sum_it += s.match.iterations;
    sum_ms += s.match_ms;
    if (s.mode == ScanMatchMode::kFallback) ++r.num_fallbacks;
    else ++r.num_matched;
    if (s.mode == ScanMatchMode::kDegenerate) ++r.num_degenerate;
    if (s.mode == ScanMatchMode::kPriorFree) ++r.num_prior_free;
  }
  if (attempts > 0) {
    r.mean_iterations = sum_it / static_cast<double>(attempts);
    r.mean_match_ms = sum_ms / static_cast<double>(attempts);
  }
  return r;
}

}  // namespace plumb
