// SPDX-License-Identifier: BSD-3-Clause
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "plumb/features/fpfh.hpp"
#include "plumb/io/pcd.hpp"
#include "test_data.hpp"

#include "features/fpfh_detail.hpp"

namespace plumb {
namespace {

/// The fixture written by scripts/fpfh_golden/make_golden.py: Open3D's normals (float32) and its
/// FPFH features of every bunny point for two neighbourhood settings.
struct BunnyGolden {
  float normal_radius = 0.0f;
  std::size_t normal_max_nn = 0;
  std::vector<Vector3f> normals;
  struct Config {
    std::string name;
    float radius = 0.0f;
    std::size_t max_nn = 0;
    std::vector<FpfhSignature> features;
  };
  std::vector<Config> configs;
};

BunnyGolden read_golden() {
  const std::string path =
      test::source_dir() + "/tests/features/golden/bunny_open3d_fpfh.txt";
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot open " + path);
  BunnyGolden g;
  std::string line;
  std::size_t n = 0;
  auto next_line = [&]() {
    do {
      if (!std::getline(in, line)) throw std::runtime_error(path + ": truncated");
    } while (line.empty() || line[0] == '#');
  };
  std::string key;
  next_line();
  std::istringstream(line) >> key >> n;
  next_line();
  std::istringstream(line) >> key >> g.normal_radius >> g.normal_max_nn;
  for (std::size_t i = 0; i < n; ++i) {
    next_line();
    Vector3f v;
    std::istringstream(line) >> v.x() >> v.y() >> v.z();
    g.normals.push_back(v);
  }
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    BunnyGolden::Config c;
    std::istringstream(line) >> key >> c.name >> c.radius >> c.max_nn;
    for (std::size_t i = 0; i < n; ++i) {
      next_line();
      std::istringstream ls(line);
      FpfhSignature s{};
      for (float& b : s) ls >> b;
      if (!ls) throw std::runtime_error(path + ": bad feature line");
      c.features.push_back(s);
    }
    g.configs.push_back(c);
  }
  return g;
}

/// Every sub-histogram of `s` sums to `expected` (within rounding).
void expect_sub_sums(const FpfhSignature& s, float expected, const std::string& what) {
  for (int f = 0; f < 3; ++f) {
    double sum = 0.0;
    for (int j = 0; j < kFpfhBinsPerFeature; ++j) sum += s[f * kFpfhBinsPerFeature + j];
    EXPECT_NEAR(sum, expected, 1e-3 * expected) << what << " sub-histogram " << f;
  }
}

TEST(FpfhTest, MatchesOpen3dOnBunny) {
  PLUMB_REQUIRE_DATA(path, "cloud3d/pcl_test/bunny.pcd");
  PointCloud cloud = io::read_pcd(path);
  const BunnyGolden g = read_golden();
  ASSERT_EQ(cloud.size(), g.normals.size());
  ASSERT_EQ(g.configs.size(), 2u);
  cloud.normals = g.normals;  // the very normals Open3D described the points with
  for (const auto& c : g.configs) {
    FpfhSettings s;
    s.radius = c.radius;
    s.max_neighbors = c.max_nn;
    const FpfhResult r = compute_fpfh(cloud, s);
    ASSERT_EQ(r.features.size(), cloud.size());
    EXPECT_EQ(r.num_invalid, 0u);
    std::size_t num_bad = 0;
    float worst = 0.0f;
    for (std::size_t i = 0; i < cloud.size(); ++i) {
      expect_sub_sums(r.features[i], 200.0f, c.name + " point " + std::to_string(i));
      for (int j = 0; j < kFpfhBins; ++j) {
        const float diff = std::fabs(r.features[i][j] - c.features[i][j]);
        worst = std::max(worst, diff);
        if (diff > 1e-3f && ++num_bad <= 5) {
          ADD_FAILURE() << c.name << ": point " << i << " bin " << j << ": plumb "
                        << r.features[i][j] << ", Open3D " << c.features[i][j];
        }
      }
    }
    EXPECT_EQ(num_bad, 0u) << c.name << ": worst difference " << worst;
  }
}

PointCloud bunny_with_golden_normals() {
  PointCloud cloud = io::read_pcd(test::data_path("cloud3d/pcl_test/bunny.pcd"));
  cloud.normals = read_golden().normals;
  return cloud;
}

TEST(FpfhTest, HandComputedPair) {
  // p1 = 0 with normal +z, p2 = (1, 0, 0) with normal tilted 60 degrees toward +x. n2 makes the
  // smaller angle with the line, so p2 is the source: u = n2, d = p1 - p2 = -x,
  // theta = u.d = -sin 60 (bin floor(11 (1 - 0.866) / 2) = 0); v = unit(d x u) = +y,
  // phi = v.n1 = 0 (bin 5);
  // w = u x v = (-cos 60, 0, sin 60), alpha = atan2(w.n1, u.n1) = 60 deg (bin floor(11 * 4/6) = 7).
  PointCloud cloud;
  const float t = static_cast<float>(M_PI / 3.0);
  cloud.points = {Vector3f(0, 0, 0), Vector3f(1, 0, 0)};
  cloud.normals = {Vector3f(0, 0, 1), Vector3f(std::sin(t), 0, std::cos(t))};
  FpfhSettings s;
  s.radius = 1.5f;
  const FpfhResult r = compute_fpfh(cloud, s);
  ASSERT_EQ(r.features.size(), 2u);
  EXPECT_EQ(r.num_invalid, 0u);
  EXPECT_EQ(r.indices, (std::vector<std::size_t>{0, 1}));
  for (const auto& f : r.features) {
    for (int j = 0; j < kFpfhBins; ++j) {
      // SPFH(p) = 100 in each feature's bin; the weighted neighbour part, renormalised, adds 100
      const bool hit = j == 7 || j == 11 + 5 || j == 22 + 0;
      EXPECT_FLOAT_EQ(f[j], hit ? 200.0f : 0.0f) << "bin " << j;
    }
  }
}

TEST(FpfhTest, AngleBinMatchesAtan2) {
  // bin = floor(11 (atan2(y, x) + pi) / 2 pi), clamped, as Open3D computes it (in double)
  auto ref = [](double y, double x) {
    const int b = static_cast<int>(std::floor(11.0 * (std::atan2(y, x) + M_PI) / (2.0 * M_PI)));
    return std::min(std::max(b, 0), 10);
  };
  EXPECT_EQ(detail::fpfh_angle_bin(0.0f, 0.0f), 5);
  EXPECT_EQ(detail::fpfh_angle_bin(0.0f, 1.0f), 5);
  EXPECT_EQ(detail::fpfh_angle_bin(0.0f, -1.0f), 10);  // atan2(+0, -1) = pi
  EXPECT_EQ(detail::fpfh_angle_bin(1.0f, 0.0f), 8);
  EXPECT_EQ(detail::fpfh_angle_bin(-1.0f, 0.0f), 2);
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  int checked = 0;
  for (int t = 0; t < 200000; ++t) {
    const float y = static_cast<float>(u(rng)), x = static_cast<float>(u(rng));
    const double edge = 11.0 * (std::atan2(double(y), double(x)) + M_PI) / (2.0 * M_PI);
    if (std::fabs(edge - std::round(edge)) < 1e-5) continue;  // on a bin edge: either is right
    ASSERT_EQ(detail::fpfh_angle_bin(y, x), ref(y, x)) << "y " << y << " x " << x;
    ++checked;
  }
  EXPECT_GT(checked, 199000);
}

TEST(FpfhTest, RotationInvariantOnRealCloud) {
  PLUMB_REQUIRE_DATA(path, "cloud3d/pcl_test/bunny.pcd");
  const PointCloud cloud = bunny_with_golden_normals();
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() =
      Eigen::AngleAxisd(2.1, Eigen::Vector3d(0.3, -0.8, 0.5).normalized()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(3.0, -1.0, 0.5);
  const PointCloud moved = transformed(cloud, T);
  FpfhSettings s;
  s.radius = 0.03f;
  s.max_neighbors = 0;
  const FpfhResult a = compute_fpfh(cloud, s);
  const FpfhResult b = compute_fpfh(moved, s);
  ASSERT_EQ(a.features.size(), b.features.size());
  // Float rounding of the moved coordinates may move a pair feature lying on a bin edge into the
  // next bin (a few points at most); every other signature must be equal to rounding.
  std::size_t num_changed = 0;
  for (std::size_t i = 0; i < a.features.size(); ++i) {
    float l1 = 0.0f;
    for (int j = 0; j < kFpfhBins; ++j) l1 += std::fabs(a.features[i][j] - b.features[i][j]);
    if (l1 > 1e-2f) ++num_changed;
  }
  EXPECT_LE(num_changed, a.features.size() / 50) << "of " << a.features.size();
}

TEST(FpfhTest, KeyPointSubsetMatchesFullRun) {
  PLUMB_REQUIRE_DATA(path, "cloud3d/pcl_test/bunny.pcd");
  const PointCloud cloud = bunny_with_golden_normals();
  FpfhSettings s;
  s.radius = 0.025f;
  s.max_neighbors = 20;  // capped: the key points' neighbours keep their own capped lists
  const FpfhResult full = compute_fpfh(cloud, s);
  std::vector<std::size_t> keys;
  for (std::size_t i = cloud.size(); i-- > 0;) {
    if (i % 7 == 3) keys.push_back(i);  // descending order
  }
  keys.push_back(keys.front());  // a repeat
  const FpfhResult sub = compute_fpfh(cloud, s, &keys);
  ASSERT_EQ(sub.features.size(), keys.size());
  EXPECT_EQ(sub.indices, keys);
  for (std::size_t k = 0; k < keys.size(); ++k) {
    EXPECT_EQ(sub.features[k], full.features[keys[k]]) << "key " << keys[k];
  }
  const std::vector<std::size_t> none;
  EXPECT_TRUE(compute_fpfh(cloud, s, &none).features.empty());
}

TEST(FpfhTest, IsolatedAndInvalidPointsGetZeroSignature) {
  PointCloud cloud;
  std::mt19937 rng(2);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  for (int i = 0; i < 200; ++i) {
    cloud.points.emplace_back(u(rng), u(rng), 0.05f * u(rng));
    cloud.normals.push_back(Vector3f(0.1f * u(rng), 0.1f * u(rng), 1.0f).normalized());
  }
  const float nan = std::numeric_limits<float>::quiet_NaN();
  cloud.points.emplace_back(50.0f, 50.0f, 50.0f);  // 200: isolated
  cloud.normals.emplace_back(0.0f, 0.0f, 1.0f);
  cloud.points.emplace_back(0.5f, 0.5f, 0.0f);  // 201: NaN normal
  cloud.normals.emplace_back(nan, nan, nan);
  cloud.points.emplace_back(nan, 0.5f, 0.0f);  // 202: NaN point
  cloud.normals.emplace_back(0.0f, 0.0f, 1.0f);
  FpfhSettings s;
  s.radius = 0.2f;
  const FpfhResult r = compute_fpfh(cloud, s);
  EXPECT_EQ(r.num_invalid, 3u);
  const FpfhSignature zero{};
  for (std::size_t i = 200; i < 203; ++i) EXPECT_EQ(r.features[i], zero) << i;
  for (std::size_t i = 0; i < 200; ++i) {
    EXPECT_NE(r.features[i], zero) << i;
    expect_sub_sums(r.features[i], 200.0f, "point " + std::to_string(i));
  }
  // the invalid points are not neighbours of anyone: same signatures without them
  PointCloud clean = cloud;
  clean.points.resize(200);
  clean.normals.resize(200);
  const FpfhResult c = compute_fpfh(clean, s);
  for (std::size_t i = 0; i < 200; ++i) {
    // equal up to the summation order of the weighted neighbour part (the kd-trees differ)
    for (int j = 0; j < kFpfhBins; ++j) EXPECT_NEAR(r.features[i][j], c.features[i][j], 1e-4f) << i;
  }
  // a cap of 1 leaves only the point itself: nothing is describable
  s.max_neighbors = 1;
  EXPECT_EQ(compute_fpfh(cloud, s).num_invalid, cloud.size());
}

TEST(FpfhTest, BadInputThrows) {
  PointCloud cloud;
  EXPECT_THROW(compute_fpfh(cloud), Error);  // empty
  cloud.points = {Vector3f(0, 0, 0), Vector3f(0.1f, 0, 0), Vector3f(0, 0.1f, 0)};
  EXPECT_THROW(compute_fpfh(cloud), Error);  // no normals
  cloud.normals = {Vector3f(0, 0, 1), Vector3f(0, 0, 1)};
  EXPECT_THROW(compute_fpfh(cloud), Error);  // wrong number of normals
  cloud.normals.push_back(Vector3f(0, 0, 1));
  EXPECT_NO_THROW(compute_fpfh(cloud));
  for (const float radius : {0.0f, -1.0f, std::numeric_limits<float>::quiet_NaN(),
                             std::numeric_limits<float>::infinity()}) {
    FpfhSettings s;
    s.radius = radius;
    EXPECT_THROW(compute_fpfh(cloud, s), Error) << radius;
  }
  const std::vector<std::size_t> out_of_range = {0, 3};
  EXPECT_THROW(compute_fpfh(cloud, {}, &out_of_range), Error);
  // every point NaN: nothing describable, no crash
  PointCloud all_nan;
  all_nan.points.assign(4, Vector3f::Constant(std::numeric_limits<float>::quiet_NaN()));
  all_nan.normals.assign(4, Vector3f::UnitZ());
  EXPECT_EQ(compute_fpfh(all_nan).num_invalid, 4u);
}

TEST(FpfhTest, Deterministic) {
  PLUMB_REQUIRE_DATA(path, "cloud3d/pcl_test/bunny.pcd");
  const PointCloud cloud = bunny_with_golden_normals();
  FpfhSettings s;
  s.radius = 0.03f;
  s.max_neighbors = 25;
  const FpfhResult a = compute_fpfh(cloud, s);
  const FpfhResult b = compute_fpfh(cloud, s);
  EXPECT_EQ(a.features, b.features);  // bit-identical
  EXPECT_EQ(a.num_invalid, b.num_invalid);
}

TEST(FpfhTest, ThreadsChangeNoSignature) {
  // Enough points for many chunks of searches and of signatures: three noisy walls of a corner
  // with their normals, a few invalid points among them; all points, then a subset with repeats.
  PointCloud cloud;
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(0.0f, 2.0f), e(-0.01f, 0.01f);
  for (int i = 0; i < 6000; ++i) {
    const int wall = i % 3;
    Vector3f p(u(rng), u(rng), u(rng));
    p[wall] = e(rng);
    Vector3f n = Vector3f::Zero();
    n[wall] = 1.0f;
    n += Vector3f(e(rng), e(rng), e(rng)) * 5.0f;
    cloud.points.push_back(p);
    cloud.normals.push_back(n.normalized());
  }
  cloud.points[17].x() = std::numeric_limits<float>::quiet_NaN();
  cloud.normals[4000] = Vector3f::Constant(std::numeric_limits<float>::quiet_NaN());
  std::vector<std::size_t> keys;
  for (std::size_t i = cloud.size(); i-- > 0;) {
    if (i % 5 == 1) keys.push_back(i);
  }
  keys.push_back(keys[3]);
  FpfhSettings s;
  s.radius = 0.15f;
  s.max_neighbors = 30;
  const FpfhResult one = compute_fpfh(cloud, s);
  const FpfhResult one_keys = compute_fpfh(cloud, s, &keys);
  EXPECT_EQ(one.num_invalid, 2u);
  for (const int threads : {2, 3, 8, 0}) {
    s.threads = threads;
    const FpfhResult many = compute_fpfh(cloud, s);
    EXPECT_EQ(many.features, one.features) << threads;  // bit-identical
    EXPECT_EQ(many.num_invalid, one.num_invalid) << threads;
    const FpfhResult many_keys = compute_fpfh(cloud, s, &keys);
    EXPECT_EQ(many_keys.features, one_keys.features) << threads;
    EXPECT_EQ(many_keys.indices, keys) << threads;
  }
  s.threads = -1;
  EXPECT_THROW(compute_fpfh(cloud, s), Error);
}

}  // namespace
}  // namespace plumb
