// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/io/kitti_bin.hpp"

#include <gtest/gtest.h>

#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "plumb/io/cloud_io.hpp"
#include "test_data.hpp"

namespace plumb::io {
namespace {

using plumb::test::temp_path;

void write_bytes(const std::string& path, const std::string& bytes) {
  std::FILE* f = std::fopen(path.c_str(), "wb");
  ASSERT_NE(f, nullptr);
  std::fwrite(bytes.data(), 1, bytes.size(), f);
  std::fclose(f);
}

std::string float_bytes(const std::vector<float>& v) {
  return std::string(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(float));
}

TEST(KittiBinTest, ReadsHandBuiltRecords) {
  const std::string file = temp_path("kitti_hand.bin");
  write_bytes(file, float_bytes({1.0f, 2.0f, 3.0f, 0.25f, -4.5f, 5.5f, -6.0f, 1.0f}));
  const PointCloud c = read_kitti_bin(file);
  ASSERT_EQ(c.size(), 2u);
  ASSERT_TRUE(c.has_intensities());
  EXPECT_EQ(c.points[0], Vector3f(1, 2, 3));
  EXPECT_EQ(c.points[1], Vector3f(-4.5f, 5.5f, -6.0f));
  EXPECT_EQ(c.intensities[0], 0.25f);
  EXPECT_EQ(c.intensities[1], 1.0f);
  std::remove(file.c_str());
}

TEST(KittiBinTest, RoundTripIsExact) {
  PointCloud c;
  for (int i = 0; i < 100; ++i) {
    c.points.emplace_back(0.1f * static_cast<float>(i), -1e-7f * static_cast<float>(i), 1e6f + static_cast<float>(i));
    c.intensities.push_back(static_cast<float>(i) / 99.0f);
  }
  const std::string file = temp_path("kitti_roundtrip.bin");
  write_kitti_bin(file, c);
  const PointCloud r = read_kitti_bin(file);
  ASSERT_EQ(r.size(), c.size());
  for (std::size_t i = 0; i < c.size(); ++i) {
    EXPECT_EQ(r.points[i], c.points[i]);
    EXPECT_EQ(r.intensities[i], c.intensities[i]);
  }
  // Without intensities the format stores 0.
  c.intensities.clear();
  write_kitti_bin(file, c);
  const PointCloud z = read_kitti_bin(file);
  ASSERT_EQ(z.size(), 100u);
  EXPECT_EQ(z.intensities[50], 0.0f);
  std::remove(file.c_str());
}

TEST(KittiBinTest, SizeNotMultipleOf16Throws) {
  const std::string file = temp_path("kitti_bad.bin");
  for (std::size_t extra : {1u, 4u, 15u}) {
    write_bytes(file, float_bytes({1, 2, 3, 4}) + std::string(extra, '\0'));
    try {
      read_kitti_bin(file);
      ADD_FAILURE() << "expected plumb::Error";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(file), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("16"), std::string::npos) << e.what();
    }
  }
  std::remove(file.c_str());
}

TEST(KittiBinTest, EmptyAndMissingFiles) {
  const std::string file = temp_path("kitti_empty.bin");
  write_bytes(file, "");
  EXPECT_TRUE(read_kitti_bin(file).empty());
  std::remove(file.c_str());
  EXPECT_THROW(read_kitti_bin("/nonexistent/0000.bin"), Error);
  PointCloud bad;
  bad.points.resize(3);
  bad.intensities.resize(2);
  EXPECT_THROW(write_kitti_bin(temp_path("kitti_inconsistent.bin"), bad), Error);
}

TEST(CloudIoTest, DispatchesOnExtension) {
  PointCloud c;
  for (int i = 0; i < 20; ++i) {
    c.points.emplace_back(static_cast<float>(i), 0.5f, -static_cast<float>(i));
    c.intensities.push_back(static_cast<float>(i));
  }
  for (const char* name : {"cloud_io.pcd", "cloud_io.PLY", "cloud_io.bin"}) {
    SCOPED_TRACE(name);
    const std::string file = temp_path(name);
    write_cloud(file, c);
    const PointCloud r = read_cloud(file);
    ASSERT_EQ(r.size(), c.size());
    EXPECT_EQ(r.points[7], c.points[7]);
    EXPECT_EQ(r.intensities[7], c.intensities[7]);
    std::remove(file.c_str());
  }
  // The .pcd is written compressed: PCL's binary_compressed header line is there.
  const std::string pcd = temp_path("cloud_io_check.pcd");
  write_cloud(pcd, c);
  std::FILE* f = std::fopen(pcd.c_str(), "rb");
  ASSERT_NE(f, nullptr);
  char buf[512] = {};
  const std::size_t got = std::fread(buf, 1, sizeof(buf) - 1, f);
  std::fclose(f);
  EXPECT_NE(std::string(buf, got).find("DATA binary_compressed"), std::string::npos);
  std::remove(pcd.c_str());
  EXPECT_THROW(read_cloud(temp_path("cloud.xyz")), Error);
  EXPECT_THROW(write_cloud(temp_path("cloud"), c), Error);
  EXPECT_THROW(read_cloud("/some.dir/noext"), Error);
}

}  // namespace
}  // namespace plumb::io
