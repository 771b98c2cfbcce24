// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/app/run.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "plumb/bim/bim_cloud.hpp"
#include "plumb/core/clock.hpp"
#include "plumb/core/deskew.hpp"
#include "plumb/core/error.hpp"
#include "plumb/core/parallel.hpp"
#include "plumb/core/prefetch.hpp"
#include "plumb/core/sensor_data.hpp"
#include "plumb/eval/metrics.hpp"

namespace plumb {
namespace {

double yaw_of(const Eigen::Isometry3d& T) { return std::atan2(T.linear()(1, 0), T.linear()(0, 0)); }

double horizontal_error(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return (a.translation() - b.translation()).head<2>().norm();
}

}  // namespace

FrameGroundTruth read_frame_ground_truth(const io::FrameDumpReader& dump, std::size_t frames) {
  FrameGroundTruth gt;
  if (!dump.has_ground_truth()) return gt;
  gt.poses = dump.ground_truth();
  gt.used = gt.poses.size() >= frames;
  gt.note = gt.used ? "used" : "too_short";
  for (std::size_t i = 0; gt.used && i < frames; ++i) {
    PLUMB_CHECK(!gt.poses.has_stamps() || std::abs(gt.poses.stamps[i] - dump.stamp(i)) < 1e-6,
                dump.dir() << "/gt.tum: pose " << i << " has stamp " << gt.poses.stamps[i] << ", frame " << i
                           << " has " << dump.stamp(i) << " (gt.tum holds one pose per frame)");
  }
  return gt;
}

namespace {

// The wheel odometry is the prior of every frame: a frame beyond its ends by more than one LiDAR
// period (a sample lost at the end of a recording is normal, a missing stretch is not) would be
// tracked with a frozen prior, so it is refused before any work.
void check_odometry_coverage(const io::FrameDumpReader& dump, const OdometryInterpolator& odom, std::size_t n,
                             RunReport& report) {
  const double rate = dump.meta().lidar.rate_hz;
  const double tolerance = rate > 0.0 ? 1.0 / rate : 0.1;
  const std::string odom_path = dump.dir() + "/odom.csv";
  for (std::size_t i = 0; i < n; ++i) {
    const double t = dump.stamp(i);
    PLUMB_CHECK(t >= odom.first_stamp() - tolerance,
                odom_path << ": the wheel odometry starts at " << odom.first_stamp() << " s, after frame " << i
                          << " (stamp " << t << " s; up to one LiDAR period, " << tolerance << " s, is tolerated)");
    PLUMB_CHECK(t <= odom.last_stamp() + tolerance,
                odom_path << ": the wheel odometry ends at " << odom.last_stamp() << " s, before frame " << i
                          << " (stamp " << t << " s) and the " << (n - 1 - i)
                          << " frames after it (up to one LiDAR period, " << tolerance
                          << " s, is tolerated; --max-frames " << i << " processes the frames it covers)");
    if (t < odom.first_stamp() || t > odom.last_stamp()) ++report.odometry_clamped_frames;
  }
  if (report.odometry_clamped_frames > 0) {
    report.warnings.push_back(odom_path + ": " + std::to_string(report.odometry_clamped_frames) +
                              " frame(s) lie just outside the wheel odometry's span; their prior is the nearest sample");
  }
}

// Frame i of the dump, deskewed with the wheel odometry when the settings ask for it.
struct FrameSource {
  const io::FrameDumpReader& dump;
  const OdometryInterpolator& odom;
  bool deskew;

  PointCloud operator()(std::size_t i) const {
    PointCloud f = dump.frame(i);
    if (deskew) {
      deskew_frame(f, dump.stamp(i), dump.meta().T_base_lidar, [&](double t) { return odom.at(t).to_isometry(); });
    }
    return f;
  }
};

// The first frame is localized again from the frames after it (RunSettings::start_search_distance):
// the front end alone chains their motion from frame 0, and a frame joins the views every
// start_view_spacing of its path. Stops at the first kOk, at the distance or at the end of the frames;
// report.localization is the last try.
void localize_while_driving(const io::FrameDumpReader& dump, const OdometryInterpolator& odom,
                            const FrameSource& frame_at, const BimLocalizer& localizer,
                            const std::shared_ptr<const PointCloud>& bim_cloud, const PointCloud& first_frame,
                            const std::optional<Vector2d>& hint, const RunSettings& settings, RunReport& report) {
  BimOdometrySettings os = settings.odometry;
  os.T_base_lidar = dump.meta().T_base_lidar;
  os.threads = 1;  // only its front end runs
  os.estimate_as_built = false;
  BimOdometry front(bim_cloud, Eigen::Isometry3d::Identity(), os);
  std::vector<PointCloud> later;  // the frames of views 1, 2, ...
  std::vector<Eigen::Isometry3d> motions;
  double path = 0.0, last_view = 0.0;
  Eigen::Isometry3d previous = Eigen::Isometry3d::Identity();
  for (std::size_t i = 0; i < report.frames_requested; ++i) {
    PointCloud frame = i == 0 ? PointCloud{} : frame_at(i);
    BimFrameInput input = front.prepare_scan(i == 0 ? first_frame : frame, dump.stamp(i), i);
    front.front_end(input, odom.at(dump.stamp(i)));
    report.localization_frames = i + 1;
    const Eigen::Isometry3d T = input.front->T_world_base_uncorrected;
    path += (T.translation() - previous.translation()).head<2>().norm();
    previous = T;
    if (path > settings.start_search_distance) break;
    if (i == 0 || path - last_view < settings.start_view_spacing) continue;
    last_view = path;
    later.push_back(std::move(frame));
    motions.push_back(T);
    std::vector<LocalizerView> views{LocalizerView{&first_frame, Eigen::Isometry3d::Identity()}};
    for (std::size_t v = 0; v < later.size(); ++v) views.push_back(LocalizerView{&later[v], motions[v]});
    report.localization = localizer.localize(views, dump.meta().T_base_lidar, hint, settings.start_hint_radius);
    report.localization_distance = path;
    if (report.localization.status == Status::kOk) break;
    if (report.localization.ambiguous) report.ambiguous_localization = report.localization;
  }
}

// Liu et al. 2022, sec. 1: the first frame in the BIM, given or localized (from more frames when
// it alone is not enough). Returns the first frame when localizing read it, for the first step of
// the frame loop.
std::optional<PointCloud> place_first_frame(const io::FrameDumpReader& dump, const bim::BimMesh& mesh,
                                            const std::shared_ptr<const PointCloud>& bim_cloud,
                                            const OdometryInterpolator& odom, const FrameSource& frame_at,
                                            const RunSettings& settings, RunReport& report) {
  const auto t_loc = std::chrono::steady_clock::now();
  std::optional<PointCloud> first_frame;
  if (settings.initial_pose) {
    report.T_world_base0 = *settings.initial_pose;
  } else {
    report.localized = true;
    first_frame = frame_at(0);
    std::optional<Vector2d> hint;
    if (settings.start_hint) {
      PLUMB_CHECK(settings.start_hint->allFinite() && settings.start_hint_radius > 0.0,
                  "run_bim_odometry: the start hint must be finite and its radius > 0");
      hint = settings.start_hint->head<2>();
    }
    const BimLocalizer localizer(mesh, *bim_cloud, settings.localizer);
    report.localization = localizer.localize(*first_frame, dump.meta().T_base_lidar, hint, settings.start_hint_radius);
    report.localization_frames = 1;
    if (report.localization.ambiguous) report.ambiguous_localization = report.localization;
    if (report.localization.status != Status::kOk && settings.start_search_distance > 0.0) {
      localize_while_driving(dump, odom, frame_at, localizer, bim_cloud, *first_frame, hint, settings, report);
    }
    if (report.localization.status == Status::kOk) report.ambiguous_localization.reset();
    report.localization_status = report.localization.status;
    report.T_world_base0 = report.localization.T_world_base;
  }
  report.seconds_localize = seconds_since(t_loc);
  return first_frame;
}

// Frames [0, n) through `odometry`, `take(i, result)` called for each in frame order. With threads, a
// pipeline of three stages: reading and deskewing a frame, its cut to a planar scan and the front
// end's match; the frame's key points (they depend on the frame alone); its BIM correction. Each
// stage sees the frames in order: the results of a serial loop. Each stage runs up to kStageDepth
// frames ahead of the next: a stage's cost varies from frame to frame (the registration's rounds,
// the scan's points), and with one frame of slack the stages kept waiting for each other
// (docs/results.md, "Threads": the two-thread speed-up against the depth). A frame that fails
// throws, after `take` has had the frames before it.
template <class Take>
void drive(BimOdometry& odometry, const io::FrameDumpReader& dump, const OdometryInterpolator& odom,
           const FrameSource& frame_at, std::optional<PointCloud> first_frame, std::size_t n, int threads,
           Take&& take) {
  constexpr std::size_t kStageDepth = 3;
  struct Matched {
    PointCloud frame;
    BimFrameInput input;
  };
  Prefetch<Matched> matched(threads, n, [&](std::size_t i) {
    Matched m;
    m.frame = (i == 0 && first_frame) ? std::move(*first_frame) : frame_at(i);
    m.input = odometry.prepare_scan(m.frame, dump.stamp(i), i);
    odometry.front_end(m.input, odom.at(dump.stamp(i)));
    return m;
  }, kStageDepth);
  Prefetch<BimFrameInput> frames(threads, n, [&](std::size_t i) {
    Matched m = matched.get(i);
    odometry.add_key_points(m.input, m.frame);
    return std::move(m.input);
  }, kStageDepth);
  for (std::size_t i = 0; i < n; ++i) take(i, odometry.process(frames.get(i), odom.at(dump.stamp(i))));
}

// BimOdometry over frames [0, n): the three trajectories, the counts and the timing of the report,
// the deviation report when the as-built is estimated, and with refine_as_built the second pass.
void track_frames(const io::FrameDumpReader& dump, const bim::BimMesh& mesh, const OdometryInterpolator& odom,
                  const FrameSource& frame_at, const std::shared_ptr<const PointCloud>& bim_cloud,
                  std::optional<PointCloud> first_frame, const RunSettings& settings, RunReport& report) {
  const std::size_t n = report.frames_requested;
  BimOdometrySettings os = settings.odometry;
  os.T_base_lidar = dump.meta().T_base_lidar;
  // With threads, two of them prepare and match the next frames (drive()) all the time; the
  // odometry's own parallel work (the registration's search) gets the others, if any.
  if (settings.odometry.threads != 1) os.threads = std::max(1, resolve_thread_count(settings.odometry.threads) - 2);
  BimOdometry odometry(bim_cloud, report.T_world_base0, os);
  const bool refine = settings.refine_as_built && odometry.as_built() != nullptr;
  const std::size_t progress_total = refine ? 2 * n : n;  // the second pass reads every frame again
  const Pose2 odom0 = odom.at(dump.stamp(0));
  const auto t_frames = std::chrono::steady_clock::now();
  try {
    drive(odometry, dump, odom, frame_at, std::move(first_frame), n, settings.odometry.threads,
          [&](std::size_t i, BimFrameResult r) {
            const double stamp = dump.stamp(i);
            report.wheel.push_back(stamp, report.T_world_base0 * odom0.ominus().oplus(odom.at(stamp)).to_isometry());
            report.lidar.push_back(stamp, r.T_world_base_uncorrected);
            report.bim.push_back(stamp, r.T_world_base);
            report.anchors_attempted += r.anchor_attempted ? 1 : 0;
            report.anchors_accepted += r.anchor.decision == AnchorDecision::kAccepted ? 1 : 0;
            report.anchors_rejected += r.anchor.decision == AnchorDecision::kRejected ? 1 : 0;
            report.fallbacks += r.mode == ScanMatchMode::kFallback ? 1 : 0;
            report.frames.push_back(std::move(r));
            if (settings.progress) settings.progress(i + 1, progress_total);
          });
  } catch (const std::exception& e) {
    // What was computed so far is kept: the caller writes it marked partial.
    if (report.frames.empty()) throw;
    report.partial = true;
    report.error = std::string("frame ") + std::to_string(report.frames.size()) + ": " + e.what();
  }
  report.seconds_frames = seconds_since(t_frames);
  if (odometry.as_built() != nullptr) {
    report.deviation_tolerance = settings.deviation_tolerance;
    report.deviations = deviation_report(*odometry.as_built(), mesh, settings.deviation_tolerance);
  }
  const std::size_t m = report.frames.size();  // n, or fewer when the run stopped early
  report.frames_per_second = report.seconds_frames > 0 ? static_cast<double>(m) / report.seconds_frames : 0.0;
  for (const BimFrameResult& f : report.frames) {
    report.mean_seconds_front_end += f.seconds_front_end / static_cast<double>(m);
    report.mean_seconds_segment += f.seconds_segment / static_cast<double>(m);
    report.mean_seconds_icp += f.seconds_icp / static_cast<double>(m);
    report.mean_seconds_process += f.seconds_total / static_cast<double>(m);
  }
  if (m > 0) {
    std::vector<double> seconds(m);
    for (std::size_t i = 0; i < m; ++i) {
      seconds[i] = report.frames[i].seconds_total;
      if (seconds[i] > seconds[report.slowest_frame]) report.slowest_frame = i;
    }
    report.max_seconds_process = seconds[report.slowest_frame];
    std::nth_element(seconds.begin(), seconds.begin() + static_cast<std::ptrdiff_t>(m / 2), seconds.end());
    report.median_seconds_process = seconds[m / 2];
  }
  if (!refine || report.partial) return;
  // The second pass: the same frames from the same start, registered to the building as estimated
  // at the end of the first, so that the first frames' poses know what the whole run learnt.
  const auto t_refine = std::chrono::steady_clock::now();
  BimOdometrySettings rs = os;
  rs.estimate_as_built = false;
  try {
    BimOdometry second(bim_cloud, report.T_world_base0, rs);
    second.register_to(*odometry.as_built());
    drive(second, dump, odom, frame_at, std::nullopt, m, settings.odometry.threads,
          [&](std::size_t i, const BimFrameResult& r) {
            report.bim_refined.push_back(r.stamp, r.T_world_base);
            if (settings.progress) settings.progress(n + i + 1, progress_total);
          });
  } catch (const std::exception& e) {
    report.bim_refined = Trajectory{};
    report.warnings.push_back(std::string("the second pass over the building as estimated failed, no refined "
                                          "trajectory: ") + e.what());
  }
  report.seconds_refine = seconds_since(t_refine);
}

// Liu et al. 2022, Table 2, the APE and the registrations' own error, all horizontal and without
// alignment (every trajectory is in the BIM frame already), against the first frames.size() poses of `truth`.
void measure_against_truth(RunReport& report, const Trajectory& truth) {
  const std::size_t m = report.frames.size();
  Trajectory gt;  // pose i at frame i, as the trajectories
  for (std::size_t i = 0; i < m; ++i) gt.push_back(report.bim.stamps[i], truth.poses[i]);
  const std::vector<double> dist = eval::path_lengths(gt, eval::PositionAxes::kXY);
  report.path_length = dist.back();
  std::vector<std::size_t> rows;  // P1, P2 at 1/3 and 2/3 of the path, the end
  for (int k = 1; k <= 2; ++k) {
    const double target = report.path_length * k / 3.0;
    const auto i = static_cast<std::size_t>(std::lower_bound(dist.begin(), dist.end(), target) - dist.begin());
    rows.push_back(std::min(i, m - 1));
  }
  rows.push_back(m - 1);
  eval::DriftSettings drift;
  drift.axes = eval::PositionAxes::kXY;
  const std::vector<eval::DriftSample> wheel = eval::drift_at(report.wheel, gt, rows, drift);
  const std::vector<eval::DriftSample> lidar = eval::drift_at(report.lidar, gt, rows, drift);
  const std::vector<eval::DriftSample> bim = eval::drift_at(report.bim, gt, rows, drift);
  const std::vector<eval::DriftSample> refined =
      report.bim_refined.empty() ? std::vector<eval::DriftSample>{} : eval::drift_at(report.bim_refined, gt, rows, drift);
  for (std::size_t k = 0; k < rows.size(); ++k) {
    ObservationRow row;
    row.name = k + 1 < rows.size() ? "P" + std::to_string(k + 1) : "end";
    row.frame = rows[k];
    row.distance = bim[k].path_length;
    row.error_wheel = wheel[k].error;
    row.error_lidar = lidar[k].error;
    row.error_bim = bim[k].error;
    if (!refined.empty()) row.error_refined = refined[k].error;
    report.table.push_back(row);
  }

  eval::ApeSettings ape;
  ape.align = eval::AlignMode::kNone;
  ape.axes = eval::PositionAxes::kXY;
  const auto error_stats = [&](const Trajectory& t, const Trajectory& ref) {
    return eval::compute_ape(t, ref, ape).translation.stats;
  };
  const eval::ErrorStats e_wheel = error_stats(report.wheel, gt);
  const eval::ErrorStats e_lidar = error_stats(report.lidar, gt);
  const eval::ErrorStats e_bim = error_stats(report.bim, gt);
  report.ape_rmse_wheel = e_wheel.rmse;
  report.ape_rmse_lidar = e_lidar.rmse;
  report.ape_rmse_bim = e_bim.rmse;
  report.max_error_wheel = e_wheel.max;
  report.max_error_lidar = e_lidar.max;
  report.max_error_bim = e_bim.max;
  if (!report.bim_refined.empty()) {
    const eval::ErrorStats e_refined = error_stats(report.bim_refined, gt);
    report.ape_rmse_refined = e_refined.rmse;
    report.max_error_refined = e_refined.max;
  }

  Trajectory registered, registered_gt;
  for (std::size_t i = 0; i < m; ++i) {
    if (!report.frames[i].registered) continue;
    registered.push_back(gt.stamps[i], report.frames[i].T_world_base_registered);
    registered_gt.push_back(gt.stamps[i], gt.poses[i]);
  }
  if (registered.empty()) return;
  const eval::ErrorStats e_reg = error_stats(registered, registered_gt);
  report.registrations = e_reg.count;
  report.registration_error_rms = e_reg.rmse;
  report.registration_error_max = e_reg.max;
}

}  // namespace

RunReport run_bim_odometry(const io::FrameDumpReader& dump, const bim::BimMesh& mesh, const RunSettings& settings) {
  PLUMB_CHECK(dump.num_frames() > 0, dump.dir() << ": the dump has no frame");
  PLUMB_CHECK(dump.has_odometry(), dump.dir() << ": the dump has no odom.csv (wheel odometry is the front end's prior)");
  PLUMB_CHECK(mesh.num_triangles() > 0, "run_bim_odometry: the model has no geometry");
  PLUMB_CHECK(settings.deviation_tolerance > 0.0 && std::isfinite(settings.deviation_tolerance),
              "run_bim_odometry: deviation_tolerance must be positive, got " << settings.deviation_tolerance);
  PLUMB_CHECK(settings.start_search_distance >= 0.0 && std::isfinite(settings.start_search_distance) &&
                  settings.start_view_spacing > 0.0 && std::isfinite(settings.start_view_spacing),
              "run_bim_odometry: start_search_distance must be >= 0 and start_view_spacing > 0, got "
                  << settings.start_search_distance << " and " << settings.start_view_spacing);
  RunReport report;
  const OdometryInterpolator odom(dump.odometry());
  auto bim_cloud = std::make_shared<const PointCloud>(bim::sample_bim_cloud(mesh, settings.bim_spacing));
  report.bim_points = bim_cloud->size();
  const std::size_t n = settings.max_frames > 0 ? std::min(settings.max_frames, dump.num_frames()) : dump.num_frames();
  report.frames_requested = n;
  check_odometry_coverage(dump, odom, n, report);

  const FrameSource frame_at{dump, odom, settings.deskew};
  std::optional<PointCloud> first_frame = place_first_frame(dump, mesh, bim_cloud, odom, frame_at, settings, report);
  const FrameGroundTruth gt = read_frame_ground_truth(dump, n);
  report.has_ground_truth = gt.used;
  report.ground_truth_note = gt.note;
  if (gt.note == "too_short") {
    report.warnings.push_back(dump.dir() + "/gt.tum: " + std::to_string(gt.poses.size()) + " poses for " +
                              std::to_string(n) + " frames; no accuracy report (Table 2, APE) for this run");
  }
  if (report.has_ground_truth) {
    const Eigen::Isometry3d& T0 = gt.poses.poses[0];
    report.initial_error_xy = horizontal_error(report.T_world_base0, T0);
    report.initial_error_yaw_deg = std::abs(std::remainder(yaw_of(report.T_world_base0) - yaw_of(T0), 2 * M_PI)) * 180.0 / M_PI;
  }
  if (report.localization_status != Status::kOk) return report;

  track_frames(dump, mesh, odom, frame_at, bim_cloud, std::move(first_frame), settings, report);
  if (report.has_ground_truth) measure_against_truth(report, gt.poses);
  return report;
}

}  // namespace plumb
