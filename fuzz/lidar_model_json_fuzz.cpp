// SPDX-License-Identifier: BSD-3-Clause
// libFuzzer target for the LiDAR model file of `plumb simulate --lidar FILE.json`
// (sim::parse_lidar_model): any input must either give a model that passes LidarModel::validate()
// or throw plumb::Error naming the input. Seeds: fuzz/seeds/lidar_model_json.
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "plumb/core/error.hpp"
#include "plumb/sim/lidar_model_json.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    const plumb::sim::LidarModel m = plumb::sim::parse_lidar_model(text, "fuzz.json");
    m.validate();  // what the reader returned must be a usable model
  } catch (const plumb::Error& e) {
    if (std::string(e.what()).rfind("fuzz.json: ", 0) != 0) {
      std::fprintf(stderr, "lidar_model_json_fuzz: error does not name the input: %s\n", e.what());
      std::abort();
    }
  }
  return 0;
}
