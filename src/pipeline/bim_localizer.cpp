// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/pipeline/bim_localizer.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <unordered_map>
#include <unordered_set>

#include <Eigen/Eigenvalues>

#include "plumb/bim/floor_plan.hpp"
#include "plumb/core/clock.hpp"
#include "plumb/core/error.hpp"

namespace plumb {
namespace {

Eigen::Isometry3d base_pose(const Pose2& p, double z) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(p.theta, Vector3d::UnitZ()).toRotationMatrix();
  T.translation() = Vector3d(p.x, p.y, z);
  return T;
}

/// Index of the cell of side `size` holding coordinate v.
std::int64_t cell_of(double v, double size) { return static_cast<std::int64_t>(std::floor(v / size)); }

/// Hash key of the 2D cell (cx, cy).
std::uint64_t cell_key(std::int64_t cx, std::int64_t cy) {
  return (static_cast<std::uint64_t>(cx + (1LL << 31)) << 32) ^ static_cast<std::uint64_t>(cy + (1LL << 31));
}

/// Normal of each 2D point from the points within `radius` (PCA line fit), facing `sensor`; NaN
/// where the neighbourhood is not a clear line (corners, clutter, too few points).
std::vector<Vector2d> scan_normals(const std::vector<Vector2d>& pts, const Vector2d& sensor, double radius) {
  std::unordered_map<std::uint64_t, std::vector<std::size_t>> cells;
  for (std::size_t i = 0; i < pts.size(); ++i) {
    cells[cell_key(cell_of(pts[i].x(), radius), cell_of(pts[i].y(), radius))].push_back(i);
  }
  std::vector<Vector2d> normals(pts.size(), Vector2d::Constant(std::nan("")));
  for (std::size_t i = 0; i < pts.size(); ++i) {
    const std::int64_t cx = cell_of(pts[i].x(), radius), cy = cell_of(pts[i].y(), radius);
    Vector2d mean = Vector2d::Zero();
    Eigen::Matrix2d second = Eigen::Matrix2d::Zero();
    int count = 0;
    for (std::int64_t dy = -1; dy <= 1; ++dy) {
      for (std::int64_t dx = -1; dx <= 1; ++dx) {
        const auto it = cells.find(cell_key(cx + dx, cy + dy));
        if (it == cells.end()) continue;
        for (std::size_t j : it->second) {
          const Vector2d d = pts[j] - pts[i];
          if (d.squaredNorm() > radius * radius) continue;
          mean += d;
          second += d * d.transpose();
          ++count;
        }
      }
    }
    if (count < 4) continue;
    mean /= count;
    const Eigen::Matrix2d cov = second / count - mean * mean.transpose();
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> es(cov);
    if (es.eigenvalues()(0) > 0.05 * es.eigenvalues()(1)) continue;  // not a line
    Vector2d n = es.eigenvectors().col(0);
    if (n.dot(sensor - pts[i]) < 0.0) n = -n;
    normals[i] = n;
  }
  return normals;
}

/// The frame's points in the height band, in the base frame, one per map cell of side `cell`.
std::vector<Vector2d> band_scan(const PointCloud& frame, const Eigen::Isometry3f& T, const BimLocalizerSettings& s,
                                double cell) {
  std::vector<Vector2d> scan;
  std::unordered_set<std::uint64_t> seen;
  for (const Vector3f& pl : frame.points) {
    if (!pl.allFinite() || pl.norm() > s.max_range) continue;
    const Vector3f p = T * pl;
    if (p.z() < s.slice_min || p.z() > s.slice_max) continue;
    if (seen.insert(cell_key(cell_of(p.x(), cell), cell_of(p.y(), cell))).second) scan.emplace_back(p.x(), p.y());
  }
  return scan;
}

/// Points grouped by the sensor position they were seen from, for the see-through test.
struct Rays {
  std::vector<std::vector<Vector2d>> points;  ///< per sensor
  std::vector<Vector2d> sensors;
};

/// The points `pick` of `points` (all when empty), grouped by view.
Rays rays_of(const std::vector<Vector2d>& points, const std::vector<std::size_t>& view,
             const std::vector<Vector2d>& sensors, const std::vector<std::size_t>& pick = {}) {
  Rays r;
  r.sensors = sensors;
  r.points.resize(sensors.size());
  if (pick.empty()) {
    for (std::size_t i = 0; i < points.size(); ++i) r.points[view[i]].push_back(points[i]);
  } else {
    for (std::size_t i : pick) r.points[view[i]].push_back(points[i]);
  }
  return r;
}

/// Up to 200 of the point indices, evenly spread.
std::vector<std::size_t> probe_indices(std::size_t n) {
  std::vector<std::size_t> probe;
  const std::size_t num_probe = std::min<std::size_t>(n, 200);
  for (std::size_t i = 0; i < num_probe; ++i) probe.push_back(i * n / num_probe);
  return probe;
}

/// Fraction of the rays' points seen through `solid` at `pose` (CorrelativeMap2D::see_through per
/// sensor, weighted by its points).
double see_through(const CorrelativeMap2D& solid, const Rays& rays, const Pose2& pose, double margin) {
  if (rays.sensors.size() == 1) return solid.see_through(rays.points[0], pose, rays.sensors[0], margin);
  double crossed = 0.0;
  std::size_t total = 0;
  for (std::size_t g = 0; g < rays.sensors.size(); ++g) {
    if (rays.points[g].empty()) continue;
    crossed += solid.see_through(rays.points[g], pose, rays.sensors[g], margin) * static_cast<double>(rays.points[g].size());
    total += rays.points[g].size();
  }
  return total > 0 ? crossed / static_cast<double>(total) : 0.0;
}

void check_settings(const BimLocalizerSettings& s) {
  PLUMB_CHECK(std::isfinite(s.slice_min) && std::isfinite(s.slice_max) && s.slice_min < s.slice_max,
              "BimLocalizer: slice_min = " << s.slice_min << " must be below slice_max = " << s.slice_max);
  PLUMB_CHECK(std::isfinite(s.max_normal_z) && s.max_normal_z >= 0.0 && s.max_normal_z <= 1.0,
              "BimLocalizer: max_normal_z = " << s.max_normal_z << " must be in [0, 1]");
  PLUMB_CHECK(std::isfinite(s.max_range) && s.max_range > 0.0, "BimLocalizer: max_range = " << s.max_range << " must be > 0");
  PLUMB_CHECK(s.max_points >= 20, "BimLocalizer: max_points = " << s.max_points << " must be >= 20");
  PLUMB_CHECK(std::isfinite(s.min_score) && s.min_score >= 0.0 && s.min_score <= 1.0,
              "BimLocalizer: min_score = " << s.min_score << " must be in [0, 1]");
  PLUMB_CHECK(std::isfinite(s.ambiguity_margin) && s.ambiguity_margin >= 0.0 && s.ambiguity_margin < 1.0,
              "BimLocalizer: ambiguity_margin = " << s.ambiguity_margin << " must be in [0, 1)");
  PLUMB_CHECK(std::isfinite(s.ambiguity_distance) && s.ambiguity_distance > 0.0 && std::isfinite(s.ambiguity_angle) &&
                  s.ambiguity_angle >= 0.0,
              "BimLocalizer: ambiguity_distance must be > 0 and ambiguity_angle >= 0");
  PLUMB_CHECK(std::isfinite(s.ambiguity_overlap_margin) && s.ambiguity_overlap_margin >= 0.0,
              "BimLocalizer: ambiguity_overlap_margin = " << s.ambiguity_overlap_margin << " must be >= 0");
  PLUMB_CHECK(std::isfinite(s.min_score_when_ambiguous) && s.min_score_when_ambiguous >= 0.0 &&
                  s.min_score_when_ambiguous <= 1.0,
              "BimLocalizer: min_score_when_ambiguous = " << s.min_score_when_ambiguous << " must be in [0, 1]");
  PLUMB_CHECK(std::isfinite(s.max_see_through) && s.max_see_through >= 0.0 && std::isfinite(s.see_through_margin) &&
                  s.see_through_margin >= 0.0,
              "BimLocalizer: max_see_through and see_through_margin must be >= 0");
  PLUMB_CHECK(std::isfinite(s.min_score_hinted) && s.min_score_hinted >= 0.0 && s.min_score_hinted <= 1.0 &&
                  std::isfinite(s.min_overlap_hinted) && s.min_overlap_hinted >= 0.0 && s.min_overlap_hinted <= 1.0,
              "BimLocalizer: min_score_hinted = " << s.min_score_hinted << " and min_overlap_hinted = "
                                                  << s.min_overlap_hinted << " must be in [0, 1]");
  PLUMB_CHECK(std::isfinite(s.search_see_through) && s.search_see_through >= 0.0,
              "BimLocalizer: search_see_through = " << s.search_see_through << " must be >= 0");
  PLUMB_CHECK(std::isfinite(s.max_refine_shift) && s.max_refine_shift > 0.0,
              "BimLocalizer: max_refine_shift = " << s.max_refine_shift << " must be > 0");
  PLUMB_CHECK(std::isfinite(s.retry_shift) && s.retry_shift >= 0.0,
              "BimLocalizer: retry_shift = " << s.retry_shift << " must be >= 0");
  PLUMB_CHECK(s.threads >= 0, "BimLocalizer: threads = " << s.threads << " must be >= 0 (0 = every core)");
}

}  // namespace

BimLocalizer::BimLocalizer(const bim::BimMesh& mesh, const PointCloud& bim_cloud, const BimLocalizerSettings& settings)
    : settings_(settings) {
  const auto t0 = std::chrono::steady_clock::now();
  check_settings(settings_);
  settings_.fine.threads = settings_.threads;
  bim_cloud.check_consistent("BimLocalizer: BIM cloud");
  PLUMB_CHECK(bim_cloud.has_normals(), "BimLocalizer: the BIM cloud has no normals (use sample_bim_cloud())");
  PLUMB_CHECK(!mesh.storeys.empty(), "BimLocalizer: the model has no storey");
  const int num_storeys = static_cast<int>(mesh.storeys.size());
  PLUMB_CHECK(settings_.storey < num_storeys, "BimLocalizer: storey " << settings_.storey << " does not exist (the model has "
                                                                      << num_storeys << " storeys)");
  bim::OccupancyGridSettings gs;
  gs.min_walkable_area = settings_.min_walkable_area;
  for (int k = 0; k < num_storeys; ++k) {
    if (settings_.storey >= 0 && k != settings_.storey) continue;
    gs.storey = k;
    std::shared_ptr<bim::OccupancyGrid> grid;
    try {
      grid = std::make_shared<bim::OccupancyGrid>(bim::floor_plan(mesh, gs));
    } catch (const Error&) {
      if (settings_.storey >= 0) throw;
      continue;  // not walkable
    }
    // Vertical faces in the band, and which thirds of the band each 10 cm column has faces in:
    // columns with all three are solid (no door or window there).
    std::vector<Vector2d> walls, wall_normals;
    std::unordered_map<std::uint64_t, int> bands;
    const double band = (settings_.slice_max - settings_.slice_min) / 3.0;
    for (std::size_t i = 0; i < bim_cloud.size(); ++i) {
      const Vector3f& p = bim_cloud.points[i];
      const Vector3f& n = bim_cloud.normals[i];
      const double h = p.z() - grid->floor_z;
      if (!p.allFinite() || !n.allFinite() || h < settings_.slice_min || h > settings_.slice_max) continue;
      if (std::abs(n.z()) > settings_.max_normal_z * n.norm()) continue;
      walls.emplace_back(p.x(), p.y());
      wall_normals.emplace_back(n.x(), n.y());
      bands[cell_key(cell_of(p.x(), 0.1), cell_of(p.y(), 0.1))] |= 1 << std::min(2, static_cast<int>((h - settings_.slice_min) / band));
    }
    if (walls.empty()) continue;
    std::vector<Vector2d> solid;
    for (const Vector2d& w : walls)
      if (bands[cell_key(cell_of(w.x(), 0.1), cell_of(w.y(), 0.1))] == 7) solid.push_back(w);
    StoreyMap m;
    if (!solid.empty()) {
      CorrelativeMapSettings sm = settings_.map;
      sm.levels = 1;
      sm.orientation_bins = 0;
      sm.sigma = 0.5 * sm.resolution;  // narrow: a ray grazing a wall does not count as crossing it
      m.solid = std::make_unique<CorrelativeMap2D>(solid, sm);
    }
    m.index = k;
    m.floor_z = grid->floor_z;
    m.floor_modelled = bim::is_modelled(grid->floor_source);
    // Search every free floor cell, also those farther than the map margin from any wall (a
    // terrace, a hall): the map's translations cover the free floor's box.
    CorrelativeMapSettings map_settings = settings_.map;
    for (int iy = 0; iy < grid->height; ++iy) {
      for (int ix = 0; ix < grid->width; ++ix) {
        if (grid->at(ix, iy) != bim::CellState::kFree) continue;
        const Vector2d corner = grid->origin + Vector2d(ix, iy) * grid->resolution;
        map_settings.bounds.extend(corner);
        map_settings.bounds.extend(Vector2d(corner + Vector2d::Constant(grid->resolution)));
      }
    }
    m.map = std::make_unique<CorrelativeMap2D>(walls, map_settings,
                                               [grid](const Vector2d& t) { return grid->is_free(t); }, wall_normals);
    maps_.push_back(std::move(m));
  }
  PLUMB_CHECK(!maps_.empty(), "BimLocalizer: no walkable storey with walls in the BIM cloud (free floor >= "
                                  << settings_.min_walkable_area << " m^2 and vertical faces "
                                  << settings_.slice_min << ".." << settings_.slice_max << " m above it)");
  fine_ = prepare_localize_target(bim_cloud, settings_.fine, LocalizeStages::kFineOnly);
  seconds_prepare_ = seconds_since(t0);
}

std::vector<int> BimLocalizer::storeys() const {
  std::vector<int> out;
  for (const StoreyMap& m : maps_) out.push_back(m.index);
  return out;
}

BimLocalizer::StoreySearch BimLocalizer::search_storeys(const BandScan& scan, const std::optional<Vector2d>& hint,
                                                         double hint_radius, BimLocalization& out) const {
  CorrelativeSearchSettings ss;
  ss.max_points = settings_.max_points;
  ss.threads = settings_.threads;
  // With a hint, a weaker 2D match may still be confirmed in 3D (see min_score_hinted).
  const double min_score = hint ? std::min(settings_.min_score, settings_.min_score_hinted) : settings_.min_score;
  ss.min_score = min_score * (1.0 - settings_.ambiguity_margin);  // a second pose below this cannot matter
  ss.second_distance = settings_.ambiguity_distance;
  ss.second_angle = settings_.ambiguity_angle;
  if (hint) {
    ss.region_center = *hint;
    ss.region_radius = hint_radius;
  }
  // Best and second best over all storeys: another storey's pose always counts as "far".
  StoreySearch found;
  // The search's free-space test runs on up to 200 of the points (evenly spread): it is called on
  // every pose that would become the best, thousands of times in a building of look-alike rooms.
  const Rays probe = rays_of(scan.points, scan.view, scan.sensors, probe_indices(scan.points.size()));
  for (const StoreyMap& m : maps_) {
    ss.accept = nullptr;
    if (m.solid && settings_.search_see_through > 0.0) {
      ss.accept = [&](const Pose2& pose) {
        return see_through(*m.solid, probe, pose, settings_.see_through_margin) <= settings_.search_see_through;
      };
    }
    const CorrelativeResult cr = m.map->match(scan.points, ss, scan.normals);
    out.rejected_by_free_space += cr.rejected;
    found.truncated = found.truncated || cr.truncated;
    out.num_points = cr.num_points;
    out.nodes_scored += cr.nodes_scored;
    if (cr.status == Status::kInsufficientData) continue;
    found.any_data = true;
    if (cr.status != Status::kOk) continue;
    auto offer_second = [&](double score, const Pose2& pose, const StoreyMap* map) {
      if (score > found.second) {
        found.second = score;
        found.second_pose = pose;
        found.second_map = map;
      }
    };
    if (cr.score > found.best) {
      if (found.best_map) offer_second(found.best, found.best_pose, found.best_map);
      found.best = cr.score;
      found.best_pose = cr.pose;
      found.best_map = &m;
    } else {
      offer_second(cr.score, cr.pose, &m);
    }
    if (cr.has_second) offer_second(cr.second_score, cr.second_pose, &m);
  }
  return found;
}

const PointCloud* BimLocalizer::refine_found(const PointCloud& frame, const Eigen::Isometry3d& T_base_lidar,
                                             const StoreySearch& found, bool close_scores, PointCloud& without_floor,
                                             BimLocalization& out) const {
  // Where the model holds no floor, the floor the frame sees cannot be matched: refine without it.
  const Eigen::Isometry3f T = T_base_lidar.cast<float>();
  auto frame_for = [&](const StoreyMap* m) -> const PointCloud& {
    if (m->floor_modelled) return frame;
    if (without_floor.empty()) {
      std::vector<std::size_t> keep;
      for (std::size_t i = 0; i < frame.size(); ++i) {
        if ((T * frame.points[i]).z() >= settings_.unmodelled_floor_height) keep.push_back(i);
      }
      without_floor = frame.select(keep);
    }
    return without_floor;
  };
  const PointCloud& best_frame = frame_for(found.best_map);
  out.fine = refine_localization(best_frame, fine_, out.T_world_base_search * T_base_lidar, settings_.fine);
  const PointCloud* result_frame = &best_frame;
  if (close_scores) {
    // Two places explain the floor-plan slice about equally: let the whole 3D frame decide.
    const PointCloud& second_frame = frame_for(found.second_map);
    IcpResult other = refine_localization(second_frame, fine_, out.T_world_base_second * T_base_lidar, settings_.fine);
    if (other.overlap > out.fine.overlap) {
      std::swap(out.fine, other);
      std::swap(out.T_world_base_search, out.T_world_base_second);
      std::swap(out.score, out.second_score);
      out.storey = found.second_map->index;
      result_frame = &second_frame;
    }
    out.second_overlap = other.overlap;
    out.ambiguous = out.fine.overlap - other.overlap < settings_.ambiguity_overlap_margin ||
                    out.score < settings_.min_score_when_ambiguous;
  }
  return result_frame;
}

void BimLocalizer::retry_refinement(const PointCloud& result_frame, const Eigen::Isometry3d& T_base_lidar,
                                    const std::vector<Vector2d>& normals, BimLocalization& out) const {
  // Before a weak hinted match is rejected for its overlap: the ICP may sit in a local optimum
  // next to the true pose, along the direction the frame's walls constrain least. Try starts on
  // either side of the 2D pose along it.
  Eigen::Matrix2d walls_info = Eigen::Matrix2d::Zero();
  for (const Vector2d& n : normals)
    if (n.allFinite()) walls_info += n * n.transpose();
  if (!(walls_info.trace() > 0.0)) return;
  const Vector2d weak_base = Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(walls_info).eigenvectors().col(0);
  const Vector2d weak = out.T_world_base_search.linear().topLeftCorner<2, 2>() * weak_base;
  for (const double side : {1.0, -1.0}) {
    Eigen::Isometry3d T_start = out.T_world_base_search;
    T_start.translation().head<2>() += side * settings_.retry_shift * weak;
    IcpResult retry = refine_localization(result_frame, fine_, T_start * T_base_lidar, settings_.fine);
    ++out.refine_starts;
    const Eigen::Isometry3d T_base = retry.T_target_source * T_base_lidar.inverse();
    const double moved = (T_base.translation() - out.T_world_base_search.translation()).norm();
    const bool better =
        retry.status == Status::kOk && (out.fine.status != Status::kOk || retry.overlap > out.fine.overlap);
    if (better && moved <= settings_.max_refine_shift) out.fine = std::move(retry);
  }
}

void BimLocalizer::apply_gates(const BandScan& scan, const StoreySearch& found, bool hinted_weak,
                               BimLocalization& out) const {
  const double shift = (out.T_world_base.translation() - out.T_world_base_search.translation()).norm();
  const StoreyMap* result_map = found.best_map;
  for (const StoreyMap& m : maps_)
    if (m.index == out.storey) result_map = &m;
  const Pose2 refined{out.T_world_base.translation().x(), out.T_world_base.translation().y(),
                      std::atan2(out.T_world_base.linear()(1, 0), out.T_world_base.linear()(0, 0))};
  if (result_map->solid) {
    out.see_through = see_through(*result_map->solid, rays_of(scan.points, scan.view, scan.sensors), refined,
                                  settings_.see_through_margin);
  }
  out.truncated = found.truncated;
  const bool score_ok = out.score >= settings_.min_score || (hinted_weak && out.fine.overlap >= settings_.min_overlap_hinted);
  if (!score_ok || out.ambiguous || out.truncated || shift > settings_.max_refine_shift ||
      out.see_through > settings_.max_see_through) {
    out.status = Status::kRejected;
  } else {
    out.status = out.fine.status;
  }
}

BimLocalization BimLocalizer::localize(const PointCloud& frame, const Eigen::Isometry3d& T_base_lidar,
                                       const std::optional<Vector2d>& hint, double hint_radius) const {
  frame.check_consistent("BimLocalizer::localize: frame");
  return localize(std::vector<LocalizerView>{LocalizerView{&frame, Eigen::Isometry3d::Identity()}}, T_base_lidar, hint,
                  hint_radius);
}

BimLocalization BimLocalizer::localize(const std::vector<LocalizerView>& views, const Eigen::Isometry3d& T_base_lidar,
                                       const std::optional<Vector2d>& hint, double hint_radius) const {
  PLUMB_CHECK(!views.empty(), "BimLocalizer::localize: no frame");
  for (std::size_t v = 0; v < views.size(); ++v) {
    PLUMB_CHECK(views[v].frame != nullptr, "BimLocalizer::localize: view " << v << " has no frame");
    views[v].frame->check_consistent(v == 0 ? "BimLocalizer::localize: frame" : "BimLocalizer::localize: frame of a later view");
    PLUMB_CHECK(views[v].T_base0_base.matrix().allFinite(), "BimLocalizer::localize: the motion of view " << v << " is not finite");
  }
  PLUMB_CHECK(T_base_lidar.matrix().allFinite(), "BimLocalizer::localize: T_base_lidar is not finite");
  PLUMB_CHECK(!hint || (hint->allFinite() && std::isfinite(hint_radius) && hint_radius > 0.0),
              "BimLocalizer::localize: the hint must be finite and its radius > 0");
  BimLocalization out;
  out.views = views.size();
  const auto t0 = std::chrono::steady_clock::now();

  // Each view's points in the height band (in its own base frame, one per map cell) and their
  // normals, moved into the first view's base frame; a cell seen by an earlier view keeps that one.
  const double r = settings_.map.resolution;
  const Vector2d sensor = T_base_lidar.translation().head<2>();
  BandScan scan;
  std::unordered_set<std::uint64_t> taken;
  for (std::size_t v = 0; v < views.size(); ++v) {
    const std::vector<Vector2d> pts = band_scan(*views[v].frame, T_base_lidar.cast<float>(), settings_, r);
    const std::vector<Vector2d> nrm = scan_normals(pts, sensor, 3.0 * r);
    const Pose2 motion = Pose2::from_isometry(views[v].T_base0_base);
    const Eigen::Matrix2d R = Eigen::Rotation2Dd(motion.theta).toRotationMatrix();
    const Vector2d t(motion.x, motion.y);
    const bool first = v == 0;  // the first view's points stay as they are (bit for bit)
    scan.sensors.push_back(first ? sensor : Vector2d(R * sensor + t));
    for (std::size_t i = 0; i < pts.size(); ++i) {
      const Vector2d p = first ? pts[i] : Vector2d(R * pts[i] + t);
      if (!taken.insert(cell_key(cell_of(p.x(), r), cell_of(p.y(), r))).second) continue;  // (never in the first view)
      scan.points.push_back(p);
      scan.normals.push_back(first ? nrm[i] : Vector2d(R * nrm[i]));
      scan.view.push_back(v);
    }
  }

  // The 2D search over every storey: the best pose and the best one away from it.
  const StoreySearch found = search_storeys(scan, hint, hint_radius, out);
  out.seconds_search = seconds_since(t0);
  if (!found.any_data) {
    out.status = Status::kInsufficientData;
    return out;
  }
  if (!found.best_map) {
    out.status = Status::kRejected;  // nothing scored even the lowered floor (or nothing in the hint region)
    return out;
  }
  out.storey = found.best_map->index;
  out.score = found.best;
  out.second_score = found.second;
  out.T_world_base_search = base_pose(found.best_pose, found.best_map->floor_z);
  if (found.second_map) out.T_world_base_second = base_pose(found.second_pose, found.second_map->floor_z);
  const bool close_scores = found.second_map && found.second >= (1.0 - settings_.ambiguity_margin) * found.best;

  // The 3D refinement of the best pose (and of the second when the scores are close), with the
  // first frame: it is where the result is, and the views' points carry the drift of their motion.
  const auto t1 = std::chrono::steady_clock::now();
  const PointCloud& frame = *views[0].frame;
  PointCloud without_floor;
  const PointCloud* result_frame = refine_found(frame, T_base_lidar, found, close_scores, without_floor, out);
  out.refine_starts = 1;
  const bool hinted_weak = hint && out.score >= settings_.min_score_hinted && out.score < settings_.min_score;
  // (An ambiguous result is rejected whatever its overlap: no retry.)
  if (hinted_weak && !out.ambiguous && settings_.retry_shift > 0.0 && out.fine.overlap < settings_.min_overlap_hinted) {
    retry_refinement(*result_frame, T_base_lidar, scan.normals, out);
  }
  out.T_world_base = out.fine.T_target_source * T_base_lidar.inverse();
  out.seconds_fine = seconds_since(t1);

  // The gates: score, ambiguity, truncated search, shift of the refinement, see-through.
  apply_gates(scan, found, hinted_weak, out);
  return out;
}

}  // namespace plumb
