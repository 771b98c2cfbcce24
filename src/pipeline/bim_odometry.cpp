// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/pipeline/bim_odometry.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <future>
#include <limits>
#include <utility>
#include <vector>

#include <Eigen/Eigenvalues>

#include "plumb/core/clock.hpp"
#include "plumb/core/error.hpp"
#include "plumb/core/lie.hpp"
#include "plumb/core/parallel.hpp"
#include "plumb/filters/voxel_grid.hpp"

namespace plumb {
namespace {

/// How far a registration may move the key points from their predicted pose and still pair with
/// exactly the points it would find in the whole cloud [m]; farther, the composer's gate rejects it.
constexpr double kTargetMotion = 0.5;

}  // namespace

Matrix3d front_end_step_covariance(const BimOdometrySettings& s, const Pose2& front_step, const Pose2& wheel_step,
                                   bool matched, const Matrix3d& match_covariance) {
  // Pose2's operators do not wrap: a step across ±π may come as ~2π.
  const double dist = std::hypot(front_step.x, front_step.y), turn = std::abs(wrap_angle(front_step.theta));
  const double sxy = (matched ? s.motion_sigma_xy : s.fallback_sigma_xy) * dist + 1e-4;
  const double sth = (matched ? s.motion_sigma_theta : s.fallback_sigma_theta) * (turn + dist) + 1e-5;
  Matrix3d c = Vector3d(sxy * sxy, sxy * sxy, sth * sth).asDiagonal();
  if (!matched) return c;
  if (match_covariance.allFinite()) c += match_covariance;
  // More disagreement with the wheels than their error budget: the match may be the one that is off.
  const double dxy = std::hypot(front_step.x - wheel_step.x, front_step.y - wheel_step.y);
  const double dth = std::abs(wrap_angle(front_step.theta - wheel_step.theta));
  const double exy = std::max(0.0, dxy - s.wheel_tolerance_xy - s.wheel_tolerance_ratio * dist);
  const double eth = std::max(0.0, dth - s.wheel_tolerance_theta - s.wheel_tolerance_ratio * turn);
  c.diagonal() += Vector3d(exy * exy, exy * exy, eth * eth);
  return c;
}

Pose2 front_end_step(const BimOdometrySettings& s, const Pose2& front_step, const Pose2& wheel_step, bool matched,
                     const Matrix3d& covariance) {
  if (!matched) return front_step;
  const double dist = std::hypot(front_step.x, front_step.y), turn = std::abs(wrap_angle(front_step.theta));
  const double txy = s.wheel_tolerance_xy + s.wheel_tolerance_ratio * dist;
  const double tth = s.wheel_tolerance_theta + s.wheel_tolerance_ratio * turn;
  const double dxy = std::hypot(front_step.x - wheel_step.x, front_step.y - wheel_step.y);
  const double dth = std::abs(wrap_angle(front_step.theta - wheel_step.theta));
  if (dxy <= txy && dth <= tth) return front_step;
  // Two measurements of one step that disagree beyond the wheels' budget: each weighted by its
  // variance (the match's grown by the disagreement, the wheels' the budget squared).
  auto blend = [](double f, double w, double var_f, double var_w) {
    if (!(var_w > 0.0)) return w;
    return (f * var_w + w * var_f) / (var_f + var_w);
  };
  Pose2 out;
  out.x = blend(front_step.x, wheel_step.x, covariance(0, 0), txy * txy);
  out.y = blend(front_step.y, wheel_step.y, covariance(1, 1), txy * txy);
  out.theta = front_step.theta + blend(0.0, wrap_angle(wheel_step.theta - front_step.theta), covariance(2, 2), tth * tth);
  return out;
}

Matrix6d element_anchor_information(const std::vector<IcpCorrespondence>& pairs, const std::vector<std::int32_t>& labels,
                                    const std::vector<Vector3d>& pivots, const std::vector<Matrix6d>& covariances,
                                    double point_sigma, const Vector3d& c) {
  PLUMB_CHECK(pivots.size() == covariances.size(), "element_anchor_information: " << pivots.size() << " pivots, "
                                                       << covariances.size() << " covariances");
  // Pose rows a = [n; (x - c) x n] of the residuals n.(x - q), and element rows h = [n; (q - p_e) x n]
  // of the same residuals against element e's displacement about its pivot p_e. The least-squares
  // pose then errs by Hp^-1 sum_e B_e eps_e (B_e = sum over e's pairs of a h^T) plus the points'
  // noise: covariance Hp^-1 M Hp^-1 with M = s^2 Hp + sum_e B_e C_e B_e^T, information Hp M^+ Hp.
  std::vector<std::size_t> slot(pivots.size(), SIZE_MAX);
  std::vector<std::size_t> seen;
  std::vector<Matrix6d> B;
  Matrix6d Hp = Matrix6d::Zero();
  for (const IcpCorrespondence& p : pairs) {
    if (p.target_index >= labels.size() || labels[p.target_index] < 0) continue;
    const auto e = static_cast<std::size_t>(labels[p.target_index]);
    if (e >= pivots.size() || !p.n.allFinite() || p.n.squaredNorm() < 0.5) continue;
    Vector6d a, h;
    a << p.n, (p.x - c).cross(p.n);
    h << p.n, (p.q - pivots[e]).cross(p.n);
    Hp.noalias() += a * a.transpose();
    if (slot[e] == SIZE_MAX) {
      slot[e] = seen.size();
      seen.push_back(e);
      B.push_back(Matrix6d::Zero());
    }
    B[slot[e]].noalias() += a * h.transpose();
  }
  Matrix6d M = point_sigma * point_sigma * Hp;
  for (std::size_t k = 0; k < seen.size(); ++k) M.noalias() += B[k] * covariances[seen[k]] * B[k].transpose();
  const Eigen::SelfAdjointEigenSolver<Matrix6d> es(0.5 * (M + M.transpose()));
  const double top = es.eigenvalues().maxCoeff();
  if (!(top > 0.0)) return Matrix6d::Zero();
  Vector6d inv = Vector6d::Zero();
  for (int i = 0; i < 6; ++i) {
    if (es.eigenvalues()(i) > 1e-12 * top) inv(i) = 1.0 / es.eigenvalues()(i);
  }
  const Matrix6d info = Hp * (es.eigenvectors() * inv.asDiagonal() * es.eigenvectors().transpose()) * Hp;
  return 0.5 * (info + info.transpose());
}

BimOdometry::BimOdometry(std::shared_ptr<const PointCloud> bim_cloud, const Eigen::Isometry3d& T_world_base0,
                         const BimOdometrySettings& settings)
    : settings_(settings),
      bim_(std::move(bim_cloud)),
      front_end_([&] {
        ScanOdometrySettings f = settings.front_end;
        f.T_base_laser = Pose2{};  // the scan is cut in the base frame
        return f;
      }()),
      composer_(T_world_base0, settings.initial_covariance, settings.composer),
      T_world_base0_(T_world_base0) {
  PLUMB_CHECK(settings.correct_every >= 1, "BimOdometry: correct_every must be >= 1");
  PLUMB_CHECK(settings.scan_band > 0.0 && settings.scan_angle_increment > 0.0 &&
                  settings.scan_range_max > settings.scan_range_min,
              "BimOdometry: scan band, angle increment and range limits must be positive and ordered");
  PLUMB_CHECK(settings.anchor_sigma > 0.0 && settings.anchor_effective_points > 0.0 &&
                  settings.anchor_length > 0.0 && settings.anchor_rank_threshold >= 0.0,
              "BimOdometry: anchor_sigma, anchor_effective_points and anchor_length must be > 0");
  PLUMB_CHECK(settings.T_base_lidar.matrix().allFinite(), "BimOdometry: T_base_lidar is not finite");
  PLUMB_CHECK(settings.wheel_tolerance_xy >= 0.0 && settings.wheel_tolerance_theta >= 0.0 &&
                  settings.wheel_tolerance_ratio >= 0.0,
              "BimOdometry: wheel_tolerance_xy, wheel_tolerance_theta and wheel_tolerance_ratio must be >= 0");
  PLUMB_CHECK(settings.refresh_threads >= 0,
              "BimOdometry: refresh_threads must be >= 0 (0 = every core), got " << settings.refresh_threads);
  PLUMB_CHECK(settings.use_bim || !settings.estimate_as_built,
              "BimOdometry: estimate_as_built needs use_bim (the as-built is estimated from the BIM registrations)");
  if (settings.use_bim) {
    PLUMB_CHECK(bim_ != nullptr, "BimOdometry: no BIM cloud (set use_bim = false for plain odometry)");
    PLUMB_CHECK(bim_->size() >= 100, "BimOdometry: the BIM cloud has " << bim_->size() << " points (need >= 100)");
    PLUMB_CHECK(bim_->has_normals(), "BimOdometry: the BIM cloud has no normals (sample it from the model's faces)");
    PLUMB_CHECK(settings_.target_band_margin >= 0.0,
                "BimOdometry: target_band_margin must be >= 0, got " << settings_.target_band_margin);
    bim_z_min_ = std::numeric_limits<double>::infinity();
    bim_z_max_ = -bim_z_min_;
    for (const Vector3f& p : bim_->points) {
      if (!p.allFinite()) continue;
      bim_z_min_ = std::min(bim_z_min_, static_cast<double>(p.z()));
      bim_z_max_ = std::max(bim_z_max_, static_cast<double>(p.z()));
    }
    // The design's own target (the whole cloud) does not depend on the frames: made here, once.
    target_ = std::make_unique<Target>();
    target_->whole = true;
    target_->cloud = bim_.get();
    target_->tree = std::make_unique<KdTree3f>(bim_->points);
    if (settings_.estimate_as_built) {
      PLUMB_CHECK(settings_.as_built_refresh_every >= 1, "BimOdometry: as_built_refresh_every must be >= 1");
      as_built_ = std::make_unique<AsBuiltMap>(bim_, settings_.as_built);
    }
    if (settings_.anchor_from_elements && bim_->has_labels()) {
      const AsBuiltSettings& ab = settings_.as_built;
      PLUMB_CHECK(ab.sigma_translation > 0.0 && ab.sigma_rotation > 0.0 && ab.point_sigma > 0.0,
                  "BimOdometry: as_built.sigma_translation, sigma_rotation and point_sigma must be > 0");
      const std::size_t n = element_pivots().size();
      Vector6d prior;
      prior << Vector3d::Constant(ab.sigma_translation * ab.sigma_translation),
          Vector3d::Constant(ab.sigma_rotation * ab.sigma_rotation);
      element_covariance_.assign(n, Matrix6d(prior.asDiagonal()));
    }
  }
}

CloudToScanResult BimOdometry::planar_scan(const PointCloud& lidar_frame, double stamp) const {
  // Liu et al. 2022, sec. 2.1: the planar scan in the base frame, from a band around the LiDAR's height.
  CloudToScanSettings cs;
  const double h = settings_.T_base_lidar.translation().z();
  cs.min_height = h - settings_.scan_band;
  cs.max_height = h + settings_.scan_band;
  cs.angle_increment = settings_.scan_angle_increment;
  cs.range_min = settings_.scan_range_min;
  cs.range_max = settings_.scan_range_max;
  cs.T_target_sensor = settings_.T_base_lidar;
  cs.stamp = stamp;
  return cloud_to_scan(lidar_frame, cs);
}

BimFrameInput BimOdometry::prepare(const PointCloud& lidar_frame, double stamp, std::size_t frame_number) const {
  BimFrameInput in = prepare_scan(lidar_frame, stamp, frame_number);
  add_key_points(in, lidar_frame);
  return in;
}

BimFrameInput BimOdometry::prepare_scan(const PointCloud& lidar_frame, double stamp, std::size_t frame_number) const {
  BimFrameInput in;
  in.stamp = stamp;
  in.frame_number = frame_number;
  const auto t0 = std::chrono::steady_clock::now();
  in.scan = planar_scan(lidar_frame, stamp);
  in.seconds_scan = seconds_since(t0);
  return in;
}

void BimOdometry::add_key_points(BimFrameInput& input, const PointCloud& lidar_frame) const {
  if (!corrects(input.frame_number)) return;
  const auto t0 = std::chrono::steady_clock::now();
  input.key_points = key_points(lidar_frame);
  input.seconds_segment = seconds_since(t0);
}

BimFrameResult BimOdometry::process(const PointCloud& lidar_frame, double stamp, const Pose2& odom_pose) {
  const auto t0 = std::chrono::steady_clock::now();
  BimFrameInput in;
  in.stamp = stamp;
  in.frame_number = frame_index_;
  // The key points depend on the frame alone: with threads, they are found on a second thread while
  // the front end matches the scan (the same points either way).
  std::future<std::pair<PointCloud, double>> keys;
  if (corrects(frame_index_)) {
    keys = start_beside(settings_.threads, [this, &lidar_frame] {
      const auto t = std::chrono::steady_clock::now();
      PointCloud points = key_points(lidar_frame);
      return std::make_pair(std::move(points), seconds_since(t));
    });
  }
  in.scan = planar_scan(lidar_frame, stamp);
  in.seconds_scan = seconds_since(t0);
  const BimFrontStep front = match(in, odom_pose);
  BimFrameResult out = compose(in, front, keys.valid() ? &keys : nullptr);
  out.seconds_total = seconds_since(t0);
  return out;
}

void BimOdometry::front_end(BimFrameInput& input, const Pose2& odom_pose) {
  PLUMB_CHECK(!input.front, "BimOdometry: frame " << input.frame_number << " has been matched already");
  input.front = match(input, odom_pose);
}

BimFrameResult BimOdometry::process(const BimFrameInput& input, const Pose2& odom_pose) {
  PLUMB_CHECK(input.frame_number == frame_index_, "BimOdometry: a frame prepared as frame number "
                                                      << input.frame_number << " given as frame number " << frame_index_);
  PLUMB_CHECK(input.key_points.has_value() || !corrects(frame_index_),
              "BimOdometry: frame " << frame_index_ << " is corrected but was prepared without key points");
  const auto t0 = std::chrono::steady_clock::now();
  const BimFrontStep front = input.front ? *input.front : match(input, odom_pose);
  BimFrameResult out = compose(input, front, nullptr);
  out.seconds_total = seconds_since(t0) + input.seconds_scan + input.seconds_segment + (input.front ? front.seconds : 0.0);
  return out;
}

BimFrontStep BimOdometry::match(const BimFrameInput& input, const Pose2& odom_pose) {
  PLUMB_CHECK(input.frame_number == front_frames_, "BimOdometry: frame number " << input.frame_number
                                                       << " matched after frame " << front_frames_ << " was due");
  const auto t0 = std::chrono::steady_clock::now();
  BimFrontStep front;
  // PLICP against the local map, wheel-odometry prior, fallback to the prior.
  const ScanOdometryStep step = front_end_.add(input.scan.scan, odom_pose);
  front.mode = step.mode;
  if (front_frames_ > 0) {
    const Pose2 rel = last_front_pose_.ominus().oplus(step.T_world_base);
    const bool matched = step.mode == ScanMatchMode::kMatched || step.mode == ScanMatchMode::kDegenerate;
    const Pose2 wheel = last_odom_pose_.ominus().oplus(odom_pose);
    const Matrix3d c = front_end_step_covariance(settings_, rel, wheel, matched, step.match.covariance);
    front.has_motion = true;
    front.motion = front_end_step(settings_, rel, wheel, matched, c).to_isometry();
    front.motion_covariance = planar_covariance(c, 1e-8, 1e-8);
  }
  last_front_pose_ = step.T_world_base;
  last_odom_pose_ = odom_pose;
  // The uncorrected chain: the front end's motion since the first frame, from the initial pose.
  if (front_frames_ == 0) first_front_pose_ = step.T_world_base;
  front.T_world_base_uncorrected =
      T_world_base0_ * first_front_pose_.ominus().oplus(step.T_world_base).to_isometry();
  ++front_frames_;
  front.seconds = seconds_since(t0);
  return front;
}

BimFrameResult BimOdometry::compose(const BimFrameInput& input, const BimFrontStep& front,
                                    std::future<std::pair<PointCloud, double>>* keys_beside) {
  BimFrameResult out;
  out.stamp = input.stamp;
  out.scan_status = input.scan.status;
  out.mode = front.mode;
  if (front.has_motion) composer_.add_motion(front.motion, front.motion_covariance);
  out.seconds_front_end = input.seconds_scan + front.seconds;
  out.T_world_base_uncorrected = front.T_world_base_uncorrected;

  if (corrects(frame_index_)) {
    if (keys_beside != nullptr) {
      auto [points, seconds] = keys_beside->get();
      out.num_key_points = points.size();
      out.seconds_segment = seconds;
      correct(points, out);
    } else {
      out.num_key_points = input.key_points->size();
      out.seconds_segment = input.seconds_segment;
      correct(*input.key_points, out);
    }
  }
  out.T_world_base = composer_.pose();
  ++frame_index_;
  return out;
}

PointCloud BimOdometry::key_points(const PointCloud& lidar_frame) const {
  // Liu et al. 2022, sec. 2.2: ground and vertical-plane key points of the frame.
  const SegmentResult seg = segment_frame(lidar_frame, settings_.segment);
  PointCloud keys;
  for (std::size_t i = 0; i < seg.labels.size(); ++i) {
    if (seg.labels[i] == kSegmentGround || seg.labels[i] == kSegmentVertical) keys.points.push_back(lidar_frame.points[i]);
  }
  if (settings_.key_point_voxel > 0.0 && keys.size() > 0) {
    VoxelGridSettings vs;
    vs.leaf_size = settings_.key_point_voxel;
    keys = voxel_grid(keys, vs).cloud;
  }
  return keys;
}

void BimOdometry::correct(const PointCloud& keys, BimFrameResult& out) {
  if (keys.size() < settings_.min_anchor_inliers) return;

  // Liu et al. 2022, sec. 3.3, loop step (5): key points at the composed pose, registered to the BIM cloud.
  const auto t1 = std::chrono::steady_clock::now();
  out.anchor_attempted = true;
  const Eigen::Isometry3d T_pred = composer_.pose() * settings_.T_base_lidar;
  IcpSettings icp_settings = settings_.icp;
  icp_settings.keep_correspondences = as_built_ != nullptr || !element_covariance_.empty();
  icp_settings.threads = settings_.threads;
  const Target& target = registration_target(keys, T_pred);
  out.target_points = target.cloud->size();
  IcpResult icp = align_icp(keys, *target.cloud, *target.tree, T_pred, icp_settings);
  if (!target.index.empty()) {
    for (IcpCorrespondence& pair : icp.correspondences) pair.target_index = target.index[pair.target_index];
  }
  out.icp_status = icp.status;
  out.icp_overlap = icp.overlap;
  out.icp_inliers = icp.num_inliers;
  out.seconds_icp = seconds_since(t1);
  if (icp.status != Status::kOk && icp.status != Status::kNotConverged) return;
  if (icp.overlap < settings_.min_anchor_overlap || icp.num_inliers < settings_.min_anchor_inliers) return;
  out.registered = true;
  out.T_world_base_registered = icp.T_target_source * settings_.T_base_lidar.inverse();

  // Information of the result about the robot's position c (so the rank test compares like with
  // like), ordered translation then rotation, then moved to the world-origin left perturbation:
  // from the elements the pairs lie on, or ICP's normal matrix at its final correspondences, scaled,
  // its rotation moved from the pairs' centroid m to c (a motion (w, v_c) about c is
  // (w, v_c + w x (m - c)) about m).
  const Eigen::Isometry3d& T = icp.T_target_source;
  const Vector3d c = (T * settings_.T_base_lidar.inverse()).translation();
  const std::size_t n = icp.num_inliers;
  if (n < settings_.min_anchor_inliers) return;
  Matrix6d H;
  if (!element_covariance_.empty()) {
    H = element_anchor_information(icp.correspondences, bim_->labels, element_pivot_, element_covariance_,
                                   settings_.as_built.point_sigma, c);
  } else {
    Matrix6d A = Matrix6d::Zero();  // [w; v_m] = A [v_c; w]
    A.block<3, 3>(0, 3) = Matrix3d::Identity();
    A.block<3, 3>(3, 0) = Matrix3d::Identity();
    A.block<3, 3>(3, 3) = -hat(icp.normal_matrix_pivot - c);
    H = A.transpose() * icp.normal_matrix * A;
    const double scale = std::min(1.0, settings_.anchor_effective_points / static_cast<double>(n)) /
                         (settings_.anchor_sigma * settings_.anchor_sigma);
    H *= scale;
  }
  // Drop directions the key points barely constrain (corridor axis, a single plane...).
  Vector6d D;
  D << 1, 1, 1, settings_.anchor_length, settings_.anchor_length, settings_.anchor_length;
  const Matrix6d Dm = D.asDiagonal().inverse();
  const Eigen::SelfAdjointEigenSolver<Matrix6d> es(Dm * H * Dm);
  Vector6d ev = es.eigenvalues();
  const double largest = ev(5);
  if (!(largest > 0.0)) return;
  for (int i = 0; i < 6; ++i) {
    if (ev(i) < settings_.anchor_rank_threshold * largest) {
      ev(i) = 0.0;
    } else {
      ++out.anchor_dof;
    }
  }
  const Matrix6d H_kept = D.asDiagonal() * (es.eigenvectors() * ev.asDiagonal() * es.eigenvectors().transpose()) *
                          D.asDiagonal();
  Eigen::Isometry3d T_c = Eigen::Isometry3d::Identity();
  T_c.translation() = c;
  const Matrix6d info_world = body_to_world_information(T_c, 0.5 * (H_kept + H_kept.transpose()));
  out.anchor = composer_.add_anchor(out.T_world_base_registered, info_world);
  if (as_built_ != nullptr && out.anchor.decision == AnchorDecision::kAccepted) update_as_built(icp, c, out);
}

void BimOdometry::register_to(const AsBuiltMap& map) {
  PLUMB_CHECK(settings_.use_bim, "BimOdometry::register_to: the odometry does not use the BIM (use_bim = false)");
  PLUMB_CHECK(!settings_.estimate_as_built,
              "BimOdometry::register_to: the odometry estimates the as-built itself (estimate_as_built), which "
              "would replace the target");
  const PointCloud& design = map.design();
  PLUMB_CHECK(&design == bim_.get() || (design.size() == bim_->size() && design.labels == bim_->labels),
              "BimOdometry::register_to: the as-built map was made from another BIM cloud ("
                  << design.size() << " points, the odometry's " << bim_->size() << ", or other element labels)");
  displace_target(map.mean());
  take_element_covariances(map);
}

const BimOdometry::Target& BimOdometry::registration_target(const PointCloud& keys, const Eigen::Isometry3d& T) {
  const IcpSettings& icp = settings_.icp;
  double z_min = std::numeric_limits<double>::infinity(), z_max = -z_min;
  for (const Vector3f& p : keys.points) {
    if (!p.allFinite()) continue;
    const double z = (T * p.cast<double>()).z();
    z_min = std::min(z_min, z);
    z_max = std::max(z_max, z);
  }
  const double reach = 2.0 * std::max(icp.max_correspondence_distance, icp.overlap_distance) + kTargetMotion;
  z_min -= reach;
  z_max += reach;
  if (target_ != nullptr && (target_->whole || (target_->z_min <= z_min && z_max <= target_->z_max))) return *target_;

  std::unique_ptr<Target> target = std::move(retired_);
  // A displacement moves the points by centimetres: when the key points lie in the retired
  // target's band, its points are moved and its tree refitted, with no partition or sort.
  const bool refit = target_mean_.size() != 0 && target != nullptr && target->tree != nullptr &&
                     (target->whole || (target->z_min <= z_min && z_max <= target->z_max));
  if (target == nullptr) target = std::make_unique<Target>();
  if (!refit) {
    target->z_min = z_min - settings_.target_band_margin;
    target->z_max = z_max + settings_.target_band_margin;
    // The design's tree is built once and serves every height; a displaced target is cut to the band.
    target->whole = target_mean_.size() == 0 || (!(target->z_min > bim_z_min_) && !(target->z_max < bim_z_max_));
    target->index.clear();
    if (!target->whole) {
      const auto lo = static_cast<float>(target->z_min), hi = static_cast<float>(target->z_max);
      target->index.reserve(bim_->size());
      for (std::size_t i = 0; i < bim_->size(); ++i) {
        const float z = bim_->points[i].z();
        if (z >= lo && z <= hi) target->index.push_back(static_cast<std::uint32_t>(i));
      }
      // Key points where the model has nothing: the whole model, to fail as it would.
      target->whole = target->index.empty();
    }
  }
  if (target_mean_.size() == 0) {
    target->displaced = PointCloud{};
    target->cloud = bim_.get();
  } else {
    // A tall model's band is millions of points: moved, and its tree refitted, on refresh_threads.
    if (target->whole) {
      displaced_points(*bim_, target_mean_, element_pivots(), target->displaced, settings_.refresh_threads);
    } else {
      displaced_points(*bim_, target->index, target_mean_, element_pivots(), target->displaced,
                       settings_.refresh_threads);
    }
    target->cloud = &target->displaced;
  }
  if (refit) {
    target->tree->refit(target->cloud->points, settings_.refresh_threads);
  } else if (target->tree != nullptr) {
    target->tree->rebuild(target->cloud->points);
  } else {
    target->tree = std::make_unique<KdTree3f>(target->cloud->points);
  }
  target_ = std::move(target);
  return *target_;
}

const std::vector<Vector3d>& BimOdometry::element_pivots() {
  if (element_pivot_.empty()) element_pivot_ = element_centroids(*bim_);
  return element_pivot_;
}

void BimOdometry::displace_target(Eigen::VectorXd mean) {
  target_mean_ = std::move(mean);
  if (target_ != nullptr && target_->cloud == &target_->displaced) retired_ = std::move(target_);
  target_.reset();
}

void BimOdometry::take_element_covariances(const AsBuiltMap& map) {
  for (std::size_t e = 0; e < element_covariance_.size() && e < map.num_elements(); ++e) {
    // The marginal covariance is a solve over every element: only the observed ones need it.
    if (!map.has_points(e) || map.frames(e) == 0) continue;
    element_covariance_[e] = map.element(e).covariance;
  }
}

void BimOdometry::update_as_built(const IcpResult& icp, const Vector3d& robot_position, BimFrameResult& out) {
  out.as_built_pairs = as_built_->observe(icp.correspondences, robot_position);
  if (++anchors_since_refresh_ < settings_.as_built_refresh_every) return;
  anchors_since_refresh_ = 0;
  displace_target(as_built_->mean());
  // The target's elements now err by the estimate's uncertainty, not by the construction tolerance.
  take_element_covariances(*as_built_);
}

}  // namespace plumb
