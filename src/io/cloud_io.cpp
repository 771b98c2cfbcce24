// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/io/cloud_io.hpp"

#include <cctype>
#include <string>

#include "plumb/io/kitti_bin.hpp"
#include "plumb/io/pcd.hpp"
#include "plumb/io/ply.hpp"

namespace plumb::io {
namespace {

std::string lower_extension(const std::string& path) {
  const std::size_t slash = path.find_last_of('/');
  const std::size_t dot = path.find_last_of('.');
  if (dot == std::string::npos || (slash != std::string::npos && dot < slash)) return "";
  std::string ext = path.substr(dot + 1);
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return ext;
}

}  // namespace

PointCloud read_cloud(const std::string& path) {
  const std::string ext = lower_extension(path);
  if (ext == "pcd") return read_pcd(path);
  if (ext == "ply") return read_ply(path);
  if (ext == "bin") return read_kitti_bin(path);
  PLUMB_THROW(path << ": unknown point-cloud extension (expected .pcd, .ply or .bin)");
}

void write_cloud(const std::string& path, const PointCloud& cloud) {
  const std::string ext = lower_extension(path);
  if (ext == "pcd") {
    PcdWriteSettings settings;
    settings.encoding = PcdEncoding::kBinaryCompressed;
    return write_pcd(path, cloud, settings);
  }
  if (ext == "ply") return write_ply(path, cloud);
  if (ext == "bin") return write_kitti_bin(path, cloud);
  PLUMB_THROW(path << ": unknown point-cloud extension (expected .pcd, .ply or .bin)");
}

}  // namespace plumb::io
