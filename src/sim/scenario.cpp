// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/sim/scenario.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <thread>

#include "plumb/core/error.hpp"
#include "plumb/core/rng.hpp"

namespace plumb::sim {
namespace {


/// SplitMix64 finaliser: independent streams from (seed, index).
std::uint64_t mix(std::uint64_t seed, std::uint64_t index) {
  std::uint64_t z = seed + 0x9E3779B97F4A7C15ull * (index + 1);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

Eigen::Isometry3d translation(double x, double y, double z) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = Vector3d(x, y, z);
  return T;
}

/// Marks the footprint of every clutter box (plus `margin`) as occupied.
void add_clutter(bim::OccupancyGrid& g, const std::vector<ClutterBox>& boxes, double margin) {
  for (const ClutterBox& b : boxes) {
    if (b.center.z() - b.half_size.z() > g.floor_z + 1.5 || b.center.z() + b.half_size.z() < g.floor_z) continue;
    const double r = b.half_size.head<2>().norm() + margin;
    const Eigen::Vector2i c0 = g.cell_of(b.center.head<2>() - Vector2d::Constant(r));
    const Eigen::Vector2i c1 = g.cell_of(b.center.head<2>() + Vector2d::Constant(r));
    const double c = std::cos(b.yaw), s = std::sin(b.yaw);
    for (int iy = std::max(c0.y(), 0); iy <= std::min(c1.y(), g.height - 1); ++iy) {
      for (int ix = std::max(c0.x(), 0); ix <= std::min(c1.x(), g.width - 1); ++ix) {
        const Vector2d d = g.center(ix, iy) - b.center.head<2>();
        const Vector2d local(c * d.x() + s * d.y(), -s * d.x() + c * d.y());
        if (std::abs(local.x()) <= b.half_size.x() + margin && std::abs(local.y()) <= b.half_size.y() + margin) {
          g.cells[g.index(ix, iy)] = bim::CellState::kOccupied;
        }
      }
    }
  }
}

/// Storey the site's ground is level with: the one whose elevation is closest to 0 (the ground floor).
int ground_storey(const bim::BimMesh& mesh) {
  PLUMB_CHECK(!mesh.storeys.empty(), "site scenario: the model has no storey (IfcBuildingStorey)");
  int best = 0;
  for (std::size_t k = 1; k < mesh.storeys.size(); ++k) {
    if (std::abs(mesh.storeys[k].elevation) < std::abs(mesh.storeys[static_cast<std::size_t>(best)].elevation)) {
      best = static_cast<int>(k);
    }
  }
  return best;
}

/// Rounded rectangle [lo, hi] with corner radius r, counter-clockwise from the middle of the
/// bottom side, vertices every `step` along the arcs.
std::vector<Vector2d> rounded_rectangle(const Vector2d& lo, const Vector2d& hi, double r, double step) {
  std::vector<Vector2d> pts;
  const Vector2d centers[4] = {{hi.x() - r, lo.y() + r}, {hi.x() - r, hi.y() - r}, {lo.x() + r, hi.y() - r},
                               {lo.x() + r, lo.y() + r}};
  pts.emplace_back(0.5 * (lo.x() + hi.x()), lo.y());
  const int n = std::max(2, static_cast<int>(std::ceil(0.5 * kPi * r / step)));
  for (int c = 0; c < 4; ++c) {
    const double a0 = -0.5 * kPi + 0.5 * kPi * c;
    for (int i = 0; i <= n; ++i) {
      const double a = a0 + 0.5 * kPi * i / n;
      pts.push_back(centers[c] + r * Vector2d(std::cos(a), std::sin(a)));
    }
  }
  return pts;
}

/// Appends square ground tiles (two triangles each, element type IfcSite) covering [lo, hi] at z.
void add_ground(bim::BimMesh& mesh, const Vector2d& lo, const Vector2d& hi, double z, double tile) {
  const int nx = std::max(1, static_cast<int>(std::ceil((hi.x() - lo.x()) / tile)));
  const int ny = std::max(1, static_cast<int>(std::ceil((hi.y() - lo.y()) / tile)));
  PLUMB_CHECK(static_cast<double>(nx) * ny < 4.0e6, "site scenario: " << nx << " x " << ny
                                                                      << " ground tiles; raise site_tile");
  for (int iy = 0; iy < ny; ++iy) {
    for (int ix = 0; ix < nx; ++ix) {
      const Vector3d a(lo.x() + ix * tile, lo.y() + iy * tile, z);
      const Vector3d b = a + Vector3d(tile, tile, 0.0);
      bim::BimElement e;
      e.type = "IfcSite";
      e.name = "ground";
      e.storey = -1;
      e.first_triangle = mesh.triangles.size();
      e.num_triangles = 2;
      e.bbox_min = a;
      e.bbox_max = b;
      e.has_body = true;
      const auto v = static_cast<std::uint32_t>(mesh.vertices.size());
      mesh.vertices.push_back(a);
      mesh.vertices.emplace_back(b.x(), a.y(), z);
      mesh.vertices.push_back(b);
      mesh.vertices.emplace_back(a.x(), b.y(), z);
      mesh.triangles.push_back({v, v + 1, v + 2});  // counter-clockwise seen from above
      mesh.triangles.push_back({v, v + 2, v + 3});
      const auto index = static_cast<std::int32_t>(mesh.elements.size());
      mesh.triangle_element.push_back(index);
      mesh.triangle_element.push_back(index);
      mesh.elements.push_back(e);
    }
  }
}

void check_settings(const ScenarioSettings& s) {
  PLUMB_CHECK(s.loops >= 1, "scenario: loops must be at least 1, got " << s.loops);
  PLUMB_CHECK(s.length >= 0.0 && std::isfinite(s.length), "scenario: length must be >= 0, got " << s.length);
  PLUMB_CHECK(s.num_threads >= 1, "scenario: num_threads must be at least 1, got " << s.num_threads);
  PLUMB_CHECK(s.site_margin > 0.0 && s.site_excursion >= 0.0 && s.site_ground_margin >= 0.0 && s.site_tile > 0.0,
              "scenario: site margins and tile size must be positive");
  s.lidar.validate();
}

}  // namespace

ScenarioKind scenario_kind_from_string(const std::string& name) {
  if (name == "indoor") return ScenarioKind::kIndoor;
  if (name == "site") return ScenarioKind::kSite;
  PLUMB_THROW("unknown scenario '" << name << "' (known: indoor, site)");
}

std::string to_string(ScenarioKind kind) { return kind == ScenarioKind::kSite ? "site" : "indoor"; }

ScenarioSettings scenario_defaults(ScenarioKind kind) {
  ScenarioSettings s;
  s.kind = kind;
  if (kind == ScenarioKind::kIndoor) {
    s.lidar = lidar_preset("rfans32");
    s.imu.rate_hz = 200.0;
    s.T_base_lidar = translation(0.15, 0.0, 0.55);
  } else {
    s.lidar = lidar_preset("vlp16");
    s.imu.rate_hz = 300.0;
    s.robot.max_speed = 1.5;
    s.robot.max_acceleration = 0.6;
    s.robot.max_lateral_acceleration = 0.5;
    s.robot.lookahead = 1.5;
    s.T_base_lidar = translation(0.2, 0.0, 0.9);
  }
  s.T_base_imu = translation(0.05, 0.02, 0.25);
  return s;
}

ScenarioPlan plan_scenario(const bim::BimMesh& mesh, const ScenarioSettings& s) {
  check_settings(s);
  ScenarioPlan plan;
  WorldSettings ws = s.world;
  ws.seed = mix(s.seed, 0);
  if (s.kind == ScenarioKind::kIndoor) {
    bim::OccupancyGridSettings fs = s.floor_plan;
    fs.storey = s.storey;
    plan.grid = bim::floor_plan(mesh, fs);
    plan.storey = plan.grid.storey;
    plan.floor_z = plan.grid.floor_z;
    ws.storey = plan.storey;
    plan.mesh = std::make_shared<const bim::BimMesh>(mesh);
    plan.world = std::make_shared<const World>(*plan.mesh, ws);
    add_clutter(plan.grid, plan.world->clutter(), 0.05);
    plan.route = plan_auto_route(plan.grid, s.route);
  } else {
    plan.storey = ground_storey(mesh);
    plan.floor_z = mesh.storeys[static_cast<std::size_t>(plan.storey)].elevation;
    Vector3d lo, hi;
    mesh.bounds(lo, hi);
    PLUMB_CHECK(lo.allFinite() && hi.allFinite(), "site scenario: the model has no geometry");
    // Around the building at site_margin, stretched along +x so that the whole drive reaches
    // site_min_length and has a long stretch with nothing but ground in range of the walls.
    const Vector2d r_lo = lo.head<2>() - Vector2d::Constant(s.site_margin);
    Vector2d r_hi = hi.head<2>() + Vector2d::Constant(s.site_margin);
    const double per_loop = s.site_min_length / s.loops;
    const double perimeter = 2.0 * ((r_hi - r_lo).x() + (r_hi - r_lo).y());
    r_hi.x() += std::max(s.site_excursion, 0.5 * (per_loop - perimeter) + 2.0);
    const double corner = std::min(3.0, 0.25 * (r_hi - r_lo).minCoeff());
    plan.route.points = rounded_rectangle(r_lo, r_hi, corner, 0.2);
    plan.route.waypoints = {plan.route.points.front()};
    plan.route.length = polyline_length(plan.route.points, true);
    bim::BimMesh site = mesh;
    add_ground(site, r_lo - Vector2d::Constant(s.site_ground_margin), r_hi + Vector2d::Constant(s.site_ground_margin),
               plan.floor_z, s.site_tile);
    ws.storey = plan.storey;
    plan.mesh = std::make_shared<const bim::BimMesh>(std::move(site));
    plan.world = std::make_shared<const World>(*plan.mesh, ws);
  }
  plan.trajectory = drive_route(plan.route.points, true, s.loops, s.length, plan.floor_z, s.robot);
  const double sweep = s.lidar.sweep_duration();
  for (std::size_t k = 0;; ++k) {
    const double t = plan.trajectory.start_time() + static_cast<double>(k) * sweep;
    if (t + sweep > plan.trajectory.end_time() + 1e-9) break;
    plan.frame_stamps.push_back(t);
  }
  PLUMB_CHECK(!plan.frame_stamps.empty(), "scenario: the drive (" << plan.trajectory.end_time() - plan.trajectory.start_time()
                                                                  << " s) is shorter than one LiDAR sweep (" << sweep
                                                                  << " s): no frame to simulate");
  return plan;
}

ScenarioRecording simulate_scenario(const bim::BimMesh& mesh, const ScenarioSettings& s,
                                    const ScenarioFrameSink& on_frame) {
  const auto start = std::chrono::steady_clock::now();
  const ScenarioPlan plan = plan_scenario(mesh, s);
  ScenarioRecording r = simulate_scenario(plan, s, on_frame);
  r.summary.wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return r;
}

ScenarioRecording simulate_scenario(const ScenarioPlan& plan, const ScenarioSettings& s,
                                    const ScenarioFrameSink& on_frame) {
  const auto start = std::chrono::steady_clock::now();
  check_settings(s);
  PLUMB_CHECK(plan.world != nullptr && !plan.trajectory.states.empty(), "simulate_scenario: empty plan");
  const RobotTrajectory& traj = plan.trajectory;
  const Eigen::Isometry3d T_base_lidar = s.T_base_lidar;
  auto T_world_lidar = [&traj, &T_base_lidar](double t) { return traj.T_world_base(t) * T_base_lidar; };
  const std::size_t total = plan.frame_stamps.size();
  ScenarioRecording r;
  const std::size_t batch = static_cast<std::size_t>(s.num_threads);
  std::vector<PointCloud> clouds(batch);
  for (std::size_t first = 0; first < total; first += batch) {
    const std::size_t count = std::min(batch, total - first);
    auto work = [&](std::size_t j) {
      Rng rng(mix(s.seed, 1000 + first + j));
      clouds[j] = simulate_sweep(*plan.world, s.lidar, T_world_lidar, plan.frame_stamps[first + j], rng, s.sweep);
    };
    if (count == 1) {
      work(0);
    } else {
      std::vector<std::thread> threads;
      std::vector<std::string> errors(count);
      for (std::size_t j = 0; j < count; ++j) {
        threads.emplace_back([&, j] {
          try {
            work(j);
          } catch (const std::exception& e) {
            errors[j] = e.what();
          }
        });
      }
      for (std::thread& t : threads) t.join();
      for (const std::string& e : errors) PLUMB_CHECK(e.empty(), e);
    }
    for (std::size_t j = 0; j < count; ++j) {
      const double stamp = plan.frame_stamps[first + j];
      if (on_frame) on_frame(first + j, stamp, clouds[j]);
      r.summary.num_points += clouds[j].size();
      r.ground_truth.push_back(stamp, traj.T_world_base(stamp));
    }
  }

  WheelSettings wheel_settings = s.wheels;
  wheel_settings.seed = mix(s.seed, 1);
  r.wheels = simulate_wheels(traj, wheel_settings);
  r.odometry = integrate_wheel_odometry(r.wheels, s.wheels.radius, s.wheels.radius, s.wheels.axle);
  ImuSettings imu_settings = s.imu;
  imu_settings.seed = mix(s.seed, 2);
  r.imu = simulate_imu(traj, s.T_base_imu, imu_settings).samples;
  for (const RobotState& st : traj.states) r.ground_truth_dense.push_back(st.t, traj.T_world_base(st.t));
  const std::vector<bim::BimElement>& elements = plan.world->bim().elements;
  r.as_built.reserve(elements.size());
  for (std::size_t e = 0; e < elements.size(); ++e) {
    r.as_built.push_back({elements[e].global_id, elements[e].type, plan.world->element_deviation(e)});
  }

  r.summary.num_frames = total;
  r.summary.path_length = traj.length();
  r.summary.duration = traj.end_time() - traj.start_time();
  r.summary.storey = plan.storey;
  if (plan.storey >= 0) r.summary.storey_name = plan.mesh->storeys[static_cast<std::size_t>(plan.storey)].name;
  r.summary.wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return r;
}

}  // namespace plumb::sim
