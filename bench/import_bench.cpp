// SPDX-License-Identifier: BSD-3-Clause
// `plumb import`'s reading: a ROS 1 bag of uncompressed chunks read with io::BagReader from a file
// (page cache warm after the first run) and every sensor_msgs/PointCloud2 decoded into a
// PointCloud, single thread. The bag is built here: 40 sweeps of a 16-line LiDAR (1800 columns, 28800
// points) in velodyne_pointcloud's PointXYZIRT layout (x y z, padding, intensity, ring, time; 32
// bytes a point), one message per chunk, about 37 MB. Bytes/s is of the bag file. The same sweeps as
// sensor_msgs/msg/PointCloud2 in CDR in an MCAP file (uncompressed chunks with their CRC32, one
// message per chunk, a summary of chunk indexes) read with io::McapReader.
#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include "plumb/io/mcap.hpp"
#include "plumb/io/ros_messages.hpp"
#include "plumb/io/rosbag.hpp"
#include "mcap_builder.hpp"
#include "rosbag_builder.hpp"

namespace {

constexpr int kFrames = 40, kColumns = 1800, kRings = 16;

std::string velodyne_points(int frame) {
  std::string data;
  data.reserve(std::size_t{kColumns} * kRings * 32);
  for (int c = 0; c < kColumns; ++c) {
    const double az = 2.0 * M_PI * c / kColumns;
    for (int r = 0; r < kRings; ++r) {
      const double el = (-15.0 + 2.0 * r) * M_PI / 180.0, range = 5.0 + 0.001 * ((c * 7 + r * 13 + frame) % 1000);
      plumb::test::RosWriter p;
      p.put(static_cast<float>(range * std::cos(el) * std::cos(az)))
          .put(static_cast<float>(range * std::cos(el) * std::sin(az)))
          .put(static_cast<float>(range * std::sin(el)))
          .put(1.0f)
          .put(static_cast<float>((c + r) % 256))
          .put(static_cast<std::uint16_t>(r))
          .put<std::uint16_t>(0)
          .put(static_cast<float>(0.1 * c / kColumns))
          .put<std::uint32_t>(0);
      data += p.s;
    }
  }
  return data;
}

std::string velodyne_sweep(int frame) {
  const std::string data = velodyne_points(frame);
  return plumb::test::ros_point_cloud2(100 + frame / 10, (frame % 10) * 100000000, 1, kColumns * kRings,
                                       {{"x", 0, 7}, {"y", 4, 7}, {"z", 8, 7}, {"intensity", 16, 7}, {"ring", 20, 4},
                                        {"time", 24, 7}},
                                       false, 32, 32 * kColumns * kRings, data);
}

const std::string& bag_path() {
  static const std::string path = [] {
    std::vector<plumb::test::BagBuilderMessage> messages;
    for (int f = 0; f < kFrames; ++f) {
      messages.push_back({0, static_cast<std::uint32_t>(100 + f / 10), static_cast<std::uint32_t>((f % 10) * 100000000),
                          velodyne_sweep(f)});
    }
    const std::string p = "/tmp/plumb_import_bench.bag";
    std::ofstream(p, std::ios::binary) << plumb::test::build_bag(
        {{"/velodyne_points", "sensor_msgs/PointCloud2", plumb::io::kRosPointCloud2Md5}}, messages, 1);
    return p;
  }();
  return path;
}

void BM_ImportBag(benchmark::State& state) {
  const std::string& path = bag_path();
  std::uint64_t bytes = 0;
  std::size_t points = 0;
  for (auto _ : state) {
    const plumb::io::BagReader bag(path);
    bytes = bag.file_size();
    points = 0;
    bag.read({0}, [&](const plumb::io::BagMessage& m) {
      const plumb::io::RosPointCloud2 pc = plumb::io::decode_point_cloud2(m.data, m.size);
      points += pc.cloud.size();
      benchmark::DoNotOptimize(pc.cloud.points.data());
      return true;
    });
  }
  state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations() * bytes));
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * points));
}
BENCHMARK(BM_ImportBag)->Name("import_bag/plumb/velodyne_uncompressed")->Unit(benchmark::kMillisecond);

const std::string& mcap_path() {
  static const std::string path = [] {
    namespace t = plumb::test;
    std::string f = t::kMcapMagicBytes + t::mcap_header();
    std::string indexes;
    for (int frame = 0; frame < kFrames; ++frame) {
      const std::int32_t sec = 100 + frame / 10;
      const std::uint32_t nsec = static_cast<std::uint32_t>((frame % 10) * 100000000);
      const std::string cloud = t::cdr_point_cloud2(
          false, sec, nsec, 1, kColumns * kRings,
          {{"x", 0, 7}, {"y", 4, 7}, {"z", 8, 7}, {"intensity", 16, 7}, {"ring", 20, 4}, {"time", 24, 7}}, false, 32,
          32 * kColumns * kRings, velodyne_points(frame));
      const std::uint64_t time = static_cast<std::uint64_t>(sec) * 1000000000 + nsec;
      std::string records = frame == 0 ? t::mcap_schema(1, "sensor_msgs/msg/PointCloud2") + t::mcap_channel(1, 1, "/points") : "";
      records += t::mcap_message(1, time, cloud);
      const std::uint64_t pos = f.size();
      f += t::mcap_chunk(records, time, time);
      indexes += t::mcap_chunk_index(time, time, pos, f.size() - pos);
    }
    f += t::mcap_data_end();
    const std::uint64_t summary = f.size();
    f += t::mcap_schema(1, "sensor_msgs/msg/PointCloud2") + t::mcap_channel(1, 1, "/points") + indexes;
    f += t::mcap_footer(summary) + t::kMcapMagicBytes;
    const std::string p = "/tmp/plumb_import_bench.mcap";
    std::ofstream(p, std::ios::binary) << f;
    return p;
  }();
  return path;
}

void BM_ImportMcap(benchmark::State& state) {
  const std::string& path = mcap_path();
  std::uint64_t bytes = 0;
  std::size_t points = 0;
  for (auto _ : state) {
    const plumb::io::McapReader mcap(path);
    bytes = mcap.file_size();
    points = 0;
    mcap.read_topics({"/points"}, [&](const plumb::io::RecordedMessage& m) {
      const plumb::io::RosPointCloud2 pc = plumb::io::decode_point_cloud2(m.data, m.size, m.serialization);
      points += pc.cloud.size();
      benchmark::DoNotOptimize(pc.cloud.points.data());
      return true;
    });
  }
  state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations() * bytes));
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * points));
}
BENCHMARK(BM_ImportMcap)->Name("import_mcap/plumb/velodyne_uncompressed")->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
