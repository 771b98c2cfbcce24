// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/registration/localize.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "plumb/core/clock.hpp"
#include "plumb/core/error.hpp"
#include "plumb/features/normals.hpp"
#include "plumb/filters/voxel_grid.hpp"
#include "plumb/registration/overlap.hpp"

#include "registration/sac_ia_detail.hpp"

namespace plumb {

namespace detail {

void check_localize_settings(const LocalizeSettings& s) {
  PLUMB_CHECK(std::isfinite(s.voxel_size) && s.voxel_size > 0.0,
              "localize_coarse_to_fine: settings.voxel_size = " << s.voxel_size << " must be > 0");
  PLUMB_CHECK(std::isfinite(s.fine_voxel_size) && s.fine_voxel_size >= 0.0,
              "localize_coarse_to_fine: settings.fine_voxel_size = " << s.fine_voxel_size << " must be >= 0");
  PLUMB_CHECK(!std::isnan(s.ambiguity_margin) && std::isfinite(s.ambiguity_distance) && s.ambiguity_distance >= 0.0 &&
                  std::isfinite(s.ambiguity_angle) && s.ambiguity_angle >= 0.0,
              "localize_coarse_to_fine: ambiguity_margin must not be NaN, ambiguity_distance / angle must be >= 0");
  PLUMB_CHECK(s.threads >= 0, "localize_coarse_to_fine: settings.threads = " << s.threads << " must be >= 0 (0 = every core)");
  PLUMB_CHECK(s.normal_neighbors >= 3,
              "localize_coarse_to_fine: settings.normal_neighbors = " << s.normal_neighbors << " must be >= 3");
  for (double f : {s.normal_radius_factor, s.fpfh_radius_factor, s.huber_factor, s.correspondence_factor})
    PLUMB_CHECK(std::isfinite(f) && f > 0.0, "localize_coarse_to_fine: a radius/distance factor is " << f << ", must be > 0");
}

/// Finite points of `cloud`, voxelised (leaf 0 = no voxel grid), with every field kept.
PointCloud localize_downsample(const PointCloud& cloud, double leaf) {
  PointCloud finite = cloud.select(cloud.finite_indices());
  if (leaf <= 0.0 || finite.empty()) return finite;
  VoxelGridSettings vs;
  vs.leaf_size = leaf;
  return voxel_grid(finite, vs).cloud;
}

/// As localize_downsample(), each of the six signed-axis normal directions voxelised on its own
/// (points without a finite normal form a seventh group). Without normals: localize_downsample().
PointCloud localize_downsample_by_normal(const PointCloud& cloud, double leaf) {
  if (leaf <= 0.0 || !cloud.has_normals()) return localize_downsample(cloud, leaf);
  std::vector<std::vector<std::size_t>> groups(7);
  for (std::size_t i : cloud.finite_indices()) {
    const Vector3f& n = cloud.normals[i];
    std::size_t g = 6;
    if (n.allFinite() && n.squaredNorm() > 0.0f) {
      Eigen::Index axis = 0;
      n.cwiseAbs().maxCoeff(&axis);
      g = static_cast<std::size_t>(2 * axis) + (n(axis) < 0.0f ? 1 : 0);
    }
    groups[g].push_back(i);
  }
  std::vector<std::size_t> kept;
  VoxelGridSettings vs;
  vs.leaf_size = leaf;
  for (const std::vector<std::size_t>& g : groups) {
    if (g.empty()) continue;
    for (std::size_t i : voxel_grid(cloud.select(g), vs).indices) kept.push_back(g[i]);
  }
  return cloud.select(kept);
}

std::size_t count_finite_normals(const PointCloud& c) {
  std::size_t n = 0;
  for (const Vector3f& v : c.normals) n += v.allFinite() ? 1 : 0;
  return n;
}

/// Normals for a stage's cloud: kept when present and wanted, else PCA (hybrid k + radius).
void localize_normals(PointCloud& c, const LocalizeSettings& s, double leaf, bool keep,
                      const Vector3f& viewpoint) {
  if (c.size() < 3) return;
  if (keep && c.has_normals() && count_finite_normals(c) >= 3) return;
  NormalSettings ns;
  ns.k = s.normal_neighbors;
  ns.radius = static_cast<float>(s.normal_radius_factor * std::max(leaf, s.voxel_size * 0.25));
  ns.viewpoint = viewpoint;
  ns.threads = s.threads;
  compute_normals(c, ns);
}

std::vector<FpfhSignature> localize_fpfh(const PointCloud& c, const LocalizeSettings& s) {
  if (c.size() < 3) return std::vector<FpfhSignature>(c.size(), FpfhSignature{});
  FpfhSettings fs;
  fs.radius = static_cast<float>(s.fpfh_radius_factor * s.voxel_size);
  fs.threads = s.threads;
  fs.max_neighbors = s.fpfh_max_neighbors;
  if (s.fpfh_visible_side_factor >= 0.0) fs.visible_side_tolerance = static_cast<float>(s.fpfh_visible_side_factor * s.voxel_size);
  return compute_fpfh(c, fs).features;
}

/// The source at the fine stage's voxel, with normals when the target has them (for the
/// normal-angle rejection).
PointCloud localize_fine_source(const PointCloud& source, const PointCloud& target_fine,
                                const LocalizeSettings& s) {
  PointCloud fine = localize_downsample(source, s.fine_voxel_size);
  fine.normals.clear();
  if (target_fine.has_normals() && fine.size() >= 3) localize_normals(fine, s, s.fine_voxel_size, false, s.source_viewpoint);
  return fine;
}

/// The gated ICP from T_init, then (settings.polish) one round at the smallest distance.
IcpResult localize_fine_stage(const PointCloud& fine, const LocalizeTarget& target,
                              const Eigen::Isometry3d& T_init, const LocalizeSettings& settings) {
  IcpSettings icp = settings.icp;
  icp.threads = settings.threads;
  IcpResult r = align_icp(fine, target.fine, *target.fine_tree, T_init, icp);
  if (settings.polish && r.status != Status::kInsufficientData) {
    IcpSettings ps = icp;
    ps.max_correspondence_distance = ps.min_correspondence_distance;
    ps.max_rounds = 1;
    ps.min_overlap = 0.0;
    const IcpResult polished = align_icp(fine, target.fine, *target.fine_tree, r.T_target_source, ps);
    if (polished.status != Status::kInsufficientData && polished.status != Status::kDegenerate) {
      r.T_target_source = polished.T_target_source;
      r.iterations += polished.iterations;
      r.num_inliers = polished.num_inliers;
      r.rmse = polished.rmse;
      r.degeneracy = polished.degeneracy;
      r.overlap = overlap_ratio(fine, *target.fine_tree, polished.T_target_source, ps.overlap_distance).overlap;
    }
  }
  return r;
}

}  // namespace detail

LocalizeSettings localize_settings_for_voxel(double v) {
  PLUMB_CHECK(std::isfinite(v) && v > 0.0, "localize_settings_for_voxel: voxel size " << v << " must be > 0");
  LocalizeSettings s;
  s.voxel_size = v;
  s.fine_voxel_size = v / 3.0;
  s.sac_ia.min_sample_distance = v * 10.0 / 3.0;
  s.icp.max_correspondence_distance = 2.0 * v;
  s.icp.distance_step = v / 3.0;
  s.icp.min_correspondence_distance = v / 3.0;
  s.icp.overlap_distance = v / 3.0;
  s.icp.kernel_scale = v / 3.0;
  return s;
}

LocalizeTarget prepare_localize_target(const PointCloud& target, const LocalizeSettings& settings,
                                       LocalizeStages stages) {
  detail::check_localize_settings(settings);
  target.check_consistent("localize_coarse_to_fine: target");
  const auto t0 = std::chrono::steady_clock::now();
  LocalizeTarget out;
  const Vector3f origin = Vector3f::Zero();
  auto downsample = [&](double leaf) {
    return settings.split_target_by_normal ? detail::localize_downsample_by_normal(target, leaf)
                                           : detail::localize_downsample(target, leaf);
  };
  if (stages == LocalizeStages::kCoarseAndFine) {
    out.coarse = downsample(settings.voxel_size);
    detail::localize_normals(out.coarse, settings, settings.voxel_size, settings.use_target_normals, origin);
    out.features = detail::localize_fpfh(out.coarse, settings);
    if (out.coarse.size() >= 3) out.coarse_tree = std::make_unique<KdTree3f>(out.coarse.points);
  }
  out.fine = downsample(settings.fine_voxel_size);
  if (settings.icp.method == IcpMethod::kPointToPlane || out.fine.has_normals()) {
    detail::localize_normals(out.fine, settings, settings.fine_voxel_size, settings.use_target_normals, origin);
  }
  if (out.fine.size() >= 3) out.fine_tree = std::make_unique<KdTree3f>(out.fine.points);
  out.seconds = seconds_since(t0);
  return out;
}

LocalizeResult localize_coarse_to_fine(const PointCloud& source, const LocalizeTarget& target,
                                       const LocalizeSettings& settings) {
  detail::check_localize_settings(settings);
  source.check_consistent("localize_coarse_to_fine: source");
  LocalizeResult out;
  auto t0 = std::chrono::steady_clock::now();
  PointCloud coarse = detail::localize_downsample(source, settings.voxel_size);
  coarse.normals.clear();  // a frame's own normals, if any, are re-estimated at this scale
  detail::localize_normals(coarse, settings, settings.voxel_size, false, settings.source_viewpoint);
  const std::vector<FpfhSignature> features = detail::localize_fpfh(coarse, settings);
  out.num_source_coarse = coarse.size();
  out.num_target_coarse = target.coarse.size();
  out.seconds_prepare = seconds_since(t0);
  if (coarse.size() < settings.sac_ia.num_samples || !target.coarse_tree || !target.fine_tree) {
    out.status = Status::kInsufficientData;
    return out;
  }

  SacIaSettings ss = settings.sac_ia;
  ss.huber_threshold = settings.huber_factor * settings.voxel_size;
  ss.max_correspondence_distance = std::max(ss.huber_threshold, settings.correspondence_factor * settings.voxel_size);
  const PointCloud fine = detail::localize_fine_source(source, target.fine, settings);
  // SAC-IA, then the gated ICP (and its polish) from its best hypothesis.
  auto attempt = [&](const SacIaSettings& sac, SacIaResult& coarse_out, IcpResult& fine_out) {
    auto t = std::chrono::steady_clock::now();
    coarse_out = align_sac_ia(coarse, features, target.coarse, target.features, *target.coarse_tree, sac);
    out.seconds_coarse += seconds_since(t);
    if (coarse_out.status == Status::kInsufficientData) return false;
    t = std::chrono::steady_clock::now();
    fine_out = detail::localize_fine_stage(fine, target, coarse_out.T_target_source, settings);
    out.seconds_fine += seconds_since(t);
    return true;
  };
  if (!attempt(ss, out.coarse, out.fine)) {
    out.status = out.coarse.status;
    return out;
  }
  // Ambiguity: the best alignment at least ambiguity_distance / ambiguity_angle away from the first
  // one. A building repeats itself (rooms alike, mirrored floors, long corridors): when the other
  // place explains the frame about as well, the frame alone cannot tell them apart.
  if (settings.ambiguity_margin >= 0.0 && out.fine.status == Status::kOk) {
    SacIaSettings other = ss;
    other.excluded = {out.fine.T_target_source};
    other.exclude_distance = settings.ambiguity_distance;
    other.exclude_angle = settings.ambiguity_angle;
    SacIaResult coarse2;
    IcpResult fine2;
    if (attempt(other, coarse2, fine2) && fine2.status != Status::kInsufficientData &&
        !detail::near_any(fine2.T_target_source, other.excluded, settings.ambiguity_distance, settings.ambiguity_angle)) {
      if (fine2.status == Status::kOk && fine2.overlap > out.fine.overlap) {
        std::swap(out.fine, fine2);
        std::swap(out.coarse, coarse2);
      }
      out.second_overlap = fine2.overlap;
      out.T_target_source_second = fine2.T_target_source;
      out.ambiguous = fine2.overlap >= (1.0 - settings.ambiguity_margin) * out.fine.overlap;
    }
  }
  out.T_target_source = out.fine.T_target_source;
  out.status = out.ambiguous ? Status::kRejected : out.fine.status;
  out.converged = out.fine.converged;
  out.iterations = out.fine.iterations;
  out.num_inliers = out.fine.num_inliers;
  out.overlap = out.fine.overlap;
  out.rmse = out.fine.rmse;
  out.degeneracy = out.fine.degeneracy;
  return out;
}

IcpResult refine_localization(const PointCloud& source, const LocalizeTarget& target,
                              const Eigen::Isometry3d& T_target_source, const LocalizeSettings& settings) {
  detail::check_localize_settings(settings);
  source.check_consistent("refine_localization: source");
  PLUMB_CHECK(T_target_source.matrix().allFinite(), "refine_localization: the initial pose is not finite");
  IcpResult r;
  r.T_target_source = T_target_source;
  if (!target.fine_tree) return r;  // kInsufficientData
  const PointCloud fine = detail::localize_fine_source(source, target.fine, settings);
  return detail::localize_fine_stage(fine, target, T_target_source, settings);
}

LocalizeResult localize_coarse_to_fine(const PointCloud& source, const PointCloud& target,
                                       const LocalizeSettings& settings) {
  const LocalizeTarget prepared = prepare_localize_target(target, settings);
  LocalizeResult r = localize_coarse_to_fine(source, prepared, settings);
  r.seconds_prepare += prepared.seconds;
  return r;
}

}  // namespace plumb
