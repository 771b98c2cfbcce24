// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief The BIM-corrected odometry over a frame dump (what `plumb run` does): BIM cloud from the
///        model, initial localization of the first frame, per-frame BimOdometry with the wheel
///        odometry as prior and for deskewing, and, when the dump has ground truth, the error table
///        of Liu et al. 2022, Table 2 (error at observation points as % of the distance travelled)
///        per method, measured with plumb::eval. Its LiDAR/IMU counterpart is run_lio() (lio_run.hpp).

#include <functional>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "plumb/bim/mesh.hpp"
#include "plumb/core/trajectory.hpp"
#include "plumb/io/frame_dump.hpp"
#include "plumb/pipeline/bim_localizer.hpp"
#include "plumb/pipeline/bim_odometry.hpp"
#include "plumb/registration/localize.hpp"

namespace plumb {

/// @brief Settings of run_bim_odometry().
struct RunSettings {
  BimOdometrySettings odometry;     ///< T_base_lidar is taken from the dump's meta.json
  double bim_spacing = 0.05;        ///< BIM cloud point spacing [m]
  /// Initial pose of the base in the BIM frame. Empty: localize the first frame in the building
  /// (BimLocalizer: floor-plan search, then the overlap-gated ICP of Liu et al. 2022, sec. 1.3).
  std::optional<Eigen::Isometry3d> initial_pose;
  BimLocalizerSettings localizer;   ///< initial localization
  /// Rough start position of the base in the BIM frame (x, y; z ignored), e.g. the room the robot
  /// starts in: the localization only considers poses within start_hint_radius of it.
  std::optional<Eigen::Vector3d> start_hint;
  double start_hint_radius = 3.0;   ///< [m]
  /// When the first frame alone is not localized (look-alike rooms, mirrored flats, a frame facing
  /// open space or a crowd), the robot's next frames are added, one every start_view_spacing of the
  /// front end's path, and the first frame is localized again from all of them (BimLocalizer with
  /// LocalizerView), until it is or the front end has covered start_search_distance; the
  /// trajectory still starts at frame 0. 0 = the first frame alone decides. [m]
  double start_search_distance = 15.0;
  double start_view_spacing = 1.0;  ///< [m], > 0
  bool deskew = true;               ///< undo motion distortion with the wheel odometry and per-point times
  std::size_t max_frames = 0;       ///< 0 = all
  /// Construction tolerance the as-built deviations are judged against (odometry.estimate_as_built) [m].
  double deviation_tolerance = 0.02;
  /// With odometry.estimate_as_built: after the run, a second pass registers every frame again, from
  /// the same start, to the building as estimated at the end of the run (BimOdometry::register_to),
  /// so that the first frames' poses know what the whole run learnt: RunReport::bim_refined. An
  /// offline result (the frames are read and processed twice); not done for a partial run.
  bool refine_as_built = false;
  /// Called after each frame; with refine_as_built `total` is twice the frames, the second pass
  /// counting on from the first.
  std::function<void(std::size_t done, std::size_t total)> progress;
};

/// @brief One row of Liu et al. 2022, Table 2.
struct ObservationRow {
  std::string name;           ///< "P1", "P2", "end"
  std::size_t frame = 0;
  double distance = 0.0;      ///< distance travelled (ground truth) [m]
  double error_wheel = 0.0, error_lidar = 0.0, error_bim = 0.0;  ///< horizontal position error [m]
  double error_refined = 0.0;  ///< of RunReport::bim_refined, when there is one [m]
};

/// @brief Everything a run produced.
struct RunReport {
  Trajectory wheel;  ///< nominal wheel odometry anchored at the initial pose, BIM frame, frame stamps
  Trajectory lidar;  ///< front end without BIM corrections
  Trajectory bim;    ///< corrected
  /// With RunSettings::refine_as_built: the second pass's trajectory, registered to the building as
  /// estimated at the end of the run (empty otherwise, or when that pass failed: see `warnings`).
  Trajectory bim_refined;
  std::vector<BimFrameResult> frames;
  std::size_t frames_requested = 0;     ///< frames the run was to process (max_frames or the whole dump)
  /// A frame failed (e.g. an unreadable frame file) after others were processed: the report covers
  /// frames [0, frames.size()) and `error` says what stopped the run. A failure before any frame
  /// result is thrown instead.
  bool partial = false;
  std::string error;
  /// Data problems that did not stop the run (odometry clamped at its ends, gt.tum too short), for
  /// the caller to show.
  std::vector<std::string> warnings;
  /// Frames whose stamp lies outside odom.csv's span by less than one LiDAR period (the wheel pose
  /// is held at the nearest sample); farther outside is an error.
  std::size_t odometry_clamped_frames = 0;
  bool localized = false;               ///< the initial pose came from BimLocalizer
  Status localization_status = Status::kOk;
  BimLocalization localization;         ///< when localized: the last try (views: the frames it used)
  double localization_distance = 0.0;  ///< front-end path from frame 0 to the last view used [m]
  /// When the localization failed and some try found two places fitting about as well: the last
  /// such try (its T_world_base_search and T_world_base_second are the two places).
  std::optional<BimLocalization> ambiguous_localization;
  std::size_t localization_frames = 0;  ///< frames read to localize (1: the first frame decided)
  Eigen::Isometry3d T_world_base0 = Eigen::Isometry3d::Identity();
  std::size_t bim_points = 0;
  std::size_t anchors_accepted = 0, anchors_rejected = 0, anchors_attempted = 0;
  std::size_t fallbacks = 0;            ///< front-end frames that fell back to the wheel prior
  double seconds_localize = 0.0, seconds_frames = 0.0;
  double seconds_refine = 0.0;          ///< the second pass (RunSettings::refine_as_built) [s]
  double frames_per_second = 0.0;       ///< frames / seconds_frames (reading and deskewing included)
  /// Mean per-frame time of BimOdometry::process() and its parts [s] (reading frames excluded).
  double mean_seconds_front_end = 0.0, mean_seconds_segment = 0.0, mean_seconds_icp = 0.0, mean_seconds_process = 0.0;
  /// BimOdometry::process() per frame: the median (the upper one of an even count) and the
  /// largest, and the frame that took it. A frame that takes up a new as-built estimate (every
  /// as_built_refresh_every anchors) does that work within its own process(): on a large model
  /// the largest is a refresh, the stall a robot waiting for that pose sees. All three are 0 when
  /// no frame was processed (check `frames` first).
  double median_seconds_process = 0.0, max_seconds_process = 0.0;
  std::size_t slowest_frame = 0;
  // With ground truth (gt.tum):
  bool has_ground_truth = false;
  std::string ground_truth_note = "absent";  ///< "used", "absent" (no gt.tum) or "too_short" (fewer poses than frames)
  double initial_error_xy = 0.0, initial_error_yaw_deg = 0.0;
  std::vector<ObservationRow> table;    ///< observation points at 1/3, 2/3 of the path and the end
  double path_length = 0.0;             ///< distance travelled, horizontal (ground truth) [m]
  /// eval::compute_ape() of each trajectory against the truth, horizontal (PositionAxes::kXY), no
  /// alignment: the RMS and the largest error [m].
  double ape_rmse_wheel = 0.0, ape_rmse_lidar = 0.0, ape_rmse_bim = 0.0;
  double max_error_wheel = 0.0, max_error_lidar = 0.0, max_error_bim = 0.0;  ///< see ape_rmse_wheel [m]
  double ape_rmse_refined = 0.0, max_error_refined = 0.0;  ///< of bim_refined, when there is one [m]
  /// Horizontal error of the BIM registrations alone (BimFrameResult::T_world_base_registered) against
  /// the truth, over the frames that registered: how well the model itself places the robot. With
  /// as-built deviations (the simulator's walls are shifted and turned) this bounds the corrected pose.
  std::size_t registrations = 0;
  double registration_error_rms = 0.0, registration_error_max = 0.0;  ///< [m]
  /// With odometry.estimate_as_built: the deviation report, one row per element of the BIM cloud.
  std::vector<DeviationReportRow> deviations;
  double deviation_tolerance = 0.0;     ///< the tolerance the rows were judged against [m]
};

/// @brief A frame dump's ground truth (gt.tum) for the frames a driver processes.
struct FrameGroundTruth {
  Trajectory poses;             ///< gt.tum as read, pose i at frame i's stamp (empty without gt.tum)
  bool used = false;            ///< gt.tum covers the frames: the driver measures against it
  std::string note = "absent";  ///< "used", "absent" (no gt.tum) or "too_short" (fewer poses than frames)
};

/// @brief Read gt.tum for the first `frames` frames of `dump`, one pose per frame.
/// @throws plumb::Error when gt.tum is malformed, or when it covers the frames but the stamp of one of
///         the first `frames` poses differs from its frame's by 1e-6 s or more (the message names both)
FrameGroundTruth read_frame_ground_truth(const io::FrameDumpReader& dump, std::size_t frames);

/// @brief Run the BIM-corrected odometry over a frame dump (see the file comment).
/// @return the report; the localization failing gives localization_status != kOk and no trajectory
/// @throws plumb::Error for a dump without odom.csv, odom.csv not covering a frame to be processed
///         (beyond one LiDAR period, 1 / meta rate_hz, 0.1 s when unknown; the message names odom.csv
///         and the first frame stamp it misses), a model without geometry, or a failure before any
///         frame result (a later failure gives a partial report, see RunReport::partial)
RunReport run_bim_odometry(const io::FrameDumpReader& dump, const bim::BimMesh& mesh, const RunSettings& settings = {});

}  // namespace plumb
