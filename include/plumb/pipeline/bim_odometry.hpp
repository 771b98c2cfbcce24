// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief BIM-corrected laser odometry (Liu et al. 2022, sec. 3.3), one frame at a time.
///
/// Per frame: the LiDAR frame is cut to a planar scan in the base frame (a z band around the
/// LiDAR's height, Liu et al. 2022, sec. 2.1); ScanOdometry matches it by PLICP against a local map,
/// seeded by the wheel odometry; the relative motion is chained in a PoseComposer. Every
/// `correct_every` frames the frame's ground and vertical-plane key points (Liu et al. 2022,
/// sec. 2.2) are placed at the composed global pose and registered to the BIM cloud by
/// point-to-plane ICP; when the registration passes the overlap and inlier gates, its result
/// becomes an absolute anchor whose information comes from the final correspondences and the
/// elements they lie on (element_anchor_information; directions the key points do not constrain,
/// e.g. along a corridor, get none), and the composer applies it
/// as `M ← M_e · M` (Liu et al. 2022, sec. 3.3, loop step (5)) through its Mahalanobis gate.

#include <cstddef>
#include <cstdint>
#include <future>
#include <memory>
#include <optional>
#include <utility>
#include <vector>

#include <Eigen/Geometry>

#include "plumb/core/point_cloud.hpp"
#include "plumb/core/pose2.hpp"
#include "plumb/core/types.hpp"
#include "plumb/pipeline/as_built.hpp"
#include "plumb/pipeline/pose_composer.hpp"
#include "plumb/registration/icp.hpp"
#include "plumb/scan2d/cloud_to_scan.hpp"
#include "plumb/scan2d/scan_odometry.hpp"
#include "plumb/search/kdtree.hpp"
#include "plumb/segmentation/segment_frame.hpp"

namespace plumb {

/// @brief Settings of BimOdometry.
struct BimOdometrySettings {
  Eigen::Isometry3d T_base_lidar = Eigen::Isometry3d::Identity();  ///< LiDAR points into the base frame
  // 3D -> 2D (Liu et al. 2022, sec. 2.1): the planar scan is taken in the base frame.
  double scan_band = 0.3;            ///< half height of the z band around the LiDAR's height [m]
  double scan_angle_increment = 0.00872664625997164788;  ///< bin width [rad] (0.5°)
  double scan_range_min = 0.3;       ///< [m]
  double scan_range_max = 40.0;      ///< [m]
  /// PLICP front end (T_base_laser is ignored) with 5 keyframes in its local map.
  ScanOdometrySettings front_end = [] {
    ScanOdometrySettings s;
    s.local_map_size = 5;
    return s;
  }();
  // Motion noise added to the front end's relative motions (world-independent, per step).
  double motion_sigma_xy = 0.01;      ///< [m] per metre travelled, plus PLICP's own covariance
  double motion_sigma_theta = 0.01;   ///< [rad] per radian turned and per metre, plus PLICP's
  double fallback_sigma_xy = 0.05;    ///< [m] per metre when the step fell back to wheel odometry
  double fallback_sigma_theta = 0.05; ///< [rad] per radian and per metre likewise
  // Wheels' error budget per step (front_end_step_covariance, front_end_step): a match that
  // disagrees with the wheels' step by more gets the excess as extra std, and the step is then
  // blended with the wheels'. Encoders of a differential drive err by a few mm and a few % per
  // step; slip beyond that only lets the next BIM anchor correct more.
  double wheel_tolerance_xy = 0.003;    ///< [m]
  double wheel_tolerance_theta = 0.01;  ///< [rad]
  double wheel_tolerance_ratio = 0.03;  ///< plus this fraction of the step's length (xy) or turn (θ)
  // BIM correction (Liu et al. 2022, sec. 3.3, loop step (5)).
  bool use_bim = true;               ///< false: plain scan-matching odometry
  std::size_t correct_every = 1;     ///< register key points every k-th frame (>= 1)
  SegmentSettings segment;           ///< ground / vertical key points
  double key_point_voxel = 0.15;     ///< key points thinned to this voxel before ICP [m] (0 = all)
  /// ICP of the per-frame BIM registration: point-to-plane from a close guess, partial overlap (the
  /// BIM has no furniture), Huber kernel.
  IcpSettings icp = [] {
    IcpSettings s;
    s.method = IcpMethod::kPointToPlane;
    s.max_correspondence_distance = 0.2;
    s.distance_step = 0.05;
    s.min_correspondence_distance = 0.1;
    s.max_rounds = 4;
    s.max_iterations = 15;
    s.min_overlap = 0.5;
    s.overlap_distance = 0.1;
    s.kernel = RobustKernel::kHuber;
    s.kernel_scale = 0.05;
    return s;
  }();
  double min_anchor_overlap = 0.5;   ///< ICP overlap below this: no anchor
  std::size_t min_anchor_inliers = 100;  ///< fewer ICP inliers: no anchor
  /// Without element labels (anchor_from_elements): residual std of one key point against the BIM [m],
  double anchor_sigma = 0.03;
  /// and the information scaled as if at most this many key points were independent (as-built
  /// deviations of a wall are shared by all its points).
  double anchor_effective_points = 50.0;
  /// Directions whose normalised information is below this fraction of the strongest get none. A
  /// weak direction's information is already as small as the elements make it (a corridor's axis,
  /// seen only through door reveals and the odd column), so only the nearly unconstrained are cut.
  double anchor_rank_threshold = 0.002;
  double anchor_length = 5.0;        ///< L normalising rotation against translation in that test [m]
  /// The anchor's information from what limits it: every key point lies on an element of the model,
  /// and the element's own displacement from where the target cloud has it (the construction
  /// tolerance `as_built.sigma_*`; with estimate_as_built, the estimate's covariance once an element
  /// has been observed) moves all its points together; plus `as_built.point_sigma` per point. Needs
  /// the BIM cloud's element labels; without them, or when false, `anchor_sigma` and
  /// `anchor_effective_points` give it.
  bool anchor_from_elements = true;
  PoseComposerSettings composer;
  /// Covariance of the initial pose (world frame); default 2 cm / 0.5°.
  Matrix6d initial_covariance = [] {
    Vector6d d;
    const double t = 0.02, r = 0.5 * 3.14159265358979323846 / 180.0;
    d << t * t, t * t, t * t, r * r, r * r, r * r;
    return Matrix6d(d.asDiagonal());
  }();
  /// Estimate every element's as-built displacement while driving (AsBuiltMap, from the key points of
  /// each accepted anchor) and register later frames to the elements as estimated. Needs the BIM
  /// cloud's element labels (bim::sample_bim_cloud gives them).
  bool estimate_as_built = false;
  AsBuiltSettings as_built;               ///< the estimator's settings (construction tolerance, ...)
  std::size_t as_built_refresh_every = 10;  ///< accepted anchors between updates of the registration target
  /// With the as-built estimate (or register_to), the registration target is the BIM cloud with
  /// every element displaced as estimated, remade whenever the estimate is taken up. Only its storey
  /// band is remade: the points whose height lies within the key points' heights at the predicted
  /// pose, widened by the registration's reach (twice its largest correspondence or overlap
  /// distance, plus 0.5 m for the registration to move) and then by this margin [m]. Every point a
  /// registration can pair with lies in it (as long as it moves the key points less than 0.5 m
  /// from their prediction), so the result is the one against the whole model, while the storeys
  /// above and below cost nothing; a band is cut again when a frame's key points leave it (a ramp,
  /// a lift). The whole cloud is used when the band holds it (a one-storey model); +inf: always.
  /// The design itself is one target for every height, made once.
  double target_band_margin = 0.5;
  /// Threads (0 = every core): the BIM registration's correspondence search (replaces
  /// `icp.threads`), and with more than one, a frame's key points are found on a second thread while
  /// the front end matches its scan. Results are bit-identical for any count (core/parallel.hpp).
  int threads = 1;
  /// Threads (0 = every core) that move the displaced target's points and refit its kd-tree when
  /// the estimate is taken up: millions of points on a large model, while everything else waits
  /// for the frame. `plumb run` gives them every thread of the run (its other stages are then
  /// waiting too). Bit-identical for any count.
  int refresh_threads = 1;
};

/// @brief Covariance (x, y, θ; frame of the previous base pose) BimOdometry gives one front-end step.
///
/// `motion_sigma_*` (or `fallback_sigma_*` when the step is not a match) times the distance and turn,
/// plus the match's own covariance; for a match, plus the square of how far its step disagrees with
/// the wheels' step beyond `wheel_tolerance_*` + `wheel_tolerance_ratio` × the step, per component.
/// Normal matches stay as confident as PLICP says; a scan-matching glitch (the match jumps where
/// the wheels did not) becomes as uncertain as the jump, so the next BIM anchor passes the
/// composer's gate and removes it instead of being rejected against an overconfident chain.
Matrix3d front_end_step_covariance(const BimOdometrySettings& settings, const Pose2& front_step,
                                   const Pose2& wheel_step, bool matched, const Matrix3d& match_covariance);

/// @brief Information of a point-to-plane registration's pose, about the point `c` (a motion
///        [v; w]: x -> x + w x (x - c) + v), when the target's points belong to elements that may each
///        be displaced from where the target has them: element `labels[target_index]` by a motion
///        about `pivots[e]` with covariance `covariances[e]` (t [m], w [rad]), independently, plus
///        noise `point_sigma` [m] per pair along its normal. The least-squares pose errs by the sum of
///        both; the information is the inverse of that covariance, zero in directions the pairs do not
///        constrain. Pairs with no label, an unknown element or no normal are skipped.
/// @throws plumb::Error when pivots and covariances differ in size
Matrix6d element_anchor_information(const std::vector<IcpCorrespondence>& pairs, const std::vector<std::int32_t>& labels,
                                    const std::vector<Vector3d>& pivots, const std::vector<Matrix6d>& covariances,
                                    double point_sigma, const Vector3d& c);

/// @brief The step BimOdometry chains: the match's step, unless the match disagrees with the wheels
///        beyond their budget; then each component is the variance-weighted mean of the two, the
///        match's variance from `covariance` (front_end_step_covariance()), the wheels' the budget
///        squared. The step's covariance stays that of the match, as large as the disagreement.
Pose2 front_end_step(const BimOdometrySettings& settings, const Pose2& front_step, const Pose2& wheel_step,
                     bool matched, const Matrix3d& covariance);

/// @brief What happened to one frame.
struct BimFrameResult {
  double stamp = 0.0;
  Eigen::Isometry3d T_world_base = Eigen::Isometry3d::Identity();        ///< corrected pose
  Eigen::Isometry3d T_world_base_uncorrected = Eigen::Isometry3d::Identity();  ///< front end only, from the initial pose
  ScanMatchMode mode = ScanMatchMode::kInitial;  ///< front-end outcome
  Status scan_status = Status::kOk;     ///< cloud_to_scan outcome (kInsufficientData: no point in the band)
  bool anchor_attempted = false;        ///< key points were registered this frame
  Status icp_status = Status::kInsufficientData;
  double icp_overlap = 0.0;
  std::size_t icp_inliers = 0;
  /// Points of the BIM cloud the key points were registered against: its storey band, or all of it
  /// (settings.target_band_margin).
  std::size_t target_points = 0;
  std::size_t num_key_points = 0;
  int anchor_dof = 0;                   ///< rank of the anchor information (6 = fully constrained)
  /// The key points' registration passed the overlap and inlier gates: T_world_base_registered is the
  /// base pose the BIM alone gives (what the anchor measured, before fusion with the front end).
  bool registered = false;
  Eigen::Isometry3d T_world_base_registered = Eigen::Isometry3d::Identity();
  AnchorResult anchor;                  ///< the composer's decision (kIgnored when no anchor was made)
  std::size_t as_built_pairs = 0;       ///< key-point pairs the as-built estimate took (estimate_as_built)
  /// Time of the front end, of finding the key points and of their registration, and of the whole
  /// frame [s] (the cut to a planar scan counts in the front end). With threads != 1 the key points
  /// are found while the front end runs, so the parts may add up to more than the whole. For a
  /// prepared frame, the cut and the key points are timed by prepare() and the whole is the time of
  /// prepare() and process() together.
  double seconds_front_end = 0.0, seconds_segment = 0.0, seconds_icp = 0.0, seconds_total = 0.0;
};

/// @brief The front end's step on one frame (BimOdometry::front_end()).
struct BimFrontStep {
  ScanMatchMode mode = ScanMatchMode::kInitial;
  bool has_motion = false;  ///< false on the first frame
  Eigen::Isometry3d motion = Eigen::Isometry3d::Identity();  ///< base motion since the previous frame
  Matrix6d motion_covariance = Matrix6d::Zero();              ///< its covariance (composer convention)
  Eigen::Isometry3d T_world_base_uncorrected = Eigen::Isometry3d::Identity();
  double seconds = 0.0;  ///< time of the match [s]
};

/// @brief What BimOdometry takes from a frame before its BIM correction: its planar scan and, for a
/// frame that is BIM-corrected, its key points, which depend on the frame alone
/// (BimOdometry::prepare()); then, optionally, the front end's step (BimOdometry::front_end()).
/// A reader can so prepare frame i + 2 and match frame i + 1 on other threads while frame i is
/// corrected.
struct BimFrameInput {
  double stamp = 0.0;
  std::size_t frame_number = 0;        ///< the frame's place in the sequence (0 = the first processed)
  CloudToScanResult scan;              ///< the 3D-to-2D cut (Liu et al. 2022, sec. 2.1)
  std::optional<PointCloud> key_points;  ///< set when the frame is corrected (BimOdometry::corrects())
  double seconds_scan = 0.0, seconds_segment = 0.0;  ///< time of the cut and of the key points [s]
  std::optional<BimFrontStep> front;   ///< set by BimOdometry::front_end()
};

/// @brief The BIM-corrected odometry (see the file comment). Deterministic. Not thread-safe, except
/// that its three stages may each run on its own thread: prepare() (const), front_end() (only the
/// front end's state) and process(), each called in frame order, front_end() of a frame before its
/// process().
class BimOdometry {
 public:
  /// @param bim_cloud the BIM cloud with normals (bim::sample_surface of the relevant storey), world frame
  /// @param T_world_base0 initial pose of the base in the BIM frame (BimLocalizer or a known start)
  /// @throws plumb::Error when the BIM cloud has no normals or too few points, or settings are invalid
  BimOdometry(std::shared_ptr<const PointCloud> bim_cloud, const Eigen::Isometry3d& T_world_base0,
              const BimOdometrySettings& settings = {});

  /// @brief Process one frame: LiDAR points (sensor frame, deskewed to `stamp` by the caller when
  ///        needed), its stamp and the wheel-odometry pose of the base at that stamp (any fixed frame).
  BimFrameResult process(const PointCloud& lidar_frame, double stamp, const Pose2& odom_pose);

  /// @brief The part of process() that depends on the frame alone, for frame number `frame_number`
  ///        (0 = the first processed). Const, and safe to call on another thread while process() runs.
  BimFrameInput prepare(const PointCloud& lidar_frame, double stamp, std::size_t frame_number) const;
  /// @brief prepare() in two steps: the planar scan alone, then (for a corrected frame) the key points
  ///        of the same frame; both const, as prepare().
  BimFrameInput prepare_scan(const PointCloud& lidar_frame, double stamp, std::size_t frame_number) const;
  void add_key_points(BimFrameInput& input, const PointCloud& lidar_frame) const;
  /// @brief The front end's match of a prepared frame (PLICP against the local map, seeded by the
  ///        wheel-odometry pose `odom_pose`), into `input.front`.
  /// @throws plumb::Error when `input` is not the frame after the one last matched, or already matched.
  void front_end(BimFrameInput& input, const Pose2& odom_pose);
  /// @brief Process a prepared frame: the same result as process() on the frame it was prepared from.
  ///        Runs the front end first unless front_end() did (`odom_pose` is then not used).
  /// @throws plumb::Error when `input` was prepared for another frame number than num_frames().
  BimFrameResult process(const BimFrameInput& input, const Pose2& odom_pose);

  /// @brief Whether frame number `frame_number` is registered to the BIM (needs key points).
  bool corrects(std::size_t frame_number) const {
    return settings_.use_bim && frame_number % settings_.correct_every == 0;
  }
  std::size_t num_frames() const { return frame_index_; }  ///< frames processed so far

  const Eigen::Isometry3d& pose() const { return composer_.pose(); }
  const PoseComposer& composer() const { return composer_; }
  const BimOdometrySettings& settings() const { return settings_; }
  /// @brief The as-built estimate (null unless settings.estimate_as_built).
  const AsBuiltMap* as_built() const { return as_built_.get(); }
  /// @brief Register the frames from now on to the building as `map` estimates it, e.g. the estimate
  ///        at the end of an earlier pass over the same frames: the target becomes the map's corrected
  ///        cloud, and each element the map has observed weighs the anchors by the estimate's
  ///        covariance instead of the construction tolerance. The map is read once, not kept.
  /// @throws plumb::Error with estimate_as_built (the odometry's own estimate would replace the
  ///         target), without use_bim, or when `map` was not made from this odometry's BIM cloud
  ///         (other points or labels)
  void register_to(const AsBuiltMap& map);

 private:
  /// The frame's ground and vertical-plane key points, thinned (a function of the frame alone).
  PointCloud key_points(const PointCloud& lidar_frame) const;
  /// The frame's planar scan in the base frame.
  CloudToScanResult planar_scan(const PointCloud& lidar_frame, double stamp) const;
  /// The front end's step on the frame (checks its number).
  BimFrontStep match(const BimFrameInput& input, const Pose2& odom_pose);
  /// process() after the front end: the motion into the composer, then the registration of the key
  /// points, which `input.key_points` holds or `keys_beside` is finding.
  BimFrameResult compose(const BimFrameInput& input, const BimFrontStep& front,
                         std::future<std::pair<PointCloud, double>>* keys_beside);
  /// Registers the key points; fills the anchor fields of `out`.
  void correct(const PointCloud& keys, BimFrameResult& out);
  /// The accepted anchor's pairs into the as-built estimate; every as_built_refresh_every anchors,
  /// the registration target becomes the cloud as estimated.
  void update_as_built(const IcpResult& icp, const Vector3d& robot_position, BimFrameResult& out);
  /// Each element `map` has observed weighs the anchors by the estimate's covariance from now on.
  void take_element_covariances(const AsBuiltMap& map);

  /// The part of the BIM cloud a registration is done against (see settings.target_band_margin).
  struct Target {
    double z_min = 0.0, z_max = 0.0;  ///< the band: key points may lie at any height in it, less the reach
    bool whole = false;       ///< the band holds the whole BIM cloud
    std::vector<std::uint32_t> index;  ///< target point -> BIM cloud point (empty when whole)
    PointCloud displaced;              ///< the points displaced by target_mean_ (empty for the design)
    const PointCloud* cloud = nullptr; ///< &displaced, or the design
    std::unique_ptr<KdTree3f> tree;
  };
  /// The target for key points `keys` at pose T (lidar in world); cut again when they leave its band.
  const Target& registration_target(const PointCloud& keys, const Eigen::Isometry3d& T);
  /// From now on register to the BIM cloud with every element displaced by `mean` (6 per element).
  void displace_target(Eigen::VectorXd mean);
  /// element_pivot_, computed at the first call.
  const std::vector<Vector3d>& element_pivots();

  BimOdometrySettings settings_;
  std::shared_ptr<const PointCloud> bim_;  ///< the BIM cloud as designed
  double bim_z_min_ = 0.0, bim_z_max_ = 0.0;  ///< heights of its lowest and highest finite points
  std::unique_ptr<Target> target_;         ///< null when the displacement changed since the last registration
  /// The displaced target the last change of displacement retired: its memory serves the next one
  /// (a tall model's band is hundreds of megabytes, and fresh pages cost more than filling them).
  std::unique_ptr<Target> retired_;
  Eigen::VectorXd target_mean_;            ///< the target's displacement of every element (empty: the design)
  std::unique_ptr<AsBuiltMap> as_built_;
  std::size_t anchors_since_refresh_ = 0;
  /// Per element label of the BIM cloud: the centroid of its points (the pivot every displacement
  /// turns an element about; see element_pivots()), and the covariance of its displacement in the
  /// registration target (prior, or the as-built estimate at the last refresh). The covariances
  /// are there only when the anchors are weighed per element (anchor_from_elements).
  std::vector<Vector3d> element_pivot_;
  std::vector<Matrix6d> element_covariance_;
  ScanOdometry front_end_;
  PoseComposer composer_;
  Eigen::Isometry3d T_world_base0_;
  Pose2 first_front_pose_;
  Pose2 last_front_pose_;
  Pose2 last_odom_pose_;
  std::size_t front_frames_ = 0;  ///< frames the front end has matched
  std::size_t frame_index_ = 0;   ///< frames processed
};

}  // namespace plumb
