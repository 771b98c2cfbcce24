// SPDX-License-Identifier: BSD-3-Clause
// Pipelines fed one frame at a time: BimOdometry, BimLocalizer, HybridLio.
#include <memory>
#include <optional>
#include <vector>

#include <pybind11/eigen.h>
#include <pybind11/stl.h>

#include "convert.hpp"
#include "plumb/core/error.hpp"
#include "plumb/bim/mesh.hpp"
#include "plumb/pipeline/as_built.hpp"
#include "plumb/pipeline/bim_localizer.hpp"
#include "plumb/pipeline/bim_odometry.hpp"
#include "plumb/pipeline/hybrid_lio.hpp"
#include "plumb/pipeline/pose_composer.hpp"

namespace plumb::python {
namespace {

std::shared_ptr<const PointCloud> shared_cloud(const py::object& cloud, const char* what) {
  return std::make_shared<const PointCloud>(cloud_from_object(cloud, what));
}

void bind_bim_odometry_types(py::module_& m) {
  py::enum_<ScanMatchMode>(m, "ScanMatchMode", "Outcome of the scan-matching front end for one frame.")
      .value("initial", ScanMatchMode::kInitial)
      .value("matched", ScanMatchMode::kMatched)
      .value("degenerate", ScanMatchMode::kDegenerate)
      .value("prior_free", ScanMatchMode::kPriorFree)
      .value("fallback", ScanMatchMode::kFallback);
  py::enum_<AnchorDecision>(m, "AnchorDecision", "What the pose composer did with a BIM anchor.")
      .value("accepted", AnchorDecision::kAccepted)
      .value("rejected", AnchorDecision::kRejected)
      .value("ignored", AnchorDecision::kIgnored);
  py::class_<AnchorResult>(m, "AnchorResult", "The pose composer's decision on one anchor.")
      .def_readonly("decision", &AnchorResult::decision)
      .def_readonly("mahalanobis_sq", &AnchorResult::mahalanobis_sq)
      .def_readonly("gate", &AnchorResult::gate)
      .def_readonly("dof", &AnchorResult::dof)
      .def_readonly("innovation", &AnchorResult::innovation)
      .def_readonly("correction", &AnchorResult::correction)
      .def_readonly("inflated", &AnchorResult::inflated);

  py::class_<AsBuiltSettings>(m, "AsBuiltSettings",
                              "Settings of the as-built estimate (construction tolerance as the elements' prior, ...).")
      .def(py::init<>())
      .def_readwrite("sigma_translation", &AsBuiltSettings::sigma_translation)
      .def_readwrite("sigma_rotation", &AsBuiltSettings::sigma_rotation)
      .def_readwrite("point_sigma", &AsBuiltSettings::point_sigma)
      .def_readwrite("max_points_per_element", &AsBuiltSettings::max_points_per_element)
      .def_readwrite("pose_sigma_translation", &AsBuiltSettings::pose_sigma_translation)
      .def_readwrite("pose_sigma_rotation", &AsBuiltSettings::pose_sigma_rotation)
      .def_readwrite("max_residual", &AsBuiltSettings::max_residual)
      .def_readwrite("outlier_distance", &AsBuiltSettings::outlier_distance)
      .def_readwrite("junction_radius", &AsBuiltSettings::junction_radius)
      .def_readwrite("decorrelation_distance", &AsBuiltSettings::decorrelation_distance);

  py::enum_<DeviationStatus>(m, "DeviationStatus", "What the deviation report says of one element.")
      .value("ok", DeviationStatus::kOk)
      .value("deviates", DeviationStatus::kDeviates)
      .value("unobserved", DeviationStatus::kUnobserved);
  py::class_<DeviationReportRow>(m, "DeviationReportRow",
                                 "One element of the deviation report (the rows of plumb run's deviations.csv).")
      .def_readonly("element", &DeviationReportRow::element)
      .def_readonly("global_id", &DeviationReportRow::global_id)
      .def_readonly("type", &DeviationReportRow::type)
      .def_readonly("name", &DeviationReportRow::name)
      .def_readonly("storey", &DeviationReportRow::storey)
      .def_readonly("observations", &DeviationReportRow::observations)
      .def_readonly("normal", &DeviationReportRow::normal)
      .def_readonly("point", &DeviationReportRow::point)
      .def_readonly("offset_m", &DeviationReportRow::offset_m)
      .def_readonly("sigma_m", &DeviationReportRow::sigma_m)
      .def_readonly("rotation_deg", &DeviationReportRow::rotation_deg)
      .def_readonly("status", &DeviationReportRow::status);

  py::class_<BimOdometrySettings> s(m, "BimOdometrySettings",
                                    "Settings of BimOdometry (the C++ defaults); the front end, segmentation and "
                                    "composer sub-settings keep their C++ defaults.");
  s.def(py::init<>())
      .def_readwrite("scan_band", &BimOdometrySettings::scan_band)
      .def_readwrite("scan_angle_increment", &BimOdometrySettings::scan_angle_increment)
      .def_readwrite("scan_range_min", &BimOdometrySettings::scan_range_min)
      .def_readwrite("scan_range_max", &BimOdometrySettings::scan_range_max)
      .def_readwrite("motion_sigma_xy", &BimOdometrySettings::motion_sigma_xy)
      .def_readwrite("motion_sigma_theta", &BimOdometrySettings::motion_sigma_theta)
      .def_readwrite("fallback_sigma_xy", &BimOdometrySettings::fallback_sigma_xy)
      .def_readwrite("fallback_sigma_theta", &BimOdometrySettings::fallback_sigma_theta)
      .def_readwrite("wheel_tolerance_xy", &BimOdometrySettings::wheel_tolerance_xy)
      .def_readwrite("wheel_tolerance_theta", &BimOdometrySettings::wheel_tolerance_theta)
      .def_readwrite("wheel_tolerance_ratio", &BimOdometrySettings::wheel_tolerance_ratio)
      .def_readwrite("use_bim", &BimOdometrySettings::use_bim)
      .def_readwrite("correct_every", &BimOdometrySettings::correct_every)
      .def_readwrite("key_point_voxel", &BimOdometrySettings::key_point_voxel)
      .def_readwrite("icp", &BimOdometrySettings::icp)
      .def_readwrite("threads", &BimOdometrySettings::threads)
      .def_readwrite("refresh_threads", &BimOdometrySettings::refresh_threads)
      .def_readwrite("min_anchor_overlap", &BimOdometrySettings::min_anchor_overlap)
      .def_readwrite("min_anchor_inliers", &BimOdometrySettings::min_anchor_inliers)
      .def_readwrite("anchor_sigma", &BimOdometrySettings::anchor_sigma)
      .def_readwrite("anchor_effective_points", &BimOdometrySettings::anchor_effective_points)
      .def_readwrite("anchor_rank_threshold", &BimOdometrySettings::anchor_rank_threshold)
      .def_readwrite("anchor_length", &BimOdometrySettings::anchor_length)
      .def_readwrite("anchor_from_elements", &BimOdometrySettings::anchor_from_elements)
      .def_readwrite("initial_covariance", &BimOdometrySettings::initial_covariance)
      .def_readwrite("estimate_as_built", &BimOdometrySettings::estimate_as_built)
      .def_readwrite("as_built", &BimOdometrySettings::as_built)
      .def_readwrite("as_built_refresh_every", &BimOdometrySettings::as_built_refresh_every)
      .def_readwrite("target_band_margin", &BimOdometrySettings::target_band_margin);
  def_pose(s, "T_base_lidar", &BimOdometrySettings::T_base_lidar, true);

  py::class_<BimFrameResult> r(m, "BimFrameResult", "What BimOdometry.process() did with one frame.");
  r.def_readonly("stamp", &BimFrameResult::stamp)
      .def_readonly("mode", &BimFrameResult::mode)
      .def_readonly("scan_status", &BimFrameResult::scan_status)
      .def_readonly("anchor_attempted", &BimFrameResult::anchor_attempted)
      .def_readonly("icp_status", &BimFrameResult::icp_status)
      .def_readonly("icp_overlap", &BimFrameResult::icp_overlap)
      .def_readonly("icp_inliers", &BimFrameResult::icp_inliers)
      .def_readonly("target_points", &BimFrameResult::target_points)
      .def_readonly("num_key_points", &BimFrameResult::num_key_points)
      .def_readonly("anchor_dof", &BimFrameResult::anchor_dof)
      .def_readonly("registered", &BimFrameResult::registered)
      .def_readonly("anchor", &BimFrameResult::anchor)
      .def_readonly("as_built_pairs", &BimFrameResult::as_built_pairs)
      .def_readonly("seconds_front_end", &BimFrameResult::seconds_front_end)
      .def_readonly("seconds_segment", &BimFrameResult::seconds_segment)
      .def_readonly("seconds_icp", &BimFrameResult::seconds_icp)
      .def_readonly("seconds_total", &BimFrameResult::seconds_total);
  def_pose(r, "T_world_base", &BimFrameResult::T_world_base);
  def_pose(r, "T_world_base_uncorrected", &BimFrameResult::T_world_base_uncorrected);
  def_pose(r, "T_world_base_registered", &BimFrameResult::T_world_base_registered);
}

void bind_bim_odometry(py::module_& m) {
  bind_bim_odometry_types(m);
  py::class_<BimOdometry>(m, "BimOdometry",
                          "BIM-corrected laser odometry (Liu et al. 2022, sec. 3.3), fed one frame at a time.")
      .def(py::init([](const py::object& bim_cloud, const py::object& T_world_base0, const py::kwargs& kwargs) {
             const auto settings = settings_from_kwargs<BimOdometrySettings>(kwargs, "BimOdometry");
             auto cloud = shared_cloud(bim_cloud, "BimOdometry: bim_cloud");
             const Eigen::Isometry3d T0 = pose_from_array(T_world_base0, "BimOdometry: T_world_base0");
             py::gil_scoped_release release;
             return std::make_unique<BimOdometry>(std::move(cloud), T0, settings);
           }),
           py::arg("bim_cloud"), py::arg("T_world_base0"),
           "bim_cloud: the BIM cloud with normals (sample_bim_cloud()); T_world_base0: the initial base pose in the "
           "BIM frame (4x4). Keyword arguments: the fields of BimOdometrySettings.")
      .def(
          "process",
          [](BimOdometry& o, const PointCloud& frame, double stamp, const py::object& odom_pose) {
            const Pose2 odom = pose2_from_array(odom_pose, "BimOdometry.process: odom_pose");
            py::gil_scoped_release release;
            return o.process(frame, stamp, odom);
          },
          py::arg("frame"), py::arg("stamp"), py::arg("odom_pose"),
          "Process one LiDAR frame (sensor frame, deskewed to `stamp`) with the wheel-odometry pose (x, y, theta) "
          "of the base at its stamp: a BimFrameResult.")
      .def_property_readonly("pose", [](const BimOdometry& o) { return pose_to_array(o.pose()); })
      .def(
          "deviation_report",
          [](const BimOdometry& o, const bim::BimMesh& mesh, double tolerance) {
            PLUMB_CHECK(o.as_built() != nullptr,
                        "BimOdometry.deviation_report: the odometry does not estimate the as-built "
                        "(construct it with estimate_as_built=True)");
            py::gil_scoped_release release;
            return deviation_report(*o.as_built(), mesh, tolerance);
          },
          py::arg("mesh"), py::arg("tolerance") = 0.02,
          "The as-built deviation report so far: a DeviationReportRow per element of the BIM cloud, judged "
          "against `tolerance` [m]. `mesh` is the BimMesh the BIM cloud was sampled from.")
      .def(
          "register_to",
          [](BimOdometry& o, const BimOdometry& estimated) {
            PLUMB_CHECK(estimated.as_built() != nullptr,
                        "BimOdometry.register_to: the odometry given does not estimate the as-built "
                        "(construct it with estimate_as_built=True)");
            py::gil_scoped_release release;
            o.register_to(*estimated.as_built());
          },
          py::arg("estimated"),
          "Register the frames from now on to the building as `estimated` (a BimOdometry with "
          "estimate_as_built=True, e.g. after a first pass over the same frames) has estimated it so far: the "
          "second pass of RunSettings.refine_as_built. This odometry must not estimate the as-built itself.")
      .def_property_readonly("settings", &BimOdometry::settings);
}

void bind_bim_localizer(py::module_& m) {
  py::class_<BimLocalizerSettings>(m, "BimLocalizerSettings",
                                   "Settings of BimLocalizer (the C++ defaults; map and fine sub-settings are C++'s).")
      .def(py::init<>())
      .def_readwrite("slice_min", &BimLocalizerSettings::slice_min)
      .def_readwrite("slice_max", &BimLocalizerSettings::slice_max)
      .def_readwrite("max_normal_z", &BimLocalizerSettings::max_normal_z)
      .def_readwrite("max_range", &BimLocalizerSettings::max_range)
      .def_readwrite("max_points", &BimLocalizerSettings::max_points)
      .def_readwrite("storey", &BimLocalizerSettings::storey)
      .def_readwrite("min_walkable_area", &BimLocalizerSettings::min_walkable_area)
      .def_readwrite("min_score", &BimLocalizerSettings::min_score)
      .def_readwrite("min_score_hinted", &BimLocalizerSettings::min_score_hinted)
      .def_readwrite("min_overlap_hinted", &BimLocalizerSettings::min_overlap_hinted)
      .def_readwrite("ambiguity_margin", &BimLocalizerSettings::ambiguity_margin)
      .def_readwrite("max_refine_shift", &BimLocalizerSettings::max_refine_shift)
      .def_readwrite("threads", &BimLocalizerSettings::threads);
  py::class_<BimLocalization> r(m, "BimLocalization", "Where BimLocalizer.localize() placed a frame.");
  r.def_readonly("status", &BimLocalization::status)
      .def_readonly("storey", &BimLocalization::storey)
      .def_readonly("score", &BimLocalization::score)
      .def_readonly("second_score", &BimLocalization::second_score)
      .def_readonly("ambiguous", &BimLocalization::ambiguous)
      .def_readonly("second_overlap", &BimLocalization::second_overlap)
      .def_readonly("see_through", &BimLocalization::see_through)
      .def_readonly("truncated", &BimLocalization::truncated)
      .def_readonly("fine", &BimLocalization::fine)
      .def_readonly("refine_starts", &BimLocalization::refine_starts)
      .def_readonly("num_points", &BimLocalization::num_points)
      .def_readonly("views", &BimLocalization::views)
      .def_readonly("seconds_search", &BimLocalization::seconds_search)
      .def_readonly("seconds_fine", &BimLocalization::seconds_fine);
  def_pose(r, "T_world_base", &BimLocalization::T_world_base);
  def_pose(r, "T_world_base_search", &BimLocalization::T_world_base_search);
  def_pose(r, "T_world_base_second", &BimLocalization::T_world_base_second);

  py::class_<BimLocalizer>(m, "BimLocalizer", "Global localization of a LiDAR frame in the building (no prior).")
      .def(py::init([](const bim::BimMesh& mesh, const py::object& bim_cloud, const py::kwargs& kwargs) {
             const auto settings = settings_from_kwargs<BimLocalizerSettings>(kwargs, "BimLocalizer");
             const PointCloud cloud = cloud_from_object(bim_cloud, "BimLocalizer: bim_cloud");
             py::gil_scoped_release release;
             return std::make_unique<BimLocalizer>(mesh, cloud, settings);
           }),
           py::arg("mesh"), py::arg("bim_cloud"), "Keyword arguments: the fields of BimLocalizerSettings.")
      .def(
          "localize",
          [](const BimLocalizer& l, const PointCloud& frame, const py::object& T_base_lidar, const py::object& hint,
             double hint_radius) {
            const Eigen::Isometry3d T = pose_from_array(T_base_lidar, "BimLocalizer.localize: T_base_lidar");
            std::optional<Vector2d> h;
            if (!hint.is_none()) h = hint.cast<Vector2d>();
            py::gil_scoped_release release;
            return l.localize(frame, T, h, hint_radius);
          },
          py::arg("frame"), py::arg("T_base_lidar"), py::arg("hint") = py::none(), py::arg("hint_radius") = 3.0,
          "Place a LiDAR frame (sensor frame) in the building; `hint` (x, y) restricts the search to within "
          "hint_radius of it.")
      .def(
          "localize_views",
          [](const BimLocalizer& l, const py::list& frame_objects, const py::list& motions,
             const py::object& T_base_lidar, const py::object& hint, double hint_radius) {
            PLUMB_CHECK(motions.size() == frame_objects.size(), "BimLocalizer.localize_views: " << frame_objects.size()
                                                                    << " frames but " << motions.size() << " motions");
            const Eigen::Isometry3d T = pose_from_array(T_base_lidar, "BimLocalizer.localize_views: T_base_lidar");
            std::vector<PointCloud> frames;
            for (const py::handle f : frame_objects) frames.push_back(cloud_from_object(f, "BimLocalizer.localize_views: frame"));
            std::vector<LocalizerView> views;
            for (std::size_t i = 0; i < frames.size(); ++i) {
              views.push_back(LocalizerView{&frames[i], pose_from_array(motions[i], "BimLocalizer.localize_views: motion")});
            }
            std::optional<Vector2d> h;
            if (!hint.is_none()) h = hint.cast<Vector2d>();
            py::gil_scoped_release release;
            return l.localize(views, T, h, hint_radius);
          },
          py::arg("frames"), py::arg("motions"), py::arg("T_base_lidar"), py::arg("hint") = py::none(),
          py::arg("hint_radius") = 3.0,
          "Place the first of several LiDAR frames from all of them: `motions[i]` (4x4) is frame i's base pose in "
          "the first frame's base frame (e.g. a scan matcher's chained motion; the first is the identity). The "
          "frames together tell look-alike places apart that one frame cannot.")
      .def("storeys", &BimLocalizer::storeys);
}

void bind_hybrid_lio(py::module_& m) {
  py::enum_<LioMode>(m, "LioMode", "Estimator of HybridLio.")
      .value("loam", LioMode::kLoam)
      .value("loam_imu", LioMode::kLoamImu)
      .value("hybrid", LioMode::kHybrid);
  py::enum_<LioFrameMode>(m, "LioFrameMode", "How HybridLio estimated one frame.")
      .value("init", LioFrameMode::kInit)
      .value("loam", LioFrameMode::kLoam)
      .value("icp", LioFrameMode::kIcp)
      .value("prediction", LioFrameMode::kPrediction)
      .value("skipped", LioFrameMode::kSkipped);
  py::class_<RangeImageSettings>(m, "RangeImageSettings", "Range image of a LiDAR frame (its ring elevations).")
      .def(py::init<>())
      .def_readwrite("vertical_angles_deg", &RangeImageSettings::vertical_angles_deg);
  py::class_<LioFeatureSettings>(m, "LioFeatureSettings", "Features and the hybrid switch of HybridLio.")
      .def(py::init<>())
      .def_readwrite("image", &LioFeatureSettings::image)
      .def_readwrite("min_plane_points", &LioFeatureSettings::min_plane_points)
      .def_readwrite("min_init_points", &LioFeatureSettings::min_init_points)
      .def_readwrite("switch_on_plane_matches", &LioFeatureSettings::switch_on_plane_matches)
      .def_readwrite("ground_max_slope_deg", &LioFeatureSettings::ground_max_slope_deg)
      .def_readwrite("ground_plane_tolerance", &LioFeatureSettings::ground_plane_tolerance);
  py::class_<LioMotionSettings>(m, "LioMotionSettings", "Constant-velocity model and deskewing of HybridLio.")
      .def(py::init<>())
      .def_readwrite("deskew", &LioMotionSettings::deskew)
      .def_readwrite("twist_frames", &LioMotionSettings::twist_frames);
  py::class_<HybridLioSettings> s(m, "HybridLioSettings",
                                  "Settings of HybridLio: mode, extrinsics, features and motion; the solver, map and "
                                  "IMU sub-settings keep their C++ defaults.");
  s.def(py::init<>())
      .def_readwrite("mode", &HybridLioSettings::mode)
      .def_readwrite("features", &HybridLioSettings::features)
      .def_readwrite("motion", &HybridLioSettings::motion)
      .def_readwrite("threads", &HybridLioSettings::threads);
  def_pose(s, "T_base_lidar", &HybridLioSettings::T_base_lidar, true);
  def_pose(s, "T_base_imu", &HybridLioSettings::T_base_imu, true);
  py::class_<LioFrameResult> r(m, "LioFrameResult", "What HybridLio.process() did with one frame.");
  r.def_readonly("stamp", &LioFrameResult::stamp)
      .def_readonly("v_world", &LioFrameResult::v_world)
      .def_property_readonly("bias_gyro", [](const LioFrameResult& f) { return Vector3d(f.bias.gyro); })
      .def_property_readonly("bias_accel", [](const LioFrameResult& f) { return Vector3d(f.bias.accel); })
      .def_readonly("mode", &LioFrameResult::mode)
      .def_readonly("status", &LioFrameResult::status)
      .def_readonly("imu_used", &LioFrameResult::imu_used)
      .def_readonly("imu_gap", &LioFrameResult::imu_gap)
      .def_readonly("deskewed", &LioFrameResult::deskewed)
      .def_readonly("num_points", &LioFrameResult::num_points)
      .def_readonly("num_plane_points", &LioFrameResult::num_plane_points)
      .def_readonly("num_edge_points", &LioFrameResult::num_edge_points)
      .def_readonly("num_correspondences", &LioFrameResult::num_correspondences)
      .def_readonly("iterations", &LioFrameResult::iterations)
      .def_readonly("rmse", &LioFrameResult::rmse)
      .def_readonly("seconds", &LioFrameResult::seconds);
  def_pose(r, "T_world_base", &LioFrameResult::T_world_base);

  py::class_<HybridLio>(m, "HybridLio", "LiDAR-inertial odometry (LOAM residuals, IMU factor, ICP fallback).")
      .def(py::init([](const py::object& T_world_base0, const py::kwargs& kwargs) {
             const auto settings = settings_from_kwargs<HybridLioSettings>(kwargs, "HybridLio");
             const Eigen::Isometry3d T0 = T_world_base0.is_none()
                                              ? Eigen::Isometry3d::Identity()
                                              : pose_from_array(T_world_base0, "HybridLio: T_world_base0");
             return std::make_unique<HybridLio>(T0, settings);
           }),
           py::arg("T_world_base0") = py::none(), "Keyword arguments: the fields of HybridLioSettings.")
      .def(
          "add_imu",
          [](HybridLio& l, double stamp, const Vector3d& gyro, const Vector3d& accel) {
            return l.add_imu(ImuSample{stamp, gyro, accel});
          },
          py::arg("stamp"), py::arg("gyro"), py::arg("accel"),
          "Queue one IMU sample (angular rate [rad/s], specific force [m/s^2], IMU frame).")
      .def("process", &HybridLio::process, py::arg("frame"), py::arg("stamp"),
           py::call_guard<py::gil_scoped_release>(), "Process one LiDAR frame (sensor frame): a LioFrameResult.")
      .def_property_readonly("T_world_base", [](const HybridLio& l) { return pose_to_array(l.T_world_base()); })
      .def("num_frames", &HybridLio::num_frames)
      .def("initialized", &HybridLio::initialized)
      .def("num_imu_dropped", &HybridLio::num_imu_dropped);
}

}  // namespace

void bind_pipeline(py::module_& m) {
  bind_bim_odometry(m);
  bind_bim_localizer(m);
  bind_hybrid_lio(m);
}

}  // namespace plumb::python
