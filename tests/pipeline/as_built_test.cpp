// SPDX-License-Identifier: BSD-3-Clause
// AsBuiltMap on a room whose walls are displaced by known amounts, key points sampled on the true
// (as-built) surfaces and registered with a pose error of their own: the online estimate equals the
// batch least-squares solution over every pose and element; what the frames can tell apart (one
// wall against the opposite one) matches the truth; what no frame constrains keeps the
// construction tolerance, and a wall the frame's own pose error can absorb gains no confidence; the
// corrected cloud and the deviation report follow the estimate.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "plumb/core/error.hpp"
#include "plumb/core/lie.hpp"
#include "plumb/pipeline/as_built.hpp"
#include "plumb/search/kdtree.hpp"

namespace plumb {
namespace {

constexpr double kLength = 8.0, kWidth = 6.0, kHeight = 3.0, kSpacing = 0.1;
enum Element { kFloor = 0, kSouth = 1, kNorth = 2, kWest = 3, kEast = 4, kAway = 5, kNumElements = 6 };

/// Points of a rectangle origin + u s + v t (s in [0, 1], t in [0, 1]) every kSpacing, with normal n.
void add_rectangle(PointCloud& c, const Vector3d& origin, const Vector3d& u, const Vector3d& v, const Vector3d& n,
                   int label) {
  const int nu = static_cast<int>(std::round(u.norm() / kSpacing)), nv = static_cast<int>(std::round(v.norm() / kSpacing));
  for (int i = 0; i <= nu; ++i) {
    for (int j = 0; j <= nv; ++j) {
      c.points.push_back((origin + u * (i / double(nu)) + v * (j / double(nv))).cast<float>());
      c.normals.push_back(n.cast<float>());
      c.labels.push_back(label);
    }
  }
}

/// The design: a floor, four walls facing in, and a wall far away that no frame sees.
PointCloud design_room() {
  PointCloud c;
  add_rectangle(c, {0, 0, 0}, {kLength, 0, 0}, {0, kWidth, 0}, {0, 0, 1}, kFloor);
  add_rectangle(c, {0, 0, 0}, {kLength, 0, 0}, {0, 0, kHeight}, {0, 1, 0}, kSouth);
  add_rectangle(c, {0, kWidth, 0}, {kLength, 0, 0}, {0, 0, kHeight}, {0, -1, 0}, kNorth);
  add_rectangle(c, {0, 0, 0}, {0, kWidth, 0}, {0, 0, kHeight}, {1, 0, 0}, kWest);
  add_rectangle(c, {kLength, 0, 0}, {0, kWidth, 0}, {0, 0, kHeight}, {-1, 0, 0}, kEast);
  add_rectangle(c, {30, 0, 0}, {0, 4, 0}, {0, 0, kHeight}, {1, 0, 0}, kAway);
  return c;
}

Vector3d centroid_of(const PointCloud& c, int label) {
  Vector3d s = Vector3d::Zero();
  int n = 0;
  for (std::size_t i = 0; i < c.size(); ++i) {
    if (c.labels[i] == label) s += c.points[i].cast<double>(), ++n;
  }
  return s / n;
}

/// The true displacements: the south wall 2 cm into the room, the west wall turned 0.3 deg about
/// z (its ends 1.6 cm off), the east wall 1 cm into the room; the rest as designed.
std::vector<Eigen::Isometry3d> true_displacements(const PointCloud& design) {
  std::vector<Eigen::Isometry3d> T(kNumElements, Eigen::Isometry3d::Identity());
  T[kSouth].translation() = Vector3d(0, 0.02, 0);
  const Vector3d c = centroid_of(design, kWest);
  T[kWest] = Eigen::Translation3d(c) * Eigen::AngleAxisd(0.3 * kPi / 180.0, Vector3d::UnitZ()) * Eigen::Translation3d(-c);
  T[kEast].translation() = Vector3d(-0.01, 0, 0);
  return T;
}

struct Scene {
  PointCloud design = design_room();
  std::vector<Eigen::Isometry3d> truth = true_displacements(design);
  KdTree3f tree{design.points};
};

/// The displacement of element e at design point q, estimated and true.
Vector3d estimated_at(const AsBuiltMap& map, int e, const Vector3d& q) {
  return map.element(static_cast<std::size_t>(e)).displacement(q);
}
Vector3d true_at(const Scene& s, int e, const Vector3d& q) { return s.truth[static_cast<std::size_t>(e)] * q - q; }

/// One frame from `robot`: key points on the true surfaces of `elements` (3 mm noise along the
/// normal), placed by a registered pose that is off by a small random motion, each paired with its
/// nearest design point. Junction handling, gating and weighting are AsBuiltMap's.
std::vector<IcpCorrespondence> frame_pairs(const Scene& s, const Vector3d& robot, const std::vector<int>& elements,
                                           std::mt19937& rng) {
  std::normal_distribution<double> noise(0.0, 0.003), pose_t(0.0, 0.01), pose_r(0.0, 0.1 * kPi / 180.0);
  const Eigen::Isometry3d pose_error =
      Eigen::Translation3d(robot + Vector3d(pose_t(rng), pose_t(rng), pose_t(rng))) *
      Eigen::AngleAxisd(pose_r(rng), Vector3d::UnitZ()) * Eigen::AngleAxisd(pose_r(rng), Vector3d::UnitX()) *
      Eigen::Translation3d(-robot);
  std::uniform_int_distribution<std::size_t> pick(0, s.design.size() - 1);
  std::vector<IcpCorrespondence> pairs;
  for (int k = 0; k < 4000 && pairs.size() < 600; ++k) {
    const std::size_t i = pick(rng);
    const int e = s.design.labels[i];
    if (std::find(elements.begin(), elements.end(), e) == elements.end()) continue;
    const Vector3d n = s.design.normals[i].cast<double>();
    const Vector3d as_built = s.truth[static_cast<std::size_t>(e)] * s.design.points[i].cast<double>() + noise(rng) * n;
    IcpCorrespondence c;
    c.x = pose_error * as_built;
    std::size_t j = 0;
    float d2 = 0.0f;
    s.tree.knn(c.x.cast<float>(), 1, &j, &d2);
    c.target_index = j;
    c.q = s.design.points[j].cast<double>();
    c.n = s.design.normals[j].cast<double>();
    pairs.push_back(c);
  }
  return pairs;
}

/// The true displacement of design point q of element e along n.
double true_offset(const Scene& s, int e, const Vector3d& q, const Vector3d& n) {
  return n.dot(s.truth[static_cast<std::size_t>(e)] * q - q);
}

/// Drive a circle through the room, every frame seeing `elements`.
AsBuiltMap drive(const Scene& s, const std::vector<int>& elements, int frames = 60) {
  AsBuiltMap map(s.design);
  std::mt19937 rng(7);
  for (int f = 0; f < frames; ++f) {
    const double a = 2.0 * kPi * f / frames;
    const Vector3d robot(4.0 + 2.0 * std::cos(a), 3.0 + 1.5 * std::sin(a), 0.5);
    EXPECT_GT(map.observe(frame_pairs(s, robot, elements, rng), robot), 0u);
  }
  return map;
}

TEST(AsBuiltMapTest, WhatTheFramesCanTellApartMatchesTheTruth) {
  // A frame's pose error moves every wall it sees alike, so the frames measure the walls against
  // each other: the gap between opposite walls, and how the west wall turns against the east one.
  const Scene s;
  const AsBuiltMap map = drive(s, {kFloor, kSouth, kNorth, kWest, kEast});
  const Vector3d q_south(4.0, 0.0, 1.5), q_north(4.0, kWidth, 1.5);
  const double gap_est = estimated_at(map, kSouth, q_south).y() - estimated_at(map, kNorth, q_north).y();
  const double gap_true = true_at(s, kSouth, q_south).y() - true_at(s, kNorth, q_north).y();
  EXPECT_NEAR(gap_est, gap_true, 0.002);
  for (double y : {0.5, 3.0, 5.5}) {  // along the turned west wall, against the east wall
    const Vector3d q_west(0.0, y, 1.5), q_east(kLength, y, 1.5);
    const double est = estimated_at(map, kWest, q_west).x() - estimated_at(map, kEast, q_east).x();
    const double truth = true_at(s, kWest, q_west).x() - true_at(s, kEast, q_east).x();
    EXPECT_NEAR(est, truth, 0.002) << "y " << y;
  }
  // Each wall alone: the common shift of two opposite walls is the frames' blind spot, so each
  // keeps 1/sqrt(2) of the prior across itself, and the estimate is within it.
  for (int e : {kSouth, kNorth, kWest, kEast}) {
    const ElementEstimate est = map.element(static_cast<std::size_t>(e));
    ASSERT_GT(est.face_observations, 100u) << "element " << e;
    const double ratio = est.face_offset_sigma() / map.settings().sigma_translation;
    EXPECT_GT(ratio, 0.6) << "element " << e;
    EXPECT_LT(ratio, 0.8) << "element " << e;
    EXPECT_NEAR(est.face_offset(), true_offset(s, e, est.face_point, est.face_normal), 3.0 * est.face_offset_sigma());
  }
}

TEST(AsBuiltMapTest, OnlineEstimateEqualsTheBatchSolution) {
  // With every pair counted alike (no cap, no decorrelation, no junctions), the map's estimate is
  // the least-squares solution over all frames' pose errors and all elements at once, under the
  // same priors: solved here densely, in one piece.
  const Scene s;
  AsBuiltSettings set;
  set.max_points_per_element = 1e9;
  set.decorrelation_distance = 0.0;
  set.junction_radius = 0.0;
  set.max_residual = 1.0;
  AsBuiltMap map(s.design, set);
  const int frames = 8, ne = kNumElements, n = 6 * (ne + frames);
  Eigen::MatrixXd H = Eigen::MatrixXd::Zero(n, n);
  Eigen::VectorXd g = Eigen::VectorXd::Zero(n);
  for (int e = 0; e < ne; ++e) {
    for (int r = 0; r < 6; ++r) H(6 * e + r, 6 * e + r) = 1.0 / std::pow(r < 3 ? set.sigma_translation : set.sigma_rotation, 2);
  }
  std::mt19937 rng(11);
  std::vector<Vector3d> pivots;
  for (int e = 0; e < ne; ++e) pivots.push_back(centroid_of(s.design, e));
  const double w = 1.0 / (set.point_sigma * set.point_sigma);
  for (int f = 0; f < frames; ++f) {
    const Vector3d robot(2.0 + 0.5 * f, 2.0 + 0.2 * f, 0.5);
    const std::vector<IcpCorrespondence> pairs = frame_pairs(s, robot, {kFloor, kSouth, kNorth, kWest, kEast}, rng);
    ASSERT_EQ(map.observe(pairs, robot), pairs.size());
    const int p = 6 * (ne + f);
    for (int r = 0; r < 6; ++r) H(p + r, p + r) += 1.0 / std::pow(r < 3 ? set.pose_sigma_translation : set.pose_sigma_rotation, 2);
    for (const IcpCorrespondence& c : pairs) {
      const int e = s.design.labels[c.target_index];
      const Vector3d q = s.design.points[c.target_index].cast<double>();
      const Vector3d nn = s.design.normals[c.target_index].cast<double>();
      // residual n.(x - q) + n.(v + w x (x - robot)) - n.(t + w_e x (q - c_e))
      Eigen::VectorXd J = Eigen::VectorXd::Zero(n);
      J.segment<3>(p) = nn;
      J.segment<3>(p + 3) = (c.x - robot).cross(nn);
      J.segment<3>(6 * e) = -nn;
      J.segment<3>(6 * e + 3) = -(q - pivots[static_cast<std::size_t>(e)]).cross(nn);
      H += w * J * J.transpose();
      g += w * nn.dot(c.x - q) * J;
    }
  }
  const Eigen::VectorXd batch = -H.ldlt().solve(g);
  const Eigen::MatrixXd batch_cov = H.inverse();
  for (int e = 0; e < ne; ++e) {
    const ElementEstimate est = map.element(static_cast<std::size_t>(e));
    EXPECT_LT((est.mean - batch.segment<6>(6 * e)).norm(), 1e-9) << "element " << e;
    EXPECT_LT((est.covariance - batch_cov.block<6, 6>(6 * e, 6 * e)).norm(), 1e-9 * batch_cov.norm()) << "element " << e;
  }
}

TEST(AsBuiltMapTest, WhatNoFrameConstrainsKeepsThePrior) {
  const Scene s;
  const AsBuiltMap map = drive(s, {kFloor, kSouth, kNorth, kWest, kEast});
  const double prior_t = map.settings().sigma_translation;
  // Never observed: the prior exactly, zero mean.
  const ElementEstimate away = map.element(kAway);
  EXPECT_EQ(away.observations, 0u);
  EXPECT_TRUE(away.mean.isZero(0.0));
  EXPECT_NEAR(std::sqrt(away.covariance(0, 0)), prior_t, 1e-12);
  // A wall slides along itself unseen: its in-plane translations keep (nearly) the prior.
  const ElementEstimate south = map.element(kSouth);
  EXPECT_GT(std::sqrt(south.covariance(0, 0)), 0.9 * prior_t);  // x, along the south wall
  EXPECT_LT(std::sqrt(south.covariance(1, 1)), 0.8 * prior_t);  // y, across it
}

TEST(AsBuiltMapTest, AWallThePoseErrorCanAbsorbGainsNoConfidence) {
  // Every frame sees the floor and the south wall only: a shift of that wall across itself looks
  // exactly like the frame's pose being off, so the frames say nothing about it.
  const Scene s;
  const AsBuiltMap map = drive(s, {kFloor, kSouth});
  const ElementEstimate south = map.element(kSouth);
  EXPECT_GT(south.face_observations, 100u);
  EXPECT_GT(south.face_offset_sigma(), 0.9 * map.settings().sigma_translation);
  EXPECT_LT(std::abs(south.face_offset()), 0.01);  // not the 2 cm the pose absorbed
}

TEST(AsBuiltMapTest, DisplacedPointsAreTheSameOnAnyNumberOfThreads) {
  // The room cloud repeated until it spans several of displaced_points()' chunks, every element moved.
  const Scene s;
  PointCloud design;
  while (design.size() < 200000) {
    design.points.insert(design.points.end(), s.design.points.begin(), s.design.points.end());
    design.normals.insert(design.normals.end(), s.design.normals.begin(), s.design.normals.end());
    design.labels.insert(design.labels.end(), s.design.labels.begin(), s.design.labels.end());
  }
  std::mt19937 gen(7);
  std::normal_distribution<double> shift(0.0, 0.01), turn(0.0, 0.0035);
  Eigen::VectorXd mean(6 * kNumElements);
  for (Eigen::Index i = 0; i < mean.size(); ++i) mean[i] = (i % 6) < 3 ? shift(gen) : turn(gen);
  const std::vector<Vector3d> pivots = element_centroids(design);
  std::vector<std::uint32_t> band;
  for (std::size_t i = 0; i < design.size(); i += 1 + i % 3) band.push_back(static_cast<std::uint32_t>(i));
  PointCloud one, whole_one;
  displaced_points(design, band, mean, pivots, one, 1);
  displaced_points(design, mean, pivots, whole_one, 1);
  ASSERT_EQ(one.size(), band.size());
  // The first thread's answer is the displacement itself.
  for (std::size_t k = 0; k < band.size(); k += 997) {
    const std::size_t i = band[k];
    const Eigen::Index e = 6 * design.labels[i];
    const Vector3d q = design.points[i].cast<double>();
    const Vector3d moved = q + mean.segment<3>(e) + mean.segment<3>(e + 3).cross(q - pivots[static_cast<std::size_t>(design.labels[i])]);
    EXPECT_LT((one.points[k].cast<double>() - moved).norm(), 1e-5) << "point " << i;
    EXPECT_EQ(one.points[k], whole_one.points[i]);
  }
  for (const int threads : {2, 3, 0}) {
    PointCloud other, whole_other;
    displaced_points(design, band, mean, pivots, other, threads);
    displaced_points(design, mean, pivots, whole_other, threads);
    EXPECT_EQ(other.points, one.points) << threads << " threads";
    EXPECT_EQ(other.normals, one.normals) << threads << " threads";
    EXPECT_EQ(other.labels, one.labels) << threads << " threads";
    EXPECT_EQ(whole_other.points, whole_one.points) << threads << " threads";
  }
  // A bad index is named the same way whichever thread meets it.
  band[band.size() - 10] = static_cast<std::uint32_t>(design.size() + 5);
  for (const int threads : {1, 2}) {
    PointCloud out;
    try {
      displaced_points(design, band, mean, pivots, out, threads);
      ADD_FAILURE() << "expected plumb::Error";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("index " + std::to_string(design.size() + 5)), std::string::npos) << e.what();
    }
  }
  PointCloud out;
  EXPECT_THROW(displaced_points(design, mean, pivots, out, -1), Error);
}

TEST(AsBuiltMapTest, CorrectedCloudMovesEachPointByItsElementsEstimate) {
  const Scene s;
  const AsBuiltMap map = drive(s, {kFloor, kSouth, kNorth, kWest, kEast});
  const PointCloud corrected = map.corrected_cloud();
  ASSERT_EQ(corrected.size(), s.design.size());
  EXPECT_EQ(corrected.labels, s.design.labels);
  for (std::size_t i = 0; i < s.design.size(); i += 37) {
    const int e = s.design.labels[i];
    const Vector3d q = s.design.points[i].cast<double>();
    const Vector3d moved = q + estimated_at(map, e, q);
    EXPECT_LT((corrected.points[i].cast<double>() - moved).norm(), 1e-5) << "point " << i;
    const Vector3d w = map.element(static_cast<std::size_t>(e)).mean.tail<3>();
    const Vector3d n = s.design.normals[i].cast<double>();
    EXPECT_LT((corrected.normals[i].cast<double>() - (n + w.cross(n)).normalized()).norm(), 1e-6);
  }
  // The room as corrected has the true gap between the south and north walls; the design has not.
  const auto gap = [&](const PointCloud& c) {
    return centroid_of(c, kNorth).y() - centroid_of(c, kSouth).y();
  };
  PointCloud truth = s.design;
  for (std::size_t i = 0; i < truth.size(); ++i) {
    truth.points[i] = (s.truth[static_cast<std::size_t>(truth.labels[i])] * s.design.points[i].cast<double>()).cast<float>();
  }
  EXPECT_GT(std::abs(gap(s.design) - gap(truth)), 0.015);
  EXPECT_NEAR(gap(corrected), gap(truth), 0.002);
}

TEST(AsBuiltMapTest, DeviationReportJudgesOffsetsAgainstTheTolerance) {
  // The south and north walls both 4 cm into the room: their gap says so, and with nothing shared
  // to hide it, each one's offset is measured.
  Scene s;
  s.truth.assign(kNumElements, Eigen::Isometry3d::Identity());
  s.truth[kSouth].translation() = Vector3d(0, 0.04, 0);
  s.truth[kNorth].translation() = Vector3d(0, -0.04, 0);
  const AsBuiltMap map = drive(s, {kFloor, kSouth, kNorth, kWest, kEast});
  bim::BimMesh mesh;
  mesh.storeys.push_back({1, "Ground floor", 0.0});
  for (int e = 0; e < kNumElements; ++e) {
    bim::BimElement el;
    el.global_id = "element" + std::to_string(e);
    el.type = e == kFloor ? "IfcSlab" : "IfcWall";
    el.name = "name, \"" + std::to_string(e) + "\"";
    el.storey = 0;
    mesh.elements.push_back(el);
  }
  const std::vector<DeviationReportRow> rows = deviation_report(map, mesh, 0.01);
  ASSERT_EQ(rows.size(), static_cast<std::size_t>(kNumElements));
  EXPECT_EQ(rows[kSouth].status, DeviationStatus::kDeviates);  // 4 cm against 1 cm
  EXPECT_EQ(rows[kNorth].status, DeviationStatus::kDeviates);
  EXPECT_EQ(rows[kWest].status, DeviationStatus::kOk);
  EXPECT_EQ(rows[kEast].status, DeviationStatus::kOk);
  EXPECT_EQ(rows[kAway].status, DeviationStatus::kUnobserved);
  EXPECT_EQ(rows[kSouth].global_id, "element1");
  EXPECT_EQ(rows[kSouth].storey, "Ground floor");
  EXPECT_NEAR(rows[kSouth].normal.y(), 1.0, 1e-9);
  EXPECT_NEAR(rows[kSouth].offset_m, 0.04, 0.004);
  EXPECT_NEAR(rows[kNorth].offset_m, 0.04, 0.004);
  // A tolerance wider than the offsets: nothing deviates.
  for (const DeviationReportRow& r : deviation_report(map, mesh, 0.1)) EXPECT_NE(r.status, DeviationStatus::kDeviates);
  EXPECT_STREQ(deviation_status_name(rows[kAway].status), "unobserved");
  EXPECT_THROW(deviation_report(map, mesh, 0.0), Error);
  mesh.elements.pop_back();
  EXPECT_THROW(deviation_report(map, mesh, 0.01), Error);
}

TEST(AsBuiltMapTest, PairsAtJunctionsAreTheOnesNearAnotherElementsPoints) {
  // Every design point paired with itself (residual 0): observe() takes exactly the pairs whose
  // point has no point of another element within the junction radius, found here by comparing
  // every pair of points. The room spans several of the cells junctions are found in.
  const PointCloud design = design_room();
  std::vector<IcpCorrespondence> pairs(design.size());
  for (std::size_t i = 0; i < design.size(); ++i) {
    pairs[i].target_index = i;
    pairs[i].x = pairs[i].q = design.points[i].cast<double>();
    pairs[i].n = design.normals[i].cast<double>();
  }
  for (double radius : {0.13, 0.27}) {  // not a multiple of the spacing: no pair at exactly the radius
    std::size_t free = 0;
    for (std::size_t i = 0; i < design.size(); ++i) {
      bool junction = false;
      for (std::size_t j = 0; j < design.size() && !junction; ++j) {
        junction = design.labels[j] != design.labels[i] &&
                   (design.points[j] - design.points[i]).squaredNorm() <= static_cast<float>(radius * radius);
      }
      free += junction ? 0 : 1;
    }
    AsBuiltSettings set;
    set.junction_radius = radius;
    set.max_residual = 1.0;
    AsBuiltMap map(design, set);
    EXPECT_EQ(map.observe(pairs, Vector3d(4, 3, 0.5)), free) << radius;
    EXPECT_LT(free, design.size());
    EXPECT_GT(free, design.size() / 2);
  }
}

TEST(AsBuiltMapTest, ElementCentroidsAreTheCentresOfTheirRectangles) {
  PointCloud c = design_room();
  const std::size_t floor_points = static_cast<std::size_t>(std::count(c.labels.begin(), c.labels.end(), kFloor));
  // An unlabelled point far off and a label no point carries change nothing of the others.
  c.points.emplace_back(100.0f, 100.0f, 100.0f);
  c.normals.emplace_back(0.0f, 0.0f, 1.0f);
  c.labels.push_back(-1);
  c.labels[0] = kNumElements + 1;
  std::vector<std::size_t> count;
  const std::vector<Vector3d> centre = element_centroids(c, &count);
  ASSERT_EQ(centre.size(), static_cast<std::size_t>(kNumElements + 2));
  // Each element is a regular grid over its rectangle, so its centroid is the rectangle's centre
  // (the floor lost its corner point to the extra label: about 1 / 3000 of a point off).
  EXPECT_LT((centre[kSouth] - Vector3d(kLength / 2, 0, kHeight / 2)).norm(), 1e-5);
  EXPECT_LT((centre[kEast] - Vector3d(kLength, kWidth / 2, kHeight / 2)).norm(), 1e-5);
  EXPECT_LT((centre[kAway] - Vector3d(30, 2, kHeight / 2)).norm(), 1e-5);
  EXPECT_LT((centre[kFloor] - Vector3d(kLength / 2, kWidth / 2, 0)).norm(), 0.01);
  EXPECT_EQ(count[kFloor], floor_points - 1);
  EXPECT_EQ(count[kNumElements], 0u);
  EXPECT_TRUE(centre[kNumElements].isZero());
  EXPECT_EQ(count[kNumElements + 1], 1u);
  EXPECT_TRUE(centre[kNumElements + 1].isZero());  // the floor corner it took, at the origin
  c.labels.clear();
  EXPECT_THROW(element_centroids(c), Error);
}

TEST(AsBuiltMapTest, BadInputThrows) {
  PointCloud design = design_room();
  design.labels.clear();
  EXPECT_THROW(AsBuiltMap{design}, Error);
  design = design_room();
  design.normals.clear();
  EXPECT_THROW(AsBuiltMap{design}, Error);
  design = design_room();
  design.labels[3] = -2;
  EXPECT_THROW(AsBuiltMap{design}, Error);
  AsBuiltSettings bad;
  bad.sigma_translation = 0.0;
  EXPECT_THROW((AsBuiltMap{design_room(), bad}), Error);
  bad = {};
  bad.decorrelation_distance = -1.0;
  EXPECT_THROW((AsBuiltMap{design_room(), bad}), Error);
  AsBuiltMap map(design_room());
  EXPECT_THROW(map.element(kNumElements), Error);
  // Pairs naming no design point, or far from every element, are not used.
  IcpCorrespondence far;
  far.target_index = design_room().size() + 5;
  far.x = Vector3d(1, 1, 1);
  EXPECT_EQ(map.observe({far}, Vector3d::Zero()), 0u);
}

}  // namespace
}  // namespace plumb
