// SPDX-License-Identifier: BSD-3-Clause
// The fast paths of segment_frame() against their references: the frame sample against
// voxel_grid() + estimate_normals() on a kd-tree, the voxel-block normals against a brute-force
// reading of their definition, the normal-direction bins of the point + normal
// RANSAC against the plain inlier count, and the stages' handling of empty and bad input.
#include "plumb/segmentation/frame_sample.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "plumb/core/rng.hpp"
#include "plumb/filters/voxel_grid.hpp"
#include "plumb/io/cloud_io.hpp"
#include "plumb/search/kdtree.hpp"
#include "plumb/segmentation/ground.hpp"
#include "plumb/segmentation/plane_ransac.hpp"
#include "plumb/segmentation/vertical_planes.hpp"
#include "test_data.hpp"

#include "features/normals_detail.hpp"
#include "segmentation/frame_sample_detail.hpp"
#include "segmentation/plane_ransac_detail.hpp"

namespace plumb {
namespace {

constexpr float kNan = std::numeric_limits<float>::quiet_NaN();

bool same_bits(const Vector3f& a, const Vector3f& b) { return std::memcmp(a.data(), b.data(), sizeof(Vector3f)) == 0; }

/// sample_frame() must be voxel_grid() (nearest to centroid) plus kd-tree normals, bit for bit.
void expect_sample_matches_reference(const PointCloud& cloud, FrameSampleSettings s) {
  s.normals = FrameNormals::kNearest;
  const FrameSample sample = sample_frame(cloud, s);
  PointCloud xyz;
  xyz.points = cloud.points;
  VoxelGridSettings vs;
  vs.leaf_size = s.voxel_size;
  const VoxelGridResult ref = voxel_grid(xyz, vs);
  ASSERT_EQ(sample.status, Status::kOk);
  ASSERT_EQ(sample.source, ref.indices);
  ASSERT_EQ(sample.points.size(), ref.cloud.points.size());
  for (std::size_t j = 0; j < sample.points.size(); ++j) ASSERT_TRUE(same_bits(sample.points[j], ref.cloud.points[j])) << j;
  const KdTree<3> tree(ref.cloud.points);
  NormalSettings ns;
  ns.k = s.normal_k;
  ns.radius = s.normal_radius;
  ns.viewpoint = s.viewpoint;
  const NormalResult normals = estimate_normals(ref.cloud.points, tree, ref.cloud.points, ns);
  ASSERT_EQ(sample.normals.size(), normals.normals.size());
  std::size_t num_nan = 0;
  for (std::size_t j = 0; j < sample.normals.size(); ++j) {
    if (!(sample.points[j].z() <= s.normal_max_z)) {
      EXPECT_TRUE(std::isnan(sample.normals[j].x())) << j;
      continue;
    }
    // The same neighbours; only the order they are summed in may differ (rounding).
    const Vector3f& a = sample.normals[j];
    const Vector3f& b = normals.normals[j];
    ASSERT_EQ(std::isnan(a.x()), std::isnan(b.x())) << j;
    if (!std::isnan(a.x())) {
      EXPECT_GT(a.dot(b), 0.99999f) << j;
    }
    num_nan += std::isnan(a.x()) ? 1 : 0;
  }
  EXPECT_LT(num_nan, sample.normals.size() / 2);
}

TEST(FrameSampleTest, SyntheticCloudWithFieldsAndNanMatchesVoxelGrid) {
  Rng rng(21);
  PointCloud cloud;
  for (int i = 0; i < 20000; ++i) {
    // a floor, a wall and clutter; duplicated points and points exactly on voxel borders
    const int kind = i % 4;
    Vector3f p;
    if (kind == 0) p = Vector3f(rng.uniform(-5, 5), rng.uniform(-5, 5), -1.5f + rng.normal(0, 0.01));
    if (kind == 1) p = Vector3f(3.0f + rng.normal(0, 0.01), rng.uniform(-5, 5), rng.uniform(-1.5, 1.5));
    if (kind == 2) p = Vector3f(rng.uniform(-5, 5), rng.uniform(-5, 5), rng.uniform(-1.5, 2));
    if (kind == 3) p = i % 8 == 3 ? cloud.points[i - 3] : Vector3f(0.3f * static_cast<float>(i % 17), 0.6f, -0.9f);
    cloud.points.push_back(p);
  }
  cloud.points[5] = Vector3f(kNan, 0, 0);
  cloud.points[77] = Vector3f::Constant(std::numeric_limits<float>::infinity());
  cloud.intensities.assign(cloud.size(), 1.0f);
  cloud.rings.assign(cloud.size(), 3);
  FrameSampleSettings s;
  expect_sample_matches_reference(cloud, s);
  s.voxel_size = 0.17;
  s.normal_max_z = 0.0f;
  expect_sample_matches_reference(cloud, s);
}

TEST(FrameSampleTest, RealFramesMatchVoxelGrid) {
  PLUMB_REQUIRE_DATA(hdl32, "cloud3d/hdl32_pair/251370668.pcd");
  PLUMB_REQUIRE_DATA(room, "cloud3d/pcl_room_scans/room_scan1.pcd");
  FrameSampleSettings s;
  expect_sample_matches_reference(io::read_cloud(hdl32), s);  // x y z intensity, no-return zeros
  s.voxel_size = 0.1;
  expect_sample_matches_reference(io::read_cloud(room), s);
}

/// kVoxelBlock normals against a brute-force reading of their definition: the k nearest (by float
/// squared distance) of the sample points whose voxel differs by at most one in x, y and z and that
/// lie within the radius; with fewer than normal_min_block of them, the k nearest within the radius
/// among all sample points. Voxels from floor((p - min) / leaf) with the finite points' minimum.
void expect_block_normals_match_brute_force(const PointCloud& cloud, const FrameSampleSettings& s) {
  const FrameSample sample = sample_frame(cloud, s);
  ASSERT_EQ(sample.status, Status::kOk);
  Vector3d lo = Vector3d::Constant(std::numeric_limits<double>::infinity());
  for (const Vector3f& p : cloud.points) {
    if (p.allFinite()) lo = lo.cwiseMin(p.cast<double>());
  }
  const std::size_t m = sample.points.size();
  std::vector<Eigen::Vector3i> cell(m);
  for (std::size_t j = 0; j < m; ++j) {
    for (int a = 0; a < 3; ++a) {
      cell[j][a] = static_cast<int>(std::floor((static_cast<double>(sample.points[j][a]) - lo[a]) / s.voxel_size));
    }
  }
  const float r_sq = s.normal_radius * s.normal_radius;
  auto d_sq = [&](std::size_t a, std::size_t b) {
    const float dx = sample.points[a].x() - sample.points[b].x(), dy = sample.points[a].y() - sample.points[b].y(),
                dz = sample.points[a].z() - sample.points[b].z();
    return dx * dx + dy * dy + dz * dz;
  };
  std::size_t num_valid = 0, num_sparse = 0;
  for (std::size_t j = 0; j < m; ++j) {
    if (!(sample.points[j].z() <= s.normal_max_z)) {
      EXPECT_TRUE(std::isnan(sample.normals[j].x())) << j;
      continue;
    }
    std::vector<std::pair<float, std::size_t>> block, all;
    for (std::size_t i = 0; i < m; ++i) {
      const float d = d_sq(i, j);
      if (!(d <= r_sq)) continue;
      all.emplace_back(d, i);
      if ((cell[i] - cell[j]).cwiseAbs().maxCoeff() <= 1) block.emplace_back(d, i);
    }
    std::vector<std::pair<float, std::size_t>>& use = block.size() >= s.normal_min_block ? block : all;
    num_sparse += block.size() >= s.normal_min_block ? 0 : 1;
    std::sort(use.begin(), use.end());
    if (use.size() > s.normal_k) use.resize(s.normal_k);
    std::vector<std::size_t> idx;
    for (const auto& u : use) idx.push_back(u.second);
    Vector3f ref;
    float curv = 0.0f;
    const bool ok = detail::pca_normal(sample.points, idx.data(), idx.size(), ref, curv);
    ASSERT_EQ(ok, !std::isnan(sample.normals[j].x())) << j;
    if (!ok) continue;
    if (ref.dot(s.viewpoint - sample.points[j]) < 0.0f) ref = -ref;
    EXPECT_GT(ref.dot(sample.normals[j]), 0.99999f) << j;
    ++num_valid;
  }
  EXPECT_GT(num_valid, m / 2);
  EXPECT_GT(num_sparse, 0u);  // both branches are exercised
  EXPECT_LT(num_sparse, m / 2);
}

TEST(FrameSampleTest, VoxelBlockNormalsMatchTheirDefinition) {
  Rng rng(5);
  PointCloud cloud;  // a floor, a tilted wall, a sparse far patch and clutter
  for (int i = 0; i < 12000; ++i) {
    const int kind = i % 4;
    if (kind == 0) cloud.points.emplace_back(rng.uniform(-4, 4), rng.uniform(-4, 4), -1.5f + rng.normal(0, 0.01));
    if (kind == 1) {
      const float t = rng.uniform(-3, 3), h = rng.uniform(-1.5, 1.5);
      cloud.points.emplace_back(2.5f + 0.3f * t + rng.normal(0, 0.01), t, h);
    }
    if (kind == 2) cloud.points.emplace_back(rng.uniform(-12, -8), rng.uniform(-6, 6), rng.uniform(-1.5, -1.2));
    if (kind == 3) cloud.points.emplace_back(rng.uniform(-4, 4), rng.uniform(-4, 4), rng.uniform(-1.5, 2));
  }
  cloud.points[9] = Vector3f(kNan, 1, 1);
  FrameSampleSettings s;
  expect_block_normals_match_brute_force(cloud, s);
  s.normal_k = 5;
  s.normal_min_block = 8;
  s.normal_max_z = 0.0f;
  s.voxel_size = 0.25;
  expect_block_normals_match_brute_force(cloud, s);
}

TEST(FrameSampleTest, VoxelBlockNormalsOnARealFrame) {
  PLUMB_REQUIRE_DATA(hdl32, "cloud3d/hdl32_pair/251371071.pcd");
  expect_block_normals_match_brute_force(io::read_cloud(hdl32), FrameSampleSettings{});
}

// The trigonometry-free smallest eigenvector against Eigen's closed form (normal_from_covariance):
// the same normal (as a line) and the same verdict on degenerate neighbourhoods, for flat, thin,
// isotropic, collinear, coincident and badly scaled point sets.
TEST(FrameSampleTest, FastCovarianceNormalMatchesClosedForm) {
  Rng rng(31);
  int num_checked = 0;
  for (int trial = 0; trial < 3000; ++trial) {
    const int kind = trial % 6;
    const double scale = std::pow(10.0, rng.uniform(-3, 3));
    const Eigen::Matrix3d R = Eigen::Quaterniond(rng.normal(), rng.normal(), rng.normal(), rng.normal()).normalized().toRotationMatrix();
    Eigen::Vector3d sd(1.0, rng.uniform(0.05, 1.0), rng.uniform(0.0, 0.05));  // flat
    if (kind == 1) sd.z() = rng.uniform(0.0, 1e-4);                         // very flat
    if (kind == 2) sd = Eigen::Vector3d(1.0, rng.uniform(0.9, 1.0), rng.uniform(0.9, 1.0));  // isotropic
    if (kind == 3) sd = Eigen::Vector3d(1.0, std::pow(10.0, rng.uniform(-6, -1)), 0.0);  // thin to collinear
    if (kind == 4) sd = Eigen::Vector3d::Zero();                           // coincident
    std::vector<Vector3f> pts;
    for (int i = 0; i < 3 + trial % 20; ++i) {
      const Eigen::Vector3d local(sd.x() * rng.normal(), sd.y() * rng.normal(), sd.z() * rng.normal());
      pts.push_back((Eigen::Vector3d(5, -2, 1) + scale * (R * local)).cast<float>());
    }
    std::vector<std::size_t> idx(pts.size());
    for (std::size_t i = 0; i < idx.size(); ++i) idx[i] = i;
    const Eigen::Matrix3d cov = detail::neighbourhood_covariance(pts, idx.data(), idx.size());
    Vector3f ref = Vector3f::Zero(), fast = Vector3f::Zero();
    float curv = 0.0f;
    const bool ok_ref = detail::normal_from_covariance(cov, ref, curv);
    const bool ok_fast = detail::normal_from_covariance_fast(cov, fast);
    ASSERT_EQ(ok_fast, ok_ref) << "trial " << trial;
    if (!ok_ref) continue;
    EXPECT_NEAR(fast.norm(), 1.0f, 1e-5f) << trial;
    // isotropic sets have no stable normal: both sides only have to agree where there is one
    if (kind != 2) {
      EXPECT_GT(std::abs(fast.dot(ref)), 0.99999f) << "trial " << trial << " kind " << kind;
    }
    ++num_checked;
  }
  EXPECT_GT(num_checked, 1500);
}

TEST(FrameSampleTest, EmptyNanAndBadSettings) {
  PointCloud empty;
  EXPECT_EQ(sample_frame(empty).status, Status::kInsufficientData);
  PointCloud nan;
  nan.points.assign(10, Vector3f::Constant(kNan));
  const FrameSample n = sample_frame(nan);
  EXPECT_EQ(n.status, Status::kInsufficientData);
  EXPECT_TRUE(n.points.empty());
  EXPECT_EQ(n.num_finite, 0u);
  PointCloud one_voxel;  // three finite points in one voxel: a sample of one point
  one_voxel.points = {{0, 0, 0}, {0.01f, 0, 0}, {0, 0.01f, 0}, {kNan, 0, 0}};
  const FrameSample o = sample_frame(one_voxel);
  EXPECT_EQ(o.status, Status::kInsufficientData);
  EXPECT_EQ(o.num_finite, 3u);
  EXPECT_TRUE(o.source.empty());

  PointCloud ok;
  ok.points = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  FrameSampleSettings s;
  s.voxel_size = 0.0;
  EXPECT_THROW(sample_frame(ok, s), Error);
  s.voxel_size = std::nan("");
  EXPECT_THROW(sample_frame(ok, s), Error);
  s = {};
  s.normal_k = 2;
  EXPECT_THROW(sample_frame(ok, s), Error);
  s = {};
  s.normal_max_z = kNan;
  EXPECT_THROW(sample_frame(ok, s), Error);
  ok.times = {0.0f};
  EXPECT_THROW(sample_frame(ok), Error);
}

// The bins skip only groups of candidates none of which can agree with the hypothesis: their count
// equals the plain count for any hypothesis, any candidate normals (tilted, zero, not unit) and any
// axis, including when the count gives up early against a best count to beat.
TEST(FrameSampleTest, NormalBinsCountEqualsPlainCount) {
  Rng rng(8);
  for (int trial = 0; trial < 6; ++trial) {
    const Vector3d axis = trial < 3 ? Vector3d::UnitZ()
                                    : Vector3d(rng.normal(), rng.normal(), rng.normal()).normalized();
    detail::PlaneCandidates c;
    c.has_normals = true;
    const int n = 3000;
    for (int i = 0; i < n; ++i) {
      // walls around the axis (normals across it, a few degrees off), plus arbitrary normals
      const double a = rng.uniform(0, 2 * 3.14159265358979323846);
      const Vector3d e1 = axis.unitOrthogonal(), e2 = axis.cross(e1);
      Vector3d nn = std::cos(a) * e1 + std::sin(a) * e2 + rng.normal(0, 0.05) * axis;
      if (i % 5 == 0) nn = Vector3d(rng.normal(), rng.normal(), rng.normal());
      nn.normalize();
      if (i % 97 == 0) nn.setZero();               // a NaN normal is stored as zero
      if (i % 89 == 0) nn *= 1.0 + 1e-6;           // not exactly unit
      const Vector3d p(rng.uniform(-5, 5), rng.uniform(-5, 5), rng.uniform(-5, 5));
      c.x.push_back(static_cast<float>(p.x()));
      c.y.push_back(static_cast<float>(p.y()));
      c.z.push_back(static_cast<float>(p.z()));
      c.nx.push_back(static_cast<float>(nn.x()));
      c.ny.push_back(static_cast<float>(nn.y()));
      c.nz.push_back(static_cast<float>(nn.z()));
      c.index.push_back(static_cast<std::size_t>(i));
    }
    detail::NormalBins bins;
    bins.build(c, axis);
    for (int h = 0; h < 400; ++h) {
      // hypotheses: candidate normals (as RANSAC draws them) and random directions
      const int i = static_cast<int>(rng.uniform_index(n));
      Vector3d nrm = h % 3 == 0 ? Vector3d(rng.normal(), rng.normal(), rng.normal())
                                : Vector3d(c.nx[i], c.ny[i], c.nz[i]);
      if (!(nrm.norm() > 0.0)) continue;
      nrm.normalize();
      const double d = nrm.dot(Vector3d(c.x[i], c.y[i], c.z[i]));
      const float cos_max = static_cast<float>(std::cos(rng.uniform(0.05, 1.4)));
      const float tau = static_cast<float>(rng.uniform(0.05, 3.0));
      const float a = static_cast<float>(nrm.x()), b = static_cast<float>(nrm.y()), cc = static_cast<float>(nrm.z()),
                  df = static_cast<float>(d);
      const std::size_t plain = detail::count_plane_inliers(c, a, b, cc, df, tau, cos_max, 0);
      ASSERT_EQ(bins.count(nrm, a, b, cc, df, tau, cos_max, 0), plain) << "trial " << trial << " hypothesis " << h;
      // against a count to beat: either the same count, or both give up at or below it
      const std::size_t beat = static_cast<std::size_t>(rng.uniform_index(2 * plain + 2));
      const std::size_t early = bins.count(nrm, a, b, cc, df, tau, cos_max, beat);
      if (plain > beat) {
        EXPECT_EQ(early, plain);
      } else {
        EXPECT_LE(early, beat);
      }
    }
  }
}

TEST(FrameSampleTest, StagesOnEmptyOrMismatchedSamples) {
  PointCloud empty;
  EXPECT_EQ(extract_ground(empty).status, Status::kInsufficientData);
  PointCloud nan;
  nan.points.assign(50, Vector3f::Constant(kNan));
  EXPECT_EQ(extract_ground(nan).status, Status::kInsufficientData);
  const FrameSample none = sample_frame(nan);
  const VerticalPlanesResult v = extract_vertical_planes(nan, none, nullptr);
  EXPECT_EQ(v.status, Status::kInsufficientData);
  EXPECT_EQ(v.plane_of_point, std::vector<std::int32_t>(50, -1));

  // A sample taken from another cloud is misuse: plumb::Error, not a crash.
  Rng rng(2);
  PointCloud big;
  for (int i = 0; i < 2000; ++i) big.points.emplace_back(rng.uniform(-3, 3), rng.uniform(-3, 3), -1.0f);
  const FrameSample sample = sample_frame(big);
  ASSERT_EQ(sample.status, Status::kOk);
  PointCloud small;
  small.points.assign(10, Vector3f(0, 0, -1));
  EXPECT_THROW(extract_ground(small, sample), Error);
  EXPECT_THROW(extract_vertical_planes(small, sample, nullptr), Error);
  FrameSample broken = sample;
  broken.normals.pop_back();
  EXPECT_THROW(extract_ground(big, broken), Error);
  EXPECT_THROW(extract_vertical_planes(big, broken, nullptr), Error);
}

}  // namespace
}  // namespace plumb
