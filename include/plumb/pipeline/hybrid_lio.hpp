// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief LiDAR/IMU tightly coupled hybrid odometry (Zhou et al. 2021, eq. 19-22): per frame, IMU deskew,
///        cosine features, and one Gauss-Newton / Levenberg-Marquardt problem over the IMU states
///        (R, p, v, b_g, b_a) of the previous and the current frame with the IMU factor (E_B), a
///        prior on the previous state (the marginal of the last solve), and either LOAM residuals
///        against a local feature map (E_L1, when the frame has enough plane points off the ground)
///        or ICP residuals against a local point map (E_L2).
///
/// Two departures from the ICP frames of Zhou et al. 2021 (sec. 3.2), both settings (the paper's form:
/// solver.icp_metric = kPointToPoint, solver.icp_keep_loam = false): the pairs are point-to-distribution, and the
/// frame keeps the LOAM residuals the map still gives (the road, a few walls) beside them. On the
/// simulated site runs without loop closure the paper's form drifted several times more than
/// LOAM+IMU, these defaults less.
///
/// Frames: `T_world_base` is what the caller gets; the estimator's state is the IMU frame
/// (`T_world_imu = T_world_base * T_base_imu`). The world is z-up with gravity (0, 0, -gravity):
/// the initial pose given to the constructor must carry the true roll and pitch.

#include <cstddef>
#include <deque>
#include <future>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Geometry>

#include "plumb/core/point_cloud.hpp"
#include "plumb/core/status.hpp"
#include "plumb/imu/imu.hpp"
#include "plumb/imu/preintegration.hpp"
#include "plumb/loam/features.hpp"
#include "plumb/loam/ground.hpp"
#include "plumb/loam/local_map.hpp"
#include "plumb/loam/odometry.hpp"
#include "plumb/loam/range_image.hpp"

namespace plumb {

/// @brief Which estimator HybridLio runs.
enum class LioMode {
  kLoam,     ///< LiDAR only: LOAM residuals, constant-velocity prediction, no deskew (LeGO-LOAM without IMU)
  kLoamImu,  ///< IMU factor + LOAM residuals on every frame (E_B + E_L1), IMU deskew and prediction
  kHybrid,   ///< as kLoamImu, but frames with too few plane points add ICP residuals (E_B + E_L1 + E_L2)
};

/// @brief "loam", "loam-imu", "hybrid". @throws plumb::Error for another name.
LioMode lio_mode_from_string(const std::string& name);
/// @brief "loam", "loam-imu", "hybrid".
const char* to_string(LioMode mode);

/// @brief How one frame was estimated.
enum class LioFrameMode {
  kInit,        ///< first frame: the initial pose, the map is started
  kLoam,        ///< LOAM edge / plane residuals against the feature map
  kIcp,         ///< ICP residuals (see IcpMetric) against the point map
  kPrediction,  ///< no usable LiDAR residuals: IMU (or constant-velocity) prediction only
  kSkipped,     ///< frame rejected (stamp not after the previous frame's, or too few points to start the map); the state is unchanged
};

/// @brief "init", "loam", "icp", "prediction", "skipped".
const char* to_string(LioFrameMode mode);

/// @brief How the ICP frames of the hybrid mode pair a query point with the local point map.
enum class IcpMetric {
  /// Nearest map point, isotropic point_sigma (Zhou et al. 2021, eq. 20).
  kPointToPoint,
  /// The mean of the icp_neighbors nearest map points, weighted by the inverse of their covariance
  /// plus point_sigma^2 (a Mahalanobis distance, as in GICP / NDT): where the map is a ring line on
  /// a far wall, the pair constrains the two directions across the line and hardly the one along
  /// it, which a nearest point would pin to where the prediction put it.
  kPointToDistribution,
};

/// @brief "point-to-point", "point-to-distribution".
const char* to_string(IcpMetric metric);
/// @brief Inverse of to_string(IcpMetric). @throws plumb::Error for another name.
IcpMetric icp_metric_from_string(const std::string& name);

/// @brief HybridLio's range image, features, ground and the hybrid switch (Zhou et al. 2021, sec. 3.2).
struct LioFeatureSettings {
  RangeImageSettings image;       ///< range image of each (deskewed) frame
  LoamFeatureSettings loam;       ///< cosine features
  /// Hybrid switch: a frame with at least this many selected plane points off the ground uses
  /// LOAM residuals, fewer use ICP (Zhou et al. 2021, sec. 3.2: 48). Ground points (the road) constrain only
  /// height, roll and pitch, so they do not count as structure.
  std::size_t min_plane_points = 48;
  /// The map starts at the first frame with at least this many points; an emptier frame before it
  /// (a sensor still starting up) is skipped, else every later frame would match an empty map.
  /// 1: only an empty frame is skipped (`plumb lio` asks for 100).
  std::size_t min_init_points = 1;
  /// True: the switch counts the frame's plane residuals against the map whose plane is not flat
  /// (LioFrameResult::num_structure_matches: what LOAM would really use off the ground); false: it
  /// counts the selected plane features off the ground (num_structure_planes, at most
  /// LoamFeatureSettings::max_planes_per_sector per ring and sector, slots which an open site fills
  /// with road points).
  bool switch_on_plane_matches = true;
  /// Two vertically adjacent returns below the horizon whose joining segment is flatter than this
  /// are ground (LeGO-LOAM's ground test) [deg].
  double ground_max_slope_deg = 10.0;
  /// Returns below the sensor this close to the plane through the pair test's ground are ground
  /// too [m]; 0 = the pair test only (see classify_ground()). Road returns the pair test misses
  /// stayed among the structure (ICP queries, edges) and, as ring arcs that barely move with the
  /// sensor, held frames back on the simulated site runs.
  double ground_plane_tolerance = 0.15;
};

/// @brief HybridLio's joint problem: association, residual noise, robust kernel, iterations
/// (Zhou et al. 2021, eq. 21-22), and the ICP frames' residual.
struct LioSolverSettings {
  int max_iterations = 8;                    ///< association + LM step rounds per frame, >= 1
  double max_correspondence_distance = 1.0;  ///< farther map neighbours are not used [m]
  /// Map points fitted per LOAM query, in [3, 64], and how close to the fitted plane they must all
  /// lie. LOAM's 5 neighbours within 0.2 m fitted biased planes to the sparse map of 16-line frames
  /// (walls 10-45 m away): on the simulated duplex site the estimate turned ~0.02 deg per frame
  /// while leaving the house (hybrid end error 3.7 m over 389 m); 10 within 0.05 m: 0.03 m. With 10
  /// within 0.2 m the robot crept 12 cm while standing still.
  int map_neighbors = 10;
  double map_plane_tolerance = 0.05;  ///< [m], see map_neighbors
  double map_edge_ratio = 3.0;               ///< a fitted line needs eigenvalue ratio >= this
  double map_plane_ratio = 10.0;             ///< a fitted plane needs second / smallest eigenvalue >= this
  double plane_sigma = 0.05;                 ///< std of a point-to-plane residual [m]
  double edge_sigma = 0.1;                   ///< std of a point-to-line residual [m]
  /// std of a point-to-point (ICP) residual [m]; kPointToDistribution adds its square to the
  /// covariance of the map neighbours.
  double point_sigma = 0.15;
  double huber_scale = 3.0;                  ///< Huber kernel on whitened LiDAR residuals [sigmas]
  /// Fewer LiDAR residuals than this: the LiDAR is not used for the frame (hybrid first tries ICP).
  std::size_t min_correspondences = 30;
  double min_step_translation = 1e-4;        ///< converged below this step [m] ...
  double min_step_rotation = 1e-5;           ///< ... and this rotation step [rad]

  IcpMetric icp_metric = IcpMetric::kPointToDistribution;  ///< ICP frames' residual (see IcpMetric)
  int icp_neighbors = 8;  ///< map points per kPointToDistribution pair, in [3, 64]
  /// ICP frames keep the LOAM residuals that the map gave too (E_B + E_L1 + E_L2); false: ICP
  /// residuals only (E_B + E_L2, Zhou et al. 2021, eq. 21).
  bool icp_keep_loam = true;
  /// ICP frames also match their ground returns point-to-plane against the plane map (the ICP
  /// pairs come from off the ground only, so without this height, roll and pitch rest on the IMU).
  bool icp_ground_planes = false;
};

/// @brief HybridLio's local maps (bounded voxel hash maps, world frame) and the frame's queries.
struct LioMapSettings {
  /// LOAM edge points
  VoxelHashMapSettings edge_map = [] {
    VoxelHashMapSettings m;
    m.voxel_size = 0.3;
    m.max_points_per_voxel = 1;
    m.max_distance = 60.0;
    m.max_voxels = 100000;
    return m;
  }();
  /// LOAM plane points
  VoxelHashMapSettings plane_map = [] {
    VoxelHashMapSettings m;
    m.voxel_size = 0.4;
    m.max_points_per_voxel = 1;
    m.max_distance = 60.0;
    m.max_voxels = 100000;
    return m;
  }();
  /// ICP points
  VoxelHashMapSettings point_map = [] {
    VoxelHashMapSettings m;
    m.voxel_size = 0.4;
    m.max_points_per_voxel = 4;
    m.max_distance = 60.0;
    m.max_voxels = 150000;
    return m;
  }();
  double icp_voxel_size = 0.6;  ///< a frame's ICP queries: one point per voxel of this size [m]
  /// LOAM plane queries and plane map points: every return, off the ground one per voxel of
  /// plane_query_voxel, on the ground one per ground_query_voxel (LOAM's mapping matches all "less
  /// flat" points). False: the selected plane features and candidates only (4 + 4 per sector).
  bool dense_plane_queries = true;
  double plane_query_voxel = 0.3;   ///< see dense_plane_queries [m]
  double ground_query_voxel = 0.3;  ///< see dense_plane_queries; also the ICP frames' ground queries [m]
  /// The maps' kd-trees are rebuilt (with every point added since) once the sensor has moved this
  /// far from where they were last built [m], or after map_rebuild_frames frames.
  double map_rebuild_distance = 1.0;
  int map_rebuild_frames = 10;  ///< see map_rebuild_distance, >= 1
};

/// @brief HybridLio's IMU factor and the initial state's prior.
struct LioImuSettings {
  ImuNoise noise;               ///< noise model of the IMU factor (MEMS defaults)
  double gravity = 9.81;        ///< |g| [m/s^2] (the simulator's value; standard gravity is 9.80665)
  double max_imu_gap = 0.05;    ///< longer without an IMU sample: the IMU is not used for the frame [s]
  double initial_velocity_sigma = 0.2;     ///< prior std of the initial velocity (0 expected) [m/s]
  double initial_gyro_bias_sigma = 0.005;  ///< prior std of the initial gyro bias [rad/s]
  double initial_accel_bias_sigma = 0.1;   ///< prior std of the initial accelerometer bias [m/s^2]
};

/// @brief HybridLio's motion model without the IMU and the deskew.
struct LioMotionSettings {
  /// Undo motion distortion in the IMU modes: with the IMU, or with constant velocity over an IMU
  /// gap. kLoam never deskews (LeGO-LOAM deskews only with an IMU; a constant-velocity deskew feeds
  /// the frame's own error back into the next frame: measured on the site runs, it oscillates from
  /// frame to frame and loses track within metres).
  bool deskew = true;
  /// The constant-velocity model (the prediction without IMU data: kLoam, and IMU modes over an IMU
  /// gap; the deskew over an IMU gap) uses the mean body twist of the last this many frame
  /// intervals. One interval feeds a frame's own registration error straight into the next frame:
  /// the deskew oscillates (simulated run with a 1 s IMU gap at 1.4-1.5 m/s: worst error 7.2 cm
  /// with one interval, 5.0 cm with five, 11 cm without deskew), and kLoam's prediction carries
  /// every velocity error on (simulated site runs, noise seeds 1-5: end error lower on all ten with
  /// five intervals than with one; median 43 m against 109 m on FZK-Haus, 76 m against 291 m on
  /// duplex). >= 1.
  std::size_t twist_frames = 5;
};

/// @brief Settings of HybridLio, grouped by stage. Defaults suit a 16-line LiDAR at 10 Hz and a
/// MEMS IMU.
struct HybridLioSettings {
  LioMode mode = LioMode::kHybrid;  ///< estimator
  Eigen::Isometry3d T_base_lidar = Eigen::Isometry3d::Identity();  ///< LiDAR points into the base frame
  Eigen::Isometry3d T_base_imu = Eigen::Isometry3d::Identity();    ///< IMU frame into the base frame
  LioFeatureSettings features;  ///< range image, features, ground, the hybrid switch
  LioSolverSettings solver;     ///< association, residuals, iterations
  LioMapSettings map;           ///< local maps
  LioImuSettings imu;           ///< IMU factor and initial prior
  LioMotionSettings motion;     ///< constant-velocity model and deskew
  /// Threads of the correspondence search against the maps (0 = every core); results are
  /// bit-identical for any count (core/parallel.hpp).
  int threads = 1;
};

/// @brief What HybridLio::process() did with one frame.
struct LioFrameResult {
  double stamp = 0.0;                                               ///< frame stamp [s]
  Eigen::Isometry3d T_world_base = Eigen::Isometry3d::Identity();   ///< estimate at the stamp
  Vector3d v_world = Vector3d::Zero();                              ///< velocity of the IMU [m/s]
  ImuBias bias;                                                     ///< bias estimate
  LioFrameMode mode = LioFrameMode::kSkipped;                       ///< how the frame was estimated
  /// kOk; kNotConverged (LiDAR used, iteration limit); kInsufficientData (no usable LiDAR
  /// residuals: prediction only); kInvalidInput (frame skipped: stamp not increasing / not finite).
  Status status = Status::kOk;
  bool imu_used = false;       ///< the IMU factor was part of the problem
  bool imu_gap = false;        ///< an IMU mode, but the IMU did not cover the interval (gap): fallback
  bool deskewed = false;       ///< points were moved to the stamp (IMU or constant velocity)
  bool deskewed_with_imu = false;  ///< ... with the IMU
  std::size_t num_points = 0;            ///< points in the frame
  std::size_t num_plane_points = 0;      ///< plane features selected (all)
  std::size_t num_ground = 0;            ///< returns taken as ground (the road)
  std::size_t num_ground_added = 0;      ///< ... of which the ground plane found, not the pair test
  std::size_t num_structure_planes = 0;  ///< plane features off the ground (the switch's count when
                                         ///< settings.features.switch_on_plane_matches is false)
  std::size_t num_structure_matches = 0; ///< hybrid: non-flat plane residuals at the first association
                                         ///< (the switch's count when switch_on_plane_matches)
  std::size_t num_edge_points = 0;       ///< edge features selected
  std::size_t num_plane_interval = 0;    ///< points in the plane cos interval (Zhou et al. 2021, sec. 1.2)
  std::size_t num_edge_interval = 0;     ///< points in the edge cos interval
  std::size_t num_correspondences = 0;   ///< matched query points (LiDAR pairs) at the last iteration
  int iterations = 0;                    ///< solver rounds
  double rmse = 0.0;                     ///< RMS distance of a pair at the last iteration [m]
  double seconds = 0.0;                  ///< wall time of process() [s]
};

/// @brief The tightly coupled LiDAR/IMU hybrid odometry (see the file comment).
///
/// Usage: construct with the initial base pose, add_imu() every IMU sample as it arrives (a frame
/// needs the samples up to the end of its sweep for deskewing), process() every frame in order.
/// @note Deterministic; single-threaded; not thread-safe. Bad data never throws: IMU samples out
///       of order or not finite are dropped (add_imu() says so), frames whose stamp does not
///       increase are skipped, gaps in the IMU fall back to constant-velocity prediction, frames
///       without features fall back to the prediction.
class HybridLio {
 public:
  /// @throws plumb::Error on bad settings (non-finite pose, non-positive sigmas...).
  explicit HybridLio(const Eigen::Isometry3d& T_world_base0 = Eigen::Isometry3d::Identity(),
                     const HybridLioSettings& settings = {});
  // A map update may be running on a second thread with a pointer to this object.
  HybridLio(const HybridLio&) = delete;
  HybridLio& operator=(const HybridLio&) = delete;

  /// @brief Buffer one IMU sample (IMU frame).
  /// @return kOk; kInvalidInput when the sample is not finite or its stamp does not increase (dropped).
  Status add_imu(const ImuSample& sample);

  /// @brief Estimate the pose of one LiDAR frame (points in the LiDAR frame, per-point `times`
  ///        since `stamp` when the sensor reports them; rings used when present).
  /// @throws plumb::Error only for a cloud with inconsistent fields (misuse).
  LioFrameResult process(const PointCloud& frame_lidar, double stamp);

  /// @brief Current base pose estimate (the initial pose before the first frame).
  Eigen::Isometry3d T_world_base() const;
  /// @brief Current IMU state estimate.
  const ImuState& state() const { return state_; }
  const HybridLioSettings& settings() const { return settings_; }
  std::size_t num_frames() const { return num_frames_; }          ///< frames processed (not skipped)
  bool initialized() const { return initialized_; }               ///< a frame has started the map
  std::size_t num_imu_dropped() const { return num_imu_dropped_; }  ///< samples add_imu() rejected
  /// @brief Local LOAM edge map (with the last frame's points: a pending update is completed first).
  const VoxelHashMap& edge_map() const {
    settle_maps();
    return edge_map_;
  }
  /// @brief Local LOAM plane map (as edge_map()).
  const VoxelHashMap& plane_map() const {
    settle_maps();
    return plane_map_;
  }
  /// @brief Local ICP point map (as edge_map()).
  const VoxelHashMap& point_map() const {
    settle_maps();
    return point_map_;
  }

 private:
  /// One frame on its way through process(): the prediction, the frame's features and queries,
  /// and the solver's state (defined in hybrid_lio.cpp).
  struct Frame;

  // The stages of process(), in order.
  /// 1. The state at the frame's stamp: IMU preintegration from the last frame, or constant velocity.
  void predict(Frame& f) const;
  /// 2. Deskew, range image, cosine features, ground, and the ICP / plane / ground query points.
  void extract(Frame& f, const PointCloud& frame_lidar) const;
  /// 3. Map pairs for the LiDAR mode `m` at state x (the search structures are rebuilt when stale);
  ///    returns the matched query points.
  std::size_t associate(Frame& f, LioFrameMode m, const ImuState& x, std::vector<LoamCorrespondence>& corr);
  /// 3'. The association of one solver round, with the hybrid switch and the fall-backs.
  void associate_round(Frame& f, int iteration);
  /// 4. The joint IMU + LiDAR problem solved by Levenberg-Marquardt.
  void solve(Frame& f);
  /// 5. Outcome, marginal prior for the next frame, state and maps.
  void conclude(Frame& f);
  /// Fills the result's state fields and wall time.
  LioFrameResult finish(Frame& f) const;

  /// Appends the current pose to recent_poses_ and updates twist_.
  void remember_pose(double stamp);
  void deskew(PointCloud& cloud, double stamp, const ImuState& at_stamp, bool use_imu, LioFrameResult& res) const;
  bool imu_covers(double t0, double t1) const;
  void update_maps(const LoamFeatures& f, const PointCloud& cloud, const Eigen::Isometry3d& T_world_lidar);
  /// Completes the pending map update (see map_update_); rethrows its exception.
  void settle_maps() const;
  void reset_prior();

  HybridLioSettings settings_;
  Eigen::Isometry3d T_imu_lidar_ = Eigen::Isometry3d::Identity();
  ImuState state_;
  Eigen::Matrix<double, 15, 15> prior_information_ = Eigen::Matrix<double, 15, 15>::Zero();
  /// Constant velocity: mean body twist per second of the IMU frame over the last twist_frames intervals.
  Vector6d twist_ = Vector6d::Zero();
  std::deque<std::pair<double, Eigen::Isometry3d>> recent_poses_;  ///< (stamp, T_world_imu) of the last frames
  std::vector<ImuSample> imu_;
  double last_imu_stamp_ = -1e300;
  double last_stamp_ = 0.0;
  bool initialized_ = false;
  std::size_t num_frames_ = 0;
  std::size_t num_imu_dropped_ = 0;
  VoxelHashMap edge_map_, plane_map_, point_map_;
  /// The last frame's map update: with threads != 1 it runs beside the next frame's prediction and
  /// feature extraction, which never read the maps; settle_maps() waits for it (or, on one thread,
  /// runs it) before anything does. The maps are then those of the serial order.
  mutable std::future<void> map_update_;
  // Search structures over the maps, rebuilt as map_rebuild_* say.
  std::optional<LoamMap> loam_tree_;
  PointCloud point_cloud_;
  std::optional<KdTree3f> point_tree_;
  Vector3d loam_built_at_ = Vector3d::Zero(), point_built_at_ = Vector3d::Zero();
  std::size_t loam_built_frame_ = 0, point_built_frame_ = 0;
};

}  // namespace plumb
