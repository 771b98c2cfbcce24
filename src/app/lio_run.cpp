// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/app/lio_run.hpp"

#include <algorithm>
#include <cmath>
#include <deque>
#include <optional>
#include <string>
#include <vector>

#include "plumb/app/run.hpp"
#include "plumb/core/error.hpp"
#include "plumb/core/parallel.hpp"
#include "plumb/core/prefetch.hpp"
#include "plumb/core/types.hpp"
#include "plumb/eval/metrics.hpp"

namespace plumb {
namespace {

// What the frame loop works from, read and checked before it.
struct LioInput {
  HybridLioSettings lio;  // the settings with the dump's sensor geometry
  FrameGroundTruth gt;
  bool imu = false;    // an IMU mode: imu.csv is read (checked whole in prepare())
  double sweep = 0.1;  // one LiDAR period [s]
};

// imu.csv fed to the estimator as the frames advance, holding only the samples a restart can
// still ask for: the run's memory does not grow with the length of the IMU log. What it hands
// out is what indexing the whole log would give.
class ImuFeed {
 public:
  explicit ImuFeed(std::optional<io::ImuCsvReader> reader) : reader_(std::move(reader)) {}

  // Every sample not handed out yet with a stamp <= t, in order.
  template <class F>
  void give_until(double t, F&& f) {
    for (;;) {
      if (next_ == kept_.size() && !read()) return;
      if (kept_[next_].stamp > t) return;
      f(kept_[next_++]);
    }
  }
  // Hand out from the first sample with a stamp >= t on (a restart; before or after the next one).
  void restart_at(double t) {
    next_ = static_cast<std::size_t>(
        std::lower_bound(kept_.begin(), kept_.end(), t, [](const ImuSample& a, double s) { return a.stamp < s; }) -
        kept_.begin());
    while (next_ == kept_.size() && read()) {
      if (kept_.back().stamp < t) {
        kept_.pop_back();
        next_ = kept_.size();
      }
    }
  }
  // Samples handed out with a stamp < t are dropped: no later restart_at() asks for them.
  void forget_before(double t) {
    while (next_ > 0 && kept_.front().stamp < t) {
      kept_.pop_front();
      --next_;
    }
  }

 private:
  bool read() {
    ImuSample m;
    if (!reader_ || !reader_->next(m)) return false;
    kept_.push_back(m);
    return true;
  }
  std::optional<io::ImuCsvReader> reader_;  // none in LioMode::kLoam
  std::deque<ImuSample> kept_;
  std::size_t next_ = 0;  // index in kept_ of the next sample to hand out
};

LioInput prepare(const io::FrameDumpReader& dump, const LioRunSettings& settings, LioRunReport& report) {
  PLUMB_CHECK(dump.num_frames() > 0, dump.dir() << ": the dump has no frame");
  const bool imu_mode = settings.lio.mode != LioMode::kLoam;
  PLUMB_CHECK(!imu_mode || dump.has_imu(),
              dump.dir() << ": the " << to_string(settings.lio.mode) << " mode needs imu.csv in the dump");
  LioInput in;
  in.lio = settings.lio;
  in.lio.T_base_lidar = dump.meta().T_base_lidar;
  in.lio.T_base_imu = dump.meta().T_base_imu;
  const std::vector<double>& elevations = dump.meta().lidar.elevations_rad;
  if (!elevations.empty()) {
    in.lio.features.image.vertical_angles_deg.clear();
    for (double e : elevations) in.lio.features.image.vertical_angles_deg.push_back(e * 180.0 / kPi);
  }
  const std::size_t n = settings.max_frames > 0 ? std::min(settings.max_frames, dump.num_frames()) : dump.num_frames();
  report.frames_requested = n;
  in.gt = read_frame_ground_truth(dump, n);
  report.has_ground_truth = in.gt.used;
  report.ground_truth_note = in.gt.note;
  if (in.gt.note == "too_short") {
    report.warnings.push_back(dump.dir() + "/gt.tum: " + std::to_string(in.gt.poses.size()) + " poses for " +
                              std::to_string(n) +
                              " frames; no accuracy report (RPE, APE, end error) and the start pose is the identity");
  }
  if (imu_mode) {
    // The whole file is checked before the first frame, so that a bad row stops the run before it
    // starts; the run itself then streams it.
    in.imu = true;
    io::ImuCsvReader check = dump.imu_reader();
    for (ImuSample m; check.next(m);) {
    }
  }
  const double rate = dump.meta().lidar.rate_hz;
  in.sweep = rate > 0.0 ? 1.0 / rate : 0.1;
  return in;
}

// HybridLio over frames [0, frames_requested): the trajectory and the per-frame results.
void track_frames(const io::FrameDumpReader& dump, const LioInput& in, const LioRunSettings& settings,
                  LioRunReport& report) {
  const std::size_t n = report.frames_requested;
  // Made at the first frame, and again at the next one while no frame has started the map: the
  // start pose is that of the frame that starts it.
  std::optional<HybridLio> lio;
  std::size_t first_frame = n;
  ImuFeed imu(in.imu ? std::optional<io::ImuCsvReader>(dump.imu_reader()) : std::nullopt);
  report.frames.reserve(n);
  // Reading frame i + 1 overlaps the estimator's work on frame i (with threads != 1).
  Prefetch<PointCloud> frames(settings.lio.threads, n, [&dump](std::size_t i) { return dump.frame(i); });
  for (std::size_t i = 0; i < n; ++i) {
    const double stamp = dump.stamp(i);
    // A restart at this frame or a later one looks back one sweep from its stamp at most.
    imu.forget_before(stamp - in.sweep);
    if (!lio) {
      lio.emplace(in.gt.used ? in.gt.poses.poses[i] : Eigen::Isometry3d::Identity(), in.lio);
      // A new estimator after a skipped first frame gets the IMU from one sweep before this frame on
      // (the first one gets all of it).
      if (i > 0) imu.restart_at(stamp - in.sweep);
    }
    // The IMU up to the end of this frame's sweep (what a live system has when the sweep is complete).
    imu.give_until(stamp + in.sweep + 0.02, [&lio](const ImuSample& m) { lio->add_imu(m); });
    LioFrameResult r;
    try {
      r = lio->process(frames.get(i), stamp);
    } catch (const std::exception& e) {
      // What was computed so far is kept: the caller writes it marked partial.
      if (first_frame == n) throw;
      report.partial = true;
      report.error = "frame " + std::to_string(i) + ": " + e.what();
      break;
    }
    if (lio->initialized() && first_frame == n) first_frame = i;
    if (!lio->initialized()) {
      report.imu_samples_dropped += lio->num_imu_dropped();
      lio.reset();
    }
    if (r.mode != LioFrameMode::kSkipped) report.trajectory.push_back(stamp, r.T_world_base);
    report.frames.push_back(r);
    if (settings.progress) settings.progress(i + 1, n);
  }
  PLUMB_CHECK(first_frame < n, dump.dir() << ": none of the " << n << " frames has the "
                                          << in.lio.features.min_init_points
                                          << " points needed to start the map (are the frame files empty?)");
  report.first_frame = first_frame;
  report.imu_samples_dropped += lio->num_imu_dropped();
}

// Counts, timing and feature means over the frames processed.
void summarize(LioRunReport& report) {
  std::vector<double> seconds;
  std::size_t planes = 0, structure = 0;
  for (const LioFrameResult& r : report.frames) {
    ++report.frames_per_mode[static_cast<std::size_t>(r.mode)];
    report.imu_gaps += r.imu_gap ? 1 : 0;
    report.not_converged += r.status == Status::kNotConverged ? 1 : 0;
    report.seconds_process += r.seconds;
    seconds.push_back(r.seconds);
    planes += r.num_plane_points;
    structure += r.num_structure_planes;
  }
  const std::size_t m = report.frames.size();
  if (m == 0) return;
  const auto frames = static_cast<double>(m);
  std::sort(seconds.begin(), seconds.end());
  report.mean_seconds_process = report.seconds_process / frames;
  report.median_seconds_process = seconds[m / 2];
  report.max_seconds_process = seconds.back();
  report.frames_per_second = report.seconds_process > 0.0 ? frames / report.seconds_process : 0.0;
  report.mean_plane_points = static_cast<double>(planes) / frames;
  report.mean_structure_planes = static_cast<double>(structure) / frames;
}

// The trajectory against gt.tum's poses of the same frames (no alignment: the run starts at the truth).
void measure_against_truth(LioRunReport& report, const Trajectory& truth) {
  Trajectory gt;
  for (std::size_t i = 0; i < report.frames.size(); ++i) {
    if (report.frames[i].mode != LioFrameMode::kSkipped) gt.push_back(truth.stamps[i], truth.poses[i]);
  }
  report.has_metrics = true;
  report.path_length = eval::path_lengths(gt).back();
  eval::ApeSettings ape;
  ape.align = eval::AlignMode::kNone;
  const eval::ApeResult full = eval::compute_ape(report.trajectory, gt, ape);
  report.ape_rmse = full.translation.stats.rmse;
  report.max_error = full.translation.stats.max;
  report.end_error = full.translation.values.back();
  ape.axes = eval::PositionAxes::kXY;
  report.end_error_xy = eval::compute_ape(report.trajectory, gt, ape).translation.values.back();

  eval::RpeSettings rpe_settings;
  rpe_settings.delta = 10.0;
  rpe_settings.unit = eval::DeltaUnit::kMeters;
  rpe_settings.pairs_along = eval::PathSource::kReference;
  const eval::RpeResult rpe = eval::compute_rpe(report.trajectory, gt, rpe_settings);
  if (rpe.status != Status::kOk) return;
  report.rpe_pairs = rpe.translation.stats.count;
  report.rpe_translation_mean = rpe.translation.stats.mean;
  report.rpe_translation_rmse = rpe.translation.stats.rmse;
  report.rpe_rotation_mean_deg = rpe.rotation_deg.stats.mean;
}

}  // namespace

LioRunReport run_lio(const io::FrameDumpReader& dump, const LioRunSettings& settings) {
  LioRunReport report;
  const LioInput in = prepare(dump, settings, report);
  track_frames(dump, in, settings, report);
  summarize(report);
  if (report.has_ground_truth && report.trajectory.size() >= 2) measure_against_truth(report, in.gt.poses);
  return report;
}

}  // namespace plumb
