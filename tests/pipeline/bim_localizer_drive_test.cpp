// SPDX-License-Identifier: BSD-3-Clause
// BimLocalizer from several frames: a robot that starts where one frame fits several places (rooms
// alike along a corridor, the duplex's two flats, turned half a turn against each other) drives on,
// and the frames it sees on the way decide. Simulated drives from random places on each building's
// indoor route (as-built deviations, furniture, range noise), against the simulator's exact ground
// truth; the frames' relative motion carries a front end's drift.
#include <algorithm>
#include <cmath>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "plumb/bim/bim_cloud.hpp"
#include "plumb/bim/ifc.hpp"
#include "plumb/bim/mesh.hpp"
#include "plumb/core/error.hpp"
#include "plumb/core/pose2.hpp"
#include "plumb/core/rng.hpp"
#include "plumb/pipeline/bim_localizer.hpp"
#include "plumb/registration/icp.hpp"
#include "plumb/registration/overlap.hpp"
#include "plumb/search/kdtree.hpp"
#include "plumb/sim/lidar.hpp"
#include "plumb/sim/scenario.hpp"
#include "test_data.hpp"

namespace {

using plumb::BimLocalization;
using plumb::BimLocalizer;
using plumb::LocalizerView;
using plumb::Status;

/// One drive: frames one metre of path apart, their true base poses, and the motion a front end
/// would report (the truth with a drift).
struct Drive {
  std::vector<plumb::PointCloud> frames;
  std::vector<Eigen::Isometry3d> truth;      ///< T_world_base
  std::vector<Eigen::Isometry3d> motion;     ///< T_base0_base as a front end reports it
};

struct DriveBuilding {
  std::unique_ptr<plumb::bim::BimMesh> mesh;
  std::unique_ptr<BimLocalizer> localizer;
  Eigen::Isometry3d T_base_lidar;
  std::vector<Drive> drives;
};

constexpr double kViewSpacing = 1.0;  // [m] of path between two frames
constexpr double kMaxDrive = 10.0;    // [m]

// Sanitizer builds run about ten times slower: they drive every tenth start.
#if defined(__SANITIZE_ADDRESS__)
constexpr std::size_t kDriveStride = 10;
#else
constexpr std::size_t kDriveStride = 1;
#endif

std::string drive_model_path(const std::string& name) {
  if (name == "demo_office") return plumb::test::source_dir() + "/examples/data/demo_office.ifc";
  return plumb::test::data_path("ifc/buildings/" + name + ".ifc");
}

/// The front end's drift over a drive: its path 0.3 % long and its heading turning 0.05 deg per
/// metre (a PLICP front end over 10 m: a few centimetres, below the localizer's 10 cm grid).
Eigen::Isometry3d drifted(const Eigen::Isometry3d& T_base0_base, double path) {
  Eigen::Isometry3d T = T_base0_base;
  T.translation() *= 1.003;
  const double turn = 0.05 * M_PI / 180.0 * path;
  return Eigen::Isometry3d(Eigen::AngleAxisd(turn, Eigen::Vector3d::UnitZ())) * T;
}

/// 20 drives from random places on the building's indoor route (seed 11), along the route.
const DriveBuilding& drive_building(const std::string& name) {
  static std::map<std::string, DriveBuilding> cache;
  auto it = cache.find(name);
  if (it != cache.end()) return it->second;
  DriveBuilding b;
  b.mesh = std::make_unique<plumb::bim::BimMesh>(plumb::bim::build_mesh(plumb::bim::read_ifc(drive_model_path(name))));
  b.localizer = std::make_unique<BimLocalizer>(*b.mesh, plumb::bim::sample_bim_cloud(*b.mesh, 0.05));
  plumb::sim::ScenarioSettings s = plumb::sim::scenario_defaults(plumb::sim::ScenarioKind::kIndoor);
  s.seed = 11;
  const plumb::sim::ScenarioPlan plan = plumb::sim::plan_scenario(*b.mesh, s);
  b.T_base_lidar = s.T_base_lidar;
  plumb::Rng rng(2027);
  const double duration = plan.frame_stamps.back();
  plumb::sim::SweepSettings sweep;
  sweep.motion_distortion = false;
  const double dt = 0.02;
  for (int k = 0; k < 20; ++k) {
    const double t0 = rng.uniform(0.0, duration);
    if (static_cast<std::size_t>(k) % kDriveStride != 0) {
      b.drives.emplace_back();
      continue;
    }
    Drive d;
    double path = 0.0, next_view = 0.0;
    Eigen::Isometry3d previous = plan.trajectory.T_world_base(t0);
    for (double t = t0; t <= duration && path <= kMaxDrive + 1e-9; t += dt) {
      const Eigen::Isometry3d T = plan.trajectory.T_world_base(t);
      path += (T.translation() - previous.translation()).head<2>().norm();
      previous = T;
      if (path < next_view) continue;
      next_view += kViewSpacing;
      const Eigen::Isometry3d T_world_lidar = T * b.T_base_lidar;
      d.frames.push_back(plumb::sim::simulate_sweep(*plan.world, s.lidar, [&](double) { return T_world_lidar; }, t, rng, sweep));
      d.truth.push_back(T);
      d.motion.push_back(drifted(d.truth.front().inverse() * T, path));
    }
    b.drives.push_back(std::move(d));
  }
  return cache.emplace(name, std::move(b)).first->second;
}

struct DriveTally {
  int tried = 0, found = 0, wrong = 0;
  int twin_missed = 0;  ///< drives not found whose last try did not name the true place among its two
  std::vector<double> distances;  ///< metres driven when found
  std::vector<double> errors;     ///< of the first frame's pose [m]
};

/// Each drive: the first frame alone, then with one more frame per metre, until kOk (or the drive
/// ends). A kOk pose must be in the right place.
DriveTally localize_drives(const std::string& name, const DriveBuilding& b) {
  DriveTally t;
  for (std::size_t k = 0; k < b.drives.size(); k += kDriveStride) {
    const Drive& d = b.drives[k];
    if (d.frames.empty()) continue;
    ++t.tried;
    std::vector<LocalizerView> views;
    BimLocalization r;
    for (std::size_t v = 0; v < d.frames.size(); ++v) {
      views.push_back(LocalizerView{&d.frames[v], d.motion[v]});
      r = b.localizer->localize(views, b.T_base_lidar);
      const double e = (r.T_world_base.translation() - d.truth[0].translation()).head<2>().norm();
      const double ey = std::abs(plumb::wrap_angle(plumb::Pose2::from_isometry(r.T_world_base).theta - plumb::Pose2::from_isometry(d.truth[0]).theta));
      if (r.status != Status::kOk) continue;
      ++t.found;
      const bool right = e < 0.15 && ey < 1.0 * M_PI / 180.0;
      t.wrong += right ? 0 : 1;
      EXPECT_TRUE(right) << name << " drive " << k << " from " << views.size() << " frames: " << e << " m, "
                         << ey * 180.0 / M_PI << " deg off";
      t.distances.push_back(static_cast<double>(v) * kViewSpacing);
      t.errors.push_back(e);
      break;
    }
    if (r.status == Status::kOk || !r.ambiguous) continue;
    // Still ambiguous at the end of the drive: the true place is one of the two it names.
    const Eigen::Vector2d truth = d.truth[0].translation().head<2>();
    const double e_best = (r.T_world_base_search.translation().head<2>() - truth).norm();
    const double e_second = (r.T_world_base_second.translation().head<2>() - truth).norm();
    t.twin_missed += std::min(e_best, e_second) < 0.3 ? 0 : 1;
  }
  return t;
}

struct DriveCase {
  std::string name;
  int min_found;  ///< of 20 drives
};

class BimLocalizerDriveTest : public ::testing::TestWithParam<DriveCase> {};

// In FZK-Haus and the demo office every drive finds its start within 10 m, never in a wrong place.
// The duplex's two flats are congruent: turned half a turn about the building's centre, 99.8 % of
// the model's surface lies within 10 cm of the other flat's, so no drive that stays inside one flat
// can tell which one it is in. There the localizer must keep saying "ambiguous" (never pick one),
// and name the true place as one of its two; a start hint decides (BimLocalizerBuildingTest).
TEST_P(BimLocalizerDriveTest, StartsAreFoundWithinTenMetresNeverWrong) {
  const DriveCase& c = GetParam();
  if (c.name != "demo_office") {
    PLUMB_REQUIRE_DATA(path, "ifc/buildings/" + c.name + ".ifc");
  }
  const DriveBuilding& b = drive_building(c.name);
  const DriveTally t = localize_drives(c.name, b);
  EXPECT_EQ(t.wrong, 0);
  EXPECT_GE(t.found, c.min_found * t.tried / 20);
  EXPECT_EQ(t.twin_missed, 0);
}

INSTANTIATE_TEST_SUITE_P(Buildings, BimLocalizerDriveTest,
                         ::testing::Values(DriveCase{"demo_office", 20}, DriveCase{"AC20-FZK-Haus", 20},
                                           DriveCase{"duplex", 2}),
                         [](const ::testing::TestParamInfo<DriveCase>& param) {
                           std::string n = param.param.name;
                           std::replace(n.begin(), n.end(), '-', '_');
                           return n;
                         });

/// Fraction of `name`'s model surface (a 0.2 m sample, 0.1-6 m above the lowest point) that lies
/// within 10 cm of the model after a half turn about the vertical through the centre of its
/// footprint, refined by ICP (the model against itself).
double half_turn_congruence(const std::string& name) {
  const DriveBuilding& b = drive_building(name);
  const plumb::PointCloud cloud = plumb::bim::sample_bim_cloud(*b.mesh, 0.05);
  Eigen::AlignedBox3f box;
  for (const plumb::Vector3f& p : cloud.points) box.extend(p);
  plumb::PointCloud sample;
  for (std::size_t i = 0; i < cloud.size(); i += 16) {
    const float h = cloud.points[i].z() - box.min().z();
    if (h > 0.1f && h < 6.0f) sample.points.push_back(cloud.points[i]);
  }
  const Eigen::Vector3d centre = box.center().cast<double>();
  Eigen::Isometry3d turn = Eigen::Isometry3d::Identity();
  turn.linear() = Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  turn.translation() = centre - turn.linear() * centre;
  turn.translation().z() = 0.0;
  const plumb::KdTree3f tree(cloud);
  plumb::IcpSettings icp;
  icp.max_correspondence_distance = 0.3;
  const plumb::IcpResult r = plumb::align_icp(sample, cloud, tree, turn, icp);
  return plumb::overlap_ratio(sample, tree, r.T_target_source, 0.1).overlap;
}

// Why the duplex stays ambiguous: its model, turned half a turn about its centre, lies on itself
// (the two flats are one design placed twice). FZK-Haus, where every drive is found, has a shell
// that is symmetric too (walls, slabs and roof: about 90 % of its surface), but rooms that are not.
TEST(BimLocalizerDriveOtherTest, TheDuplexFlatsAreOneDesignTurnedHalfATurn) {
  PLUMB_REQUIRE_DATA(fzk, "ifc/buildings/AC20-FZK-Haus.ifc");
  PLUMB_REQUIRE_DATA(duplex, "ifc/buildings/duplex.ifc");
#if defined(__SANITIZE_ADDRESS__)
  GTEST_SKIP() << "a property of the models, not of the code: release builds";
#endif
  EXPECT_GT(half_turn_congruence("duplex"), 0.99);
  EXPECT_LT(half_turn_congruence("AC20-FZK-Haus"), 0.95);
}

// Drives from one building offered to another: with 3, 6 and 11 frames, none is accepted.
TEST(BimLocalizerDriveOtherTest, DrivesFromAnotherBuildingAreRejected) {
  PLUMB_REQUIRE_DATA(fzk, "ifc/buildings/AC20-FZK-Haus.ifc");
  PLUMB_REQUIRE_DATA(duplex, "ifc/buildings/duplex.ifc");
  const DriveBuilding& office = drive_building("demo_office");
  const DriveBuilding& house = drive_building("AC20-FZK-Haus");
  const DriveBuilding& flats = drive_building("duplex");
  int confident = 0, tried = 0;
  for (const auto& [from, into] : {std::pair{&office, &house}, std::pair{&house, &flats}, std::pair{&flats, &office}}) {
    for (std::size_t k = 0; k < from->drives.size(); k += 5 * kDriveStride) {
      const Drive& d = from->drives[k];
      for (const std::size_t n : {std::size_t{3}, std::size_t{6}, d.frames.size()}) {
        std::vector<LocalizerView> views;
        for (std::size_t v = 0; v < std::min(n, d.frames.size()); ++v) views.push_back(LocalizerView{&d.frames[v], d.motion[v]});
        confident += into->localizer->localize(views, from->T_base_lidar).status == Status::kOk ? 1 : 0;
        ++tried;
      }
    }
  }
  EXPECT_GT(tried, 0);
  EXPECT_EQ(confident, 0);
}

// The search's roots are split over threads and replayed in order, the refinement's ICP is
// threaded: every field of the result is that of one thread (nodes_scored, the work, aside).
TEST(BimLocalizerDriveOtherTest, ThreadsChangeNoResult) {
  const DriveBuilding& office = drive_building("demo_office");
  plumb::BimLocalizerSettings threaded = office.localizer->settings();
  threaded.threads = 3;
  const BimLocalizer three(*office.mesh, plumb::bim::sample_bim_cloud(*office.mesh, 0.05), threaded);
  for (std::size_t k = 0; k < office.drives.size(); k += 5 * kDriveStride) {
    const Drive& d = office.drives[k];
    for (const std::size_t n : {std::size_t{1}, std::size_t{4}}) {
      std::vector<LocalizerView> views;
      for (std::size_t v = 0; v < std::min(n, d.frames.size()); ++v) views.push_back(LocalizerView{&d.frames[v], d.motion[v]});
      const BimLocalization a = office.localizer->localize(views, office.T_base_lidar);
      const BimLocalization b = three.localize(views, office.T_base_lidar);
      EXPECT_EQ(a.status, b.status) << k << " " << n;
      EXPECT_TRUE(a.T_world_base.isApprox(b.T_world_base, 0.0)) << k << " " << n;
      EXPECT_TRUE(a.T_world_base_search.isApprox(b.T_world_base_search, 0.0)) << k << " " << n;
      EXPECT_TRUE(a.T_world_base_second.isApprox(b.T_world_base_second, 0.0)) << k << " " << n;
      EXPECT_EQ(a.score, b.score) << k << " " << n;
      EXPECT_EQ(a.second_score, b.second_score) << k << " " << n;
      EXPECT_EQ(a.ambiguous, b.ambiguous) << k << " " << n;
      EXPECT_EQ(a.see_through, b.see_through) << k << " " << n;
      EXPECT_EQ(a.rejected_by_free_space, b.rejected_by_free_space) << k << " " << n;
      EXPECT_EQ(a.fine.overlap, b.fine.overlap) << k << " " << n;
      EXPECT_EQ(a.second_overlap, b.second_overlap) << k << " " << n;
    }
  }
  threaded.threads = -1;
  EXPECT_THROW(BimLocalizer(*office.mesh, plumb::bim::sample_bim_cloud(*office.mesh, 0.2), threaded), plumb::Error);
}

TEST(BimLocalizerDriveOtherTest, BadViewsGiveAClearError) {
  const DriveBuilding& office = drive_building("demo_office");
  const BimLocalizer& loc = *office.localizer;
  EXPECT_THROW(loc.localize(std::vector<LocalizerView>{}, office.T_base_lidar), plumb::Error);
  EXPECT_THROW(loc.localize(std::vector<LocalizerView>{LocalizerView{}}, office.T_base_lidar), plumb::Error);
  const Drive& d = office.drives[0];
  Eigen::Isometry3d bad = Eigen::Isometry3d::Identity();
  bad.translation().y() = std::nan("");
  EXPECT_THROW(loc.localize({LocalizerView{&d.frames[0], Eigen::Isometry3d::Identity()}, LocalizerView{&d.frames[1], bad}},
                            office.T_base_lidar),
               plumb::Error);
  // One view is the single-frame localization, bit for bit.
  const BimLocalization one = loc.localize({LocalizerView{&d.frames[0], Eigen::Isometry3d::Identity()}}, office.T_base_lidar);
  const BimLocalization alone = loc.localize(d.frames[0], office.T_base_lidar);
  EXPECT_EQ(one.status, alone.status);
  EXPECT_EQ(one.score, alone.score);
  EXPECT_EQ(one.second_score, alone.second_score);
  EXPECT_TRUE(one.T_world_base.isApprox(alone.T_world_base, 0.0));
  EXPECT_EQ(one.views, 1u);
}

}  // namespace
