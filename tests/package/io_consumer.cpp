// SPDX-License-Identifier: BSD-3-Clause
// Links plumb::io: a compressed binary PCD (LZF) written and read back.
#include <cstdio>
#include <filesystem>
#include <string>

#include <plumb/io/pcd.hpp>

int main() {
  plumb::PointCloud cloud;
  for (int i = 0; i < 500; ++i) cloud.points.emplace_back(0.01f * static_cast<float>(i), 1.0f, -0.5f);
  const std::string path = (std::filesystem::temp_directory_path() / "plumb_io_consumer.pcd").string();
  plumb::io::PcdWriteSettings pcd;
  pcd.encoding = plumb::io::PcdEncoding::kBinaryCompressed;
  plumb::io::write_pcd(path, cloud, pcd);
  const plumb::PointCloud back = plumb::io::read_pcd(path);
  std::filesystem::remove(path);
  const bool ok = back.size() == cloud.size() && back.points[123] == cloud.points[123];
  std::printf("plumb::io: pcd round trip %s\n", ok ? "ok" : "FAILED");
  return ok ? 0 : 1;
}
