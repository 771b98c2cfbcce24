// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/io/recording.hpp"

#include <algorithm>
#include <cstring>
#include <fstream>

#include "plumb/core/error.hpp"
#include "plumb/io/input_file.hpp"
#include "plumb/io/mcap.hpp"
#include "plumb/io/rosbag.hpp"

namespace plumb::io {

std::string ros1_type_name(const std::string& type) {
  const std::size_t slash = type.find('/');
  if (slash != std::string::npos && type.compare(slash, 5, "/msg/") == 0) {
    return type.substr(0, slash) + type.substr(slash + 4);
  }
  return type;
}

std::unique_ptr<Recording> open_recording(const std::string& path) {
  char head[16] = {};
  std::size_t n = 0;
  {
    std::ifstream in = open_input_file(path);
    in.read(head, sizeof(head));
    n = static_cast<std::size_t>(in.gcount());
  }
  // The MCAP magic, or as much of it as a truncated file holds.
  if (n > 0 && std::memcmp(head, kMcapMagic, std::min(n, kMcapMagicSize)) == 0) return std::make_unique<McapReader>(path);
  PLUMB_CHECK(std::memcmp(head, "SQLite format 3", 16) != 0,
              path << ": offset 0: a ROS 2 bag in sqlite3 (.db3), which plumb does not read; convert it to MCAP "
                      "with `ros2 bag convert` (storage_id: mcap) and import the .mcap file");
  return std::make_unique<BagReader>(path);  // a ROS 1 bag, or its error message
}

}  // namespace plumb::io
