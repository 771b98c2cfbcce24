// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/io/kitti_bin.hpp"

#include <cstring>
#include <string>
#include <vector>

#include "detail_cloud_io.hpp"

namespace plumb::io {

PointCloud read_kitti_bin_buffer(const char* data, std::size_t size, const std::string& name) {
  constexpr std::size_t kRecord = 4 * sizeof(float);
  if (size % kRecord != 0) {
    PLUMB_THROW(name << ": byte " << size - size % kRecord << ": size " << size
                     << " is not a multiple of the 16-byte x y z intensity record (truncated file?)");
  }
  const std::size_t n = size / kRecord;
  PointCloud cloud;
  cloud.points.resize(n);
  cloud.intensities.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    float r[4];
    std::memcpy(r, data + i * kRecord, kRecord);
    cloud.points[i] = Vector3f(r[0], r[1], r[2]);
    cloud.intensities[i] = r[3];
  }
  return cloud;
}

PointCloud read_kitti_bin(const std::string& path) {
  const std::vector<char> data = cloud_detail::slurp_file(path);
  return read_kitti_bin_buffer(data.data(), data.size(), path);
}

void write_kitti_bin(const std::string& path, const PointCloud& cloud) {
  try {
    cloud.check_consistent("write_kitti_bin");
  } catch (const Error& e) {
    PLUMB_THROW(path << ": " << e.what());
  }
  const std::size_t n = cloud.size();
  std::vector<float> buf(4 * n);
  for (std::size_t i = 0; i < n; ++i) {
    buf[4 * i + 0] = cloud.points[i].x();
    buf[4 * i + 1] = cloud.points[i].y();
    buf[4 * i + 2] = cloud.points[i].z();
    buf[4 * i + 3] = cloud.has_intensities() ? cloud.intensities[i] : 0.0f;
  }
  cloud_detail::write_file(path, reinterpret_cast<const char*>(buf.data()), buf.size() * sizeof(float));
}

}  // namespace plumb::io
