// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/pipeline/hybrid_lio.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <optional>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

#include "plumb/core/error.hpp"
#include "plumb/core/levenberg_marquardt.hpp"
#include "plumb/core/lie.hpp"
#include "plumb/loam/ground.hpp"
#include "plumb/loam/odometry.hpp"
#include "plumb/core/parallel.hpp"
#include "plumb/search/kdtree.hpp"

#include "lio_problem.hpp"

namespace plumb {
namespace {

using lio_detail::JointProblem;
using lio_detail::Matrix30d;
using lio_detail::Vector30d;
using lio_detail::pose_of;

void check_map_settings(const VoxelHashMapSettings& m, const char* name) {
  PLUMB_CHECK(std::isfinite(m.voxel_size) && m.voxel_size > 0.0 && m.max_points_per_voxel >= 1 &&
                  m.max_distance > 0.0 && m.max_voxels >= 1,
              "HybridLio: settings." << name << " needs voxel_size > 0, max_points_per_voxel >= 1, max_distance > 0");
}

}  // namespace

LioMode lio_mode_from_string(const std::string& name) {
  if (name == "loam") return LioMode::kLoam;
  if (name == "loam-imu") return LioMode::kLoamImu;
  if (name == "hybrid") return LioMode::kHybrid;
  PLUMB_THROW("unknown LIO mode '" << name << "' (known: loam, loam-imu, hybrid)");
}

const char* to_string(LioMode mode) {
  switch (mode) {
    case LioMode::kLoam: return "loam";
    case LioMode::kLoamImu: return "loam-imu";
    case LioMode::kHybrid: return "hybrid";
  }
  return "unknown";
}

const char* to_string(IcpMetric metric) {
  return metric == IcpMetric::kPointToDistribution ? "point-to-distribution" : "point-to-point";
}

IcpMetric icp_metric_from_string(const std::string& name) {
  if (name == "point-to-point") return IcpMetric::kPointToPoint;
  if (name == "point-to-distribution") return IcpMetric::kPointToDistribution;
  PLUMB_THROW("unknown ICP metric '" << name << "' (known: point-to-point, point-to-distribution)");
}

const char* to_string(LioFrameMode mode) {
  switch (mode) {
    case LioFrameMode::kInit: return "init";
    case LioFrameMode::kLoam: return "loam";
    case LioFrameMode::kIcp: return "icp";
    case LioFrameMode::kPrediction: return "prediction";
    case LioFrameMode::kSkipped: return "skipped";
  }
  return "unknown";
}

HybridLio::HybridLio(const Eigen::Isometry3d& T_world_base0, const HybridLioSettings& s)
    : settings_(s), edge_map_(s.map.edge_map), plane_map_(s.map.plane_map), point_map_(s.map.point_map) {
  PLUMB_CHECK(T_world_base0.matrix().allFinite(), "HybridLio: the initial pose is not finite");
  PLUMB_CHECK(s.T_base_lidar.matrix().allFinite() && s.T_base_imu.matrix().allFinite(),
              "HybridLio: settings.T_base_lidar / T_base_imu are not finite");
  PLUMB_CHECK(s.threads >= 0, "HybridLio: settings.threads must be >= 0 (0 = every core), got " << s.threads);
  const LioSolverSettings& so = s.solver;
  PLUMB_CHECK(so.max_iterations >= 1,
              "HybridLio: settings.solver.max_iterations must be >= 1, got " << so.max_iterations);
  PLUMB_CHECK(so.max_correspondence_distance > 0.0 && std::isfinite(so.max_correspondence_distance),
              "HybridLio: settings.solver.max_correspondence_distance must be > 0");
  PLUMB_CHECK(so.map_neighbors >= 3 && so.map_neighbors <= 64,
              "HybridLio: settings.solver.map_neighbors must be in [3, 64], got " << so.map_neighbors);
  PLUMB_CHECK(std::isfinite(so.map_plane_tolerance) && so.map_plane_tolerance > 0.0,
              "HybridLio: settings.solver.map_plane_tolerance must be > 0 [m], got " << so.map_plane_tolerance);
  PLUMB_CHECK(so.map_edge_ratio >= 1.0 && so.map_plane_ratio >= 1.0,
              "HybridLio: settings.solver.map_edge_ratio / map_plane_ratio must be >= 1 (eigenvalue ratios)");
  PLUMB_CHECK(so.plane_sigma > 0.0 && so.edge_sigma > 0.0 && so.point_sigma > 0.0 && so.huber_scale > 0.0,
              "HybridLio: settings.solver.plane_sigma / edge_sigma / point_sigma / huber_scale must be > 0");
  PLUMB_CHECK(so.icp_neighbors >= 3 && so.icp_neighbors <= 64,
              "HybridLio: settings.solver.icp_neighbors must be in [3, 64], got " << so.icp_neighbors);
  PLUMB_CHECK(so.min_correspondences >= 6, "HybridLio: settings.solver.min_correspondences must be >= 6");
  const LioMapSettings& m = s.map;
  PLUMB_CHECK(m.icp_voxel_size > 0.0 && m.plane_query_voxel > 0.0 && m.ground_query_voxel > 0.0,
              "HybridLio: settings.map.icp_voxel_size / plane_query_voxel / ground_query_voxel must be > 0");
  PLUMB_CHECK(m.map_rebuild_distance >= 0.0 && m.map_rebuild_frames >= 1,
              "HybridLio: settings.map.map_rebuild_distance must be >= 0 and map_rebuild_frames >= 1");
  const LioImuSettings& imu = s.imu;
  PLUMB_CHECK(imu.gravity > 0.0 && std::isfinite(imu.gravity), "HybridLio: settings.imu.gravity must be > 0");
  PLUMB_CHECK(imu.max_imu_gap > 0.0, "HybridLio: settings.imu.max_imu_gap must be > 0");
  PLUMB_CHECK(imu.initial_velocity_sigma > 0.0 && imu.initial_gyro_bias_sigma > 0.0 &&
                  imu.initial_accel_bias_sigma > 0.0,
              "HybridLio: settings.imu.initial_*_sigma must be > 0");
  PLUMB_CHECK(s.motion.twist_frames >= 1, "HybridLio: settings.motion.twist_frames must be >= 1");
  const LioFeatureSettings& fe = s.features;
  PLUMB_CHECK(std::isfinite(fe.ground_plane_tolerance) && fe.ground_plane_tolerance >= 0.0,
              "HybridLio: settings.features.ground_plane_tolerance must be >= 0 [m], got "
                  << fe.ground_plane_tolerance);
  PLUMB_CHECK(fe.ground_max_slope_deg >= 0.0 && fe.ground_max_slope_deg < 90.0,
              "HybridLio: settings.features.ground_max_slope_deg must be in [0, 90)");
  check_map_settings(m.edge_map, "map.edge_map");
  check_map_settings(m.plane_map, "map.plane_map");
  check_map_settings(m.point_map, "map.point_map");
  T_imu_lidar_ = s.T_base_imu.inverse() * s.T_base_lidar;
  const Eigen::Isometry3d T_world_imu = T_world_base0 * s.T_base_imu;
  state_.R_world_body = T_world_imu.linear();
  state_.p_world_body = T_world_imu.translation();
  reset_prior();
}

void HybridLio::reset_prior() {
  const HybridLioSettings& s = settings_;
  Vector15d sigma;
  sigma << Vector3d::Constant(1e-3), Vector3d::Constant(1e-2), Vector3d::Constant(s.imu.initial_velocity_sigma),
      Vector3d::Constant(s.imu.initial_gyro_bias_sigma), Vector3d::Constant(s.imu.initial_accel_bias_sigma);
  prior_information_ = sigma.cwiseInverse().cwiseAbs2().asDiagonal();
}

Eigen::Isometry3d HybridLio::T_world_base() const { return pose_of(state_) * settings_.T_base_imu.inverse(); }

Status HybridLio::add_imu(const ImuSample& sample) {
  if (!std::isfinite(sample.stamp) || !sample.gyro.allFinite() || !sample.accel.allFinite() ||
      !(sample.stamp > last_imu_stamp_)) {
    ++num_imu_dropped_;
    return Status::kInvalidInput;
  }
  imu_.push_back(sample);
  last_imu_stamp_ = sample.stamp;
  return Status::kOk;
}

bool HybridLio::imu_covers(double t0, double t1) const {
  if (imu_.empty()) return false;
  auto it = std::upper_bound(imu_.begin(), imu_.end(), t0, [](double t, const ImuSample& s) { return t < s.stamp; });
  std::size_t a = static_cast<std::size_t>(it - imu_.begin());
  if (a == 0) {
    if (imu_.front().stamp - t0 > settings_.imu.max_imu_gap) return false;
  } else {
    --a;
    if (t0 - imu_[a].stamp > settings_.imu.max_imu_gap) return false;
  }
  for (std::size_t k = a; k + 1 < imu_.size() && imu_[k].stamp < t1; ++k) {
    if (imu_[k + 1].stamp - imu_[k].stamp > settings_.imu.max_imu_gap) return false;
  }
  return t1 - imu_.back().stamp <= settings_.imu.max_imu_gap;
}

void HybridLio::remember_pose(double stamp) {
  recent_poses_.emplace_back(stamp, pose_of(state_));
  while (recent_poses_.size() > settings_.motion.twist_frames + 1) recent_poses_.pop_front();
  const auto& [t0, T0] = recent_poses_.front();
  twist_ = recent_poses_.size() < 2 ? Vector6d::Zero() : Vector6d(se3::log(T0.inverse() * pose_of(state_)) / (stamp - t0));
}

void HybridLio::deskew(PointCloud& cloud, double stamp, const ImuState& x, bool use_imu, LioFrameResult& res) const {
  if (!settings_.motion.deskew || !cloud.has_times()) return;
  double t_max = 0.0;
  for (float t : cloud.times) {
    if (std::isfinite(t) && t > t_max) t_max = t;
  }
  t_max = std::min(t_max, 1.0);
  if (!(t_max > 0.0)) return;
  // Knots: times since the stamp and poses of the IMU at that time in the IMU frame at the stamp.
  std::vector<double> kt{0.0};
  std::vector<Matrix3d> kR{Matrix3d::Identity()};
  std::vector<Vector3d> kp{Vector3d::Zero()};
  if (use_imu && imu_covers(stamp, stamp + t_max)) {
    const Vector3d g(0.0, 0.0, -settings_.imu.gravity);
    Matrix3d R = x.R_world_body;
    Vector3d p = x.p_world_body, v = x.v_world;
    const Matrix3d R0t = R.transpose();
    const Vector3d p0 = p;
    auto it = std::upper_bound(imu_.begin(), imu_.end(), stamp, [](double t, const ImuSample& s) { return t < s.stamp; });
    std::size_t k = it == imu_.begin() ? 0 : static_cast<std::size_t>(it - imu_.begin()) - 1;
    double t = stamp;
    const double t_end = stamp + t_max;
    while (t < t_end) {
      const double t_next = std::min(k + 1 < imu_.size() ? imu_[k + 1].stamp : t_end, t_end);
      const double dt = t_next - t;
      if (dt > 0.0) {
        const Vector3d w = imu_[k].gyro - x.bias.gyro;
        const Vector3d a = R * (imu_[k].accel - x.bias.accel) + g;
        p += v * dt + 0.5 * a * dt * dt;
        v += a * dt;
        R = R * so3::exp(w * dt);
        t = t_next;
        kt.push_back(t - stamp);
        kR.push_back(R0t * R);
        kp.push_back(R0t * (p - p0));
      }
      if (k + 1 < imu_.size() && imu_[k + 1].stamp <= t) ++k;
      else if (dt <= 0.0) break;
    }
    res.deskewed_with_imu = true;
  } else {
    // Constant velocity: the mean body twist of the last few intervals (see twist_frames).
    const int n = std::max(2, static_cast<int>(std::ceil(t_max / 0.005)));
    for (int i = 1; i <= n; ++i) {
      const double t = t_max * i / n;
      const Eigen::Isometry3d T = se3::exp(twist_ * t);
      kt.push_back(t);
      kR.push_back(T.linear());
      kp.push_back(T.translation());
    }
  }
  const Eigen::Isometry3d T_lidar_imu = T_imu_lidar_.inverse();
  float last = std::numeric_limits<float>::quiet_NaN();
  Eigen::Matrix3f Rf = Eigen::Matrix3f::Identity();
  Eigen::Vector3f tf = Eigen::Vector3f::Zero();
  for (std::size_t i = 0; i < cloud.points.size(); ++i) {
    const float ti = cloud.times[i];
    if (!std::isfinite(ti)) continue;
    if (ti != last) {
      const double t = std::clamp(static_cast<double>(ti), 0.0, t_max);
      std::size_t j = static_cast<std::size_t>(std::upper_bound(kt.begin(), kt.end(), t) - kt.begin());
      j = std::clamp<std::size_t>(j, 1, kt.size() - 1);
      const double span = kt[j] - kt[j - 1];
      const double f = span > 0.0 ? std::clamp((t - kt[j - 1]) / span, 0.0, 1.0) : 1.0;
      const Matrix3d Ri = kR[j - 1] * so3::exp(f * so3::log(kR[j - 1].transpose() * kR[j]));
      const Vector3d pi = (1.0 - f) * kp[j - 1] + f * kp[j];
      const Eigen::Isometry3d T = T_lidar_imu * se3::make(Ri, pi) * T_imu_lidar_;
      Rf = T.linear().cast<float>();
      tf = T.translation().cast<float>();
      last = ti;
    }
    cloud.points[i] = Rf * cloud.points[i] + tf;
  }
  res.deskewed = true;
}

void HybridLio::settle_maps() const {
  if (map_update_.valid()) map_update_.get();
}

void HybridLio::update_maps(const LoamFeatures& f, const PointCloud& cloud, const Eigen::Isometry3d& T_world_lidar) {
  const Eigen::Matrix3f R = T_world_lidar.linear().cast<float>();
  const Eigen::Vector3f t = T_world_lidar.translation().cast<float>();
  auto world = [&](std::vector<Vector3f> pts) {
    for (Vector3f& p : pts) p = R * p + t;
    return pts;
  };
  if (!f.edge_pool.empty()) {
    edge_map_.insert(world(f.edge_pool.points));
  } else {
    edge_map_.insert(world(f.edges.points));
    edge_map_.insert(world(f.edge_candidates.points));
  }
  if (!f.plane_pool.empty()) {
    plane_map_.insert(world(f.plane_pool.points));
  } else {
    plane_map_.insert(world(f.planes.points));
    plane_map_.insert(world(f.plane_candidates.points));
  }
  point_map_.insert(world(cloud.points));
  const Vector3d c = T_world_lidar.translation();
  edge_map_.prune(c);
  plane_map_.prune(c);
  point_map_.prune(c);
}

// ---- process() and its stages ---------------------------------------------------------------------

struct HybridLio::Frame {
  std::chrono::steady_clock::time_point start;
  double stamp = 0.0;
  double dt = 0.0;  ///< since the last frame [s]
  LioFrameResult res;
  // predict()
  std::optional<ImuPreintegration> pim;
  ImuState pred;
  // extract()
  PointCloud cloud;           ///< deskewed frame
  LoamFeatures feats;         ///< LOAM features (edges off the ground; dense plane queries if set)
  LoamFeatures ground_feats;  ///< ground plane queries
  PointCloud icp_points;      ///< ICP queries: off the ground, one point per voxel
  // associate() / solve()
  Vector3d here = Vector3d::Zero();  ///< predicted LiDAR position, for the search structures' staleness
  LioFrameMode lidar_mode = LioFrameMode::kLoam;
  bool tried_icp = false;
  bool lidar_ok = true;
  bool converged = false;
  std::size_t num_matched = 0;
  std::vector<LoamCorrespondence> corr;
  LoamMapCache map_cache;       ///< the LOAM map neighbours of the earlier rounds
  std::vector<Vector3d> s_imu;  ///< corr[k].p in the IMU frame
  ImuState xi, xj;              ///< the previous and the current state being solved for
};

namespace {

LoamSettings map_association_settings(const HybridLioSettings& set) {
  LoamSettings ls;
  ls.max_correspondence_distance = set.solver.max_correspondence_distance;
  ls.map_neighbors = set.solver.map_neighbors;
  ls.map_plane_tolerance = set.solver.map_plane_tolerance;
  ls.map_edge_ratio = set.solver.map_edge_ratio;
  ls.map_plane_ratio = set.solver.map_plane_ratio;
  ls.threads = set.threads;
  return ls;
}

std::vector<Vector3f> voxel_downsample(const std::vector<Vector3f>& pts, double voxel) {
  VoxelHashMap ds({voxel, 1, 1e12, std::numeric_limits<std::size_t>::max()});
  ds.insert(pts);
  return ds.points();
}

}  // namespace

LioFrameResult HybridLio::process(const PointCloud& frame_lidar, double stamp) {
  Frame f;
  f.start = std::chrono::steady_clock::now();
  frame_lidar.check_consistent("HybridLio::process");
  f.stamp = stamp;
  f.res.stamp = stamp;
  f.res.num_points = frame_lidar.size();
  if (!std::isfinite(stamp) || (initialized_ && !(stamp > last_stamp_))) {
    f.res.mode = LioFrameMode::kSkipped;
    f.res.status = Status::kInvalidInput;
    return finish(f);
  }
  f.dt = initialized_ ? stamp - last_stamp_ : 0.0;
  predict(f);
  extract(f, frame_lidar);
  if (!initialized_ && f.cloud.size() < settings_.features.min_init_points) {
    f.res.mode = LioFrameMode::kSkipped;
    f.res.status = Status::kInsufficientData;
    return finish(f);
  }
  if (!initialized_) {
    initialized_ = true;
    last_stamp_ = stamp;
    remember_pose(stamp);
    ++num_frames_;
    f.res.mode = LioFrameMode::kInit;
    f.res.status = f.feats.status;
    update_maps(f.feats, f.icp_points, pose_of(state_) * T_imu_lidar_);
    return finish(f);
  }
  solve(f);
  conclude(f);
  return finish(f);
}

LioFrameResult HybridLio::finish(Frame& f) const {
  f.res.T_world_base = T_world_base();
  f.res.v_world = state_.v_world;
  f.res.bias = state_.bias;
  f.res.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - f.start).count();
  return f.res;
}

void HybridLio::predict(Frame& f) const {
  const HybridLioSettings& set = settings_;
  PreintegrationSettings pis;
  pis.noise = set.imu.noise;
  pis.g_world = Vector3d(0.0, 0.0, -set.imu.gravity);
  pis.max_gap = set.imu.max_imu_gap;
  f.pred = state_;
  if (initialized_) {
    if (set.mode != LioMode::kLoam) {
      f.pim.emplace(state_.bias, pis);
      if (f.pim->integrate(imu_, last_stamp_, f.stamp) == Status::kOk && f.pim->num_measurements() > 0) {
        f.pred = f.pim->predict(state_);
      } else {
        f.pim.reset();
        f.res.imu_gap = true;
      }
    }
    if (!f.pim) {
      const Eigen::Isometry3d T = pose_of(state_) * se3::exp(twist_ * f.dt);
      f.pred.R_world_body = T.linear();
      f.pred.p_world_body = T.translation();
    }
  }
  f.res.imu_used = f.pim.has_value();
}

void HybridLio::extract(Frame& f, const PointCloud& frame_lidar) const {
  const HybridLioSettings& set = settings_;
  LioFrameResult& res = f.res;
  // Deskew to the stamp, then range image and cosine features (Zhou et al. 2021, sec. 1.1-1.2).
  f.cloud = frame_lidar;
  const PointCloud& cloud = f.cloud;
  if (set.mode != LioMode::kLoam) deskew(f.cloud, f.stamp, f.pred, f.pim.has_value() || !initialized_, res);
  // The image is built on the deskewed points, so near the sensor a ring loses the points whose
  // azimuth moved into a neighbour's column. Building it from the frame as fired (LOAM's order)
  // keeps the rings whole, but made both simulated site runs drift more (hybrid mode, end error:
  // FZK-Haus 0.71 m against 0.009 m, duplex ~8 m against 3.7 m). The cause is open.
  const RangeImage image = build_range_image(cloud, set.features.image);
  LoamFeatures& feats = f.feats;
  feats = extract_loam_features(cloud, image, set.features.loam);
  res.num_plane_points = feats.planes.size();
  res.num_edge_points = feats.edges.size();
  res.num_plane_interval = feats.num_plane_interval;
  res.num_edge_interval = feats.num_edge_interval;

  // Ground (LeGO-LOAM's pair test, completed by a plane): the road.
  RingGroundSettings gs;
  gs.max_slope_deg = set.features.ground_max_slope_deg;
  gs.plane_tolerance = set.features.ground_plane_tolerance;
  const RingGroundResult ground_result = classify_ground(cloud, image, f.pred.R_world_body * T_imu_lidar_.linear(), gs);
  const std::vector<char>& ground = ground_result.ground;
  res.num_ground = ground_result.num_ground;
  res.num_ground_added = ground_result.num_from_plane;
  for (std::size_t i : feats.plane_indices) res.num_structure_planes += ground[i] ? 0 : 1;
  // Edges only off the ground (LeGO-LOAM): on the road, range noise makes "corners" along a ring,
  // and lines fitted to them run along the ring circles, which pulls every frame onto the last.
  auto off_ground = [&](const std::vector<std::size_t>& idx) {
    PointCloud out;
    for (std::size_t i : idx) {
      if (!ground[i]) out.points.push_back(cloud.points[i]);
    }
    return out;
  };
  feats.edges = off_ground(feats.edge_indices);
  feats.edge_candidates = off_ground(feats.edge_candidate_indices);
  feats.edge_pool.clear();
  res.num_edge_points = feats.edges.size();

  std::vector<Vector3f> off, on;
  off.reserve(cloud.size());
  on.reserve(cloud.size());
  for (std::size_t i = 0; i < cloud.size(); ++i) (ground[i] ? on : off).push_back(cloud.points[i]);
  // ICP queries, off the ground only: nearest-point pairs on the rings of a flat road pull the
  // frame back onto the last one (the rings barely move with the sensor); height, roll and pitch
  // come from the IMU and the previous state.
  f.icp_points.points = voxel_downsample(off, set.map.icp_voxel_size);
  // Scan-to-map plane queries (LOAM's mapping step matches every "less flat" point, not only the
  // few selected per sector, which on an open site are nearly all on the road): the structure
  // off the ground on a fine grid, the ground on a coarse one (it only fixes height, roll, pitch).
  // The map association keeps only neighbourhoods that fit a plane.
  // Ground queries on their own as well: ICP frames match them point-to-plane against the plane
  // map (LeGO-LOAM's ground step: height, roll and pitch from the road in every mode).
  f.ground_feats.planes.points = voxel_downsample(on, set.map.ground_query_voxel);
  if (set.map.dense_plane_queries) {
    feats.planes.points = voxel_downsample(off, set.map.plane_query_voxel);
    const std::vector<Vector3f>& g = f.ground_feats.planes.points;
    feats.planes.points.insert(feats.planes.points.end(), g.begin(), g.end());
    feats.plane_candidates.points.clear();
    feats.plane_pool = feats.planes;
  }
}

std::size_t HybridLio::associate(Frame& f, LioFrameMode m, const ImuState& x,
                                 std::vector<LoamCorrespondence>& corr) {
  const HybridLioSettings& set = settings_;
  auto stale = [&](const Vector3d& at, std::size_t frame) {
    return (f.here - at).norm() > set.map.map_rebuild_distance ||
           num_frames_ - frame >= static_cast<std::size_t>(set.map.map_rebuild_frames);
  };
  corr.clear();
  settle_maps();
  const LoamSettings ls = map_association_settings(set);
  const Eigen::Isometry3d T_world_lidar = pose_of(x) * T_imu_lidar_;
  const bool loam_in_icp = set.solver.icp_keep_loam || set.solver.icp_ground_planes;
  if (m == LioFrameMode::kLoam || loam_in_icp) {
    if (!loam_tree_ || stale(loam_built_at_, loam_built_frame_)) {
      PointCloud e, p;
      e.points = edge_map_.points();
      p.points = plane_map_.points();
      loam_tree_.emplace(std::move(e), std::move(p));
      f.map_cache.clear();
      loam_built_at_ = f.here;
      loam_built_frame_ = num_frames_;
    }
  }
  if (m == LioFrameMode::kLoam) {
    loam_associate_map(*loam_tree_, f.feats, T_world_lidar, ls, corr, &f.map_cache);
    return corr.size();
  }
  if (!point_tree_ || stale(point_built_at_, point_built_frame_)) {
    point_tree_.reset();
    point_cloud_.points = point_map_.points();
    point_tree_.emplace(point_cloud_);
    point_built_at_ = f.here;
    point_built_frame_ = num_frames_;
  }
  std::size_t matched = 0;
  if (set.solver.icp_metric == IcpMetric::kPointToDistribution) {
    // An ICP pair to a distribution is three correspondences.
    matched = lio_detail::associate_distributions(point_cloud_, *point_tree_, f.icp_points, T_world_lidar, set, corr);
  } else {
    loam_associate_points(point_cloud_, *point_tree_, f.icp_points, T_world_lidar,
                          set.solver.max_correspondence_distance,
                          corr);
    matched = corr.size();
  }
  // Too few ICP pairs is what makes the frame fall back to the prediction; ground planes alone
  // do not count (they fix neither x, y nor yaw).
  if (loam_in_icp && matched >= set.solver.min_correspondences) {
    const std::size_t before = corr.size();
    loam_associate_map(*loam_tree_, set.solver.icp_keep_loam ? f.feats : f.ground_feats, T_world_lidar, ls, corr,
                       &f.map_cache);
    matched += corr.size() - before;
  }
  return matched;
}

void HybridLio::associate_round(Frame& f, int iteration) {
  const HybridLioSettings& set = settings_;
  std::size_t matched = associate(f, f.lidar_mode, f.xj, f.corr);
  if (iteration == 0 && set.mode == LioMode::kHybrid && set.features.switch_on_plane_matches) {
    // The switch on what LOAM would use: plane residuals whose map plane is not flat (walls,
    // roofs, not the road), the ones that fix x, y and yaw.
    const double cos_flat = std::cos(set.features.ground_max_slope_deg * kPi / 180.0);
    for (const LoamCorrespondence& c : f.corr) {
      if (c.kind == LoamCorrespondence::Kind::kPlane && std::abs(c.dir.z()) < cos_flat) ++f.res.num_structure_matches;
    }
    if (f.res.num_structure_matches < set.features.min_plane_points) {
      f.tried_icp = true;
      f.lidar_mode = LioFrameMode::kIcp;
      matched = associate(f, f.lidar_mode, f.xj, f.corr);
    }
  }
  if (matched < set.solver.min_correspondences) {
    if (set.mode == LioMode::kHybrid && !f.tried_icp) {  // hybrid: LOAM found too little, try ICP
      f.tried_icp = true;
      f.lidar_mode = LioFrameMode::kIcp;
      matched = associate(f, f.lidar_mode, f.xj, f.corr);
    }
    if (matched < set.solver.min_correspondences) {
      f.lidar_ok = false;
      f.corr.clear();
      matched = 0;
    }
  }
  f.num_matched = matched;
  f.s_imu.resize(f.corr.size());
  for (std::size_t k = 0; k < f.corr.size(); ++k) f.s_imu[k] = T_imu_lidar_ * f.corr[k].p;
}

void HybridLio::solve(Frame& f) {
  const HybridLioSettings& set = settings_;
  // The hybrid switch (Zhou et al. 2021, sec. 3.2).
  f.lidar_mode = LioFrameMode::kLoam;
  if (set.mode == LioMode::kHybrid && !set.features.switch_on_plane_matches &&
      f.res.num_structure_planes < set.features.min_plane_points) {
    f.lidar_mode = LioFrameMode::kIcp;
  }
  f.tried_icp = f.lidar_mode == LioFrameMode::kIcp;
  f.here = (pose_of(f.pred) * T_imu_lidar_).translation();
  f.xi = state_;
  f.xj = f.pred;
  const JointProblem problem(set, f.pim ? &*f.pim : nullptr, state_, prior_information_);
  const int n = problem.dim();
  LevenbergMarquardt lm;
  Matrix30d H;
  Vector30d g;
  double sum_sq = 0.0;
  for (int it = 0; it < set.solver.max_iterations; ++it) {
    if (f.lidar_ok) {
      associate_round(f, it);
      if (!f.lidar_ok && !problem.with_imu()) break;
    }
    f.res.iterations = it + 1;
    const double cost = problem.build(f.xi, f.xj, f.corr, f.s_imu, &H, &g, &sum_sq);
    f.res.num_correspondences = f.num_matched;
    f.res.rmse = f.num_matched == 0 ? 0.0 : std::sqrt(sum_sq / static_cast<double>(f.num_matched));
    // The system of the first n unknowns (the pose of x_j alone without the IMU factor).
    const Eigen::MatrixXd Hn = H.topLeftCorner(n, n);
    const Eigen::VectorXd gn = g.head(n);
    Eigen::VectorXd dn(n);
    Vector30d delta = Vector30d::Zero();
    ImuState a, b;
    const bool accepted = lm.step(Hn, gn, cost, [&](const Eigen::VectorXd& d) {
      delta.head(n) = d;
      problem.step(delta, f.xi, f.xj, a, b);
      return problem.build(a, b, f.corr, f.s_imu, nullptr, nullptr, nullptr);
    }, dn);
    delta.head(n) = dn;
    if (accepted) {
      problem.step(delta, f.xi, f.xj, a, b);
      f.xi = a;
      f.xj = b;
    }
    const Vector6d dj = delta.segment<6>(problem.offset_j());
    if (!accepted ||
        (dj.head<3>().norm() < set.solver.min_step_rotation && dj.tail<3>().norm() < set.solver.min_step_translation)) {
      f.converged = true;
      break;
    }
  }
}

void HybridLio::conclude(Frame& f) {
  LioFrameResult& res = f.res;
  if (f.lidar_ok) {
    res.mode = f.lidar_mode;
    res.status = f.converged ? Status::kOk : Status::kNotConverged;
  } else {
    res.mode = LioFrameMode::kPrediction;
    res.status = Status::kInsufficientData;
    if (!f.pim) f.xj = f.pred;
  }
  if (f.pim) {
    // The marginal prior on x_j: the Schur complement of x_i in the joint system at the solution.
    const JointProblem problem(settings_, &*f.pim, state_, prior_information_);
    Matrix30d H;
    Vector30d g;
    double sum_sq = 0.0;
    problem.build(f.xi, f.xj, f.corr, f.s_imu, &H, &g, &sum_sq);
    const Matrix15d Hii = H.topLeftCorner<15, 15>();
    const Eigen::Matrix<double, 15, 15> Hij = H.topRightCorner<15, 15>();
    const Eigen::LDLT<Matrix15d> ldlt(Hii);
    Matrix15d L = H.bottomRightCorner<15, 15>() - Hij.transpose() * ldlt.solve(Hij);
    L = 0.5 * (L + L.transpose()).eval();
    L.diagonal().array() += 1e-9;
    if (L.allFinite()) prior_information_ = L;
    else reset_prior();
  } else {
    f.xj.v_world = (f.xj.p_world_body - state_.p_world_body) / f.dt;
    f.xj.bias = state_.bias;
    reset_prior();
  }
  state_ = f.xj;
  remember_pose(f.stamp);
  last_stamp_ = f.stamp;
  ++num_frames_;
  if (f.lidar_ok) {
    // Needed next by the next frame's association: with threads, made beside that frame's
    // prediction and feature extraction. The frame's features are not used after this.
    settle_maps();
    map_update_ = start_beside(settings_.threads, [this, feats = std::move(f.feats), points = std::move(f.icp_points),
                                                   T = pose_of(state_) * T_imu_lidar_] { update_maps(feats, points, T); });
  }

  // Keep the IMU buffer bounded: samples older than a second before this frame are not needed.
  if (imu_.size() > 4096) {
    auto it = std::upper_bound(imu_.begin(), imu_.end(), f.stamp - 1.0,
                               [](double t, const ImuSample& s) { return t < s.stamp; });
    if (it - imu_.begin() > 2048) imu_.erase(imu_.begin(), it);
  }
}

}  // namespace plumb
