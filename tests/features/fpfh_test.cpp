// SPDX-License-Identifier: BSD-3-Clause
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include "plumb/core/rng.hpp"
#include "plumb/features/fpfh.hpp"
#include "plumb/features/normals.hpp"
#include "plumb/filters/voxel_grid.hpp"
#include "plumb/io/pcd.hpp"
#include "test_data.hpp"

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
  const std::string path = std::string(PLUMB_SOURCE_DIR) + "/tests/features/golden/bunny_open3d_fpfh.txt";
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

}  // namespace
}  // namespace plumb
